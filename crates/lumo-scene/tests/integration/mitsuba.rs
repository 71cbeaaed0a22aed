//! Mitsuba 3 XML loading: structure, values, transforms, materials, emitters and errors.

use crate::common;

use common::{load, load_strict, mitsuba, scenes, temp_dir, write};
use lumo_scene::load::{load_scene, LoadError, LoadOptions};
use lumo_scene::{BsdfSpec, Distribution, FovAxis, Light, Mat4, Roughness, Texture, Vec2, Vec3};

#[test]
fn cornell_xml_is_the_builtin_cornell_exactly() {
    let loaded = load(&scenes().join("cornell.xml")).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let builtin = lumo_scene::builtin_scene("cornell").unwrap();
    let s = &loaded.scene;
    assert_eq!(s.meshes.len(), builtin.meshes.len());
    for (a, b) in s.meshes.iter().zip(&builtin.meshes) {
        assert_eq!(a.positions, b.positions, "{}", b.name);
        assert_eq!(a.normals, b.normals, "{}", b.name);
        assert_eq!(a.uvs, b.uvs, "{}", b.name);
        assert_eq!(a.indices, b.indices, "{}", b.name);
        assert_eq!(a.material, b.material, "{}", b.name);
    }
    for (a, b) in s.materials.iter().zip(&builtin.materials) {
        assert_eq!(a.emission, b.emission);
        assert_eq!(format!("{:?}", a.bsdf), format!("{:?}", b.bsdf));
    }
    assert_eq!(s.camera.origin, builtin.camera.origin);
    assert_eq!(s.camera.target, builtin.camera.target);
    assert_eq!(s.camera.up, builtin.camera.up);
    assert_eq!(s.camera.fov, builtin.camera.fov);
    assert_eq!(s.camera.fov_axis, FovAxis::Smaller);
    assert_eq!(loaded.settings.spp, Some(16));
    assert_eq!(loaded.settings.max_depth, Some(8));
    assert_eq!(loaded.settings.rr_depth, Some(5));
    assert_eq!(loaded.settings.size, Some((512, 512)));
}

#[test]
fn command_line_definitions_override_defaults() {
    let options = LoadOptions {
        defines: vec![("spp".into(), "64".into()), ("res".into(), "128".into())],
        ..Default::default()
    };
    let loaded = load_scene(&scenes().join("cornell.xml"), &options).unwrap();
    assert_eq!(loaded.settings.spp, Some(64));
    assert_eq!(loaded.settings.size, Some((128, 128)));
    assert_eq!(loaded.settings.max_depth, Some(8));
}

#[test]
fn undefined_parameter_names_the_line_and_the_fix() {
    let dir = temp_dir("undefined");
    let p = write(
        &dir,
        "s.xml",
        mitsuba("<shape type=\"sphere\">\n<float name=\"radius\" value=\"$r\"/></shape>"),
    );
    let e = load(&p).unwrap_err().to_string();
    assert!(e.contains("s.xml:4"), "{e}");
    assert!(
        e.contains("$r is not defined") && e.contains("-D r="),
        "{e}"
    );
}

#[test]
fn include_relative_paths_textures_and_spectra() {
    let loaded = load(&scenes().join("materials.xml")).unwrap();
    let s = &loaded.scene;
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    // Mitsuba ignores PLY vertex colours (they need a mesh_attribute texture); so does lumo.
    assert!(s.meshes.iter().all(|m| m.colors.is_empty()));
    assert_eq!(loaded.settings.spp, Some(16));
    assert_eq!(loaded.settings.seed, Some(7));
    assert_eq!(loaded.settings.size, Some((320, 240)));
    // The floor (from the included file) has the bitmap, tiled 4× by to_uv.
    let floor = s
        .materials
        .iter()
        .find(|m| m.name == "floor")
        .expect("floor material");
    match &floor.bsdf {
        BsdfSpec::Diffuse {
            reflectance: Texture::Transformed { texture, uv },
        } => {
            assert!(matches!(**texture, Texture::Bitmap { .. }));
            assert_eq!(
                uv.transform_point2(lumo_scene::Vec2::ONE),
                lumo_scene::Vec2::splat(4.0)
            );
        }
        other => panic!("floor: {other:?}"),
    }
    // The wall's spectrum became a warm colour.
    let spectral = s
        .materials
        .iter()
        .find_map(|m| match &m.bsdf {
            BsdfSpec::Diffuse {
                reflectance: Texture::Constant(c),
            } if c.x > c.z && m.name == "diffuse" => Some(*c),
            _ => None,
        })
        .expect("spectral wall");
    assert!(spectral.x > 0.6 && spectral.z < 0.4, "{spectral}");
    let gold = s
        .materials
        .iter()
        .find(|m| matches!(&m.bsdf, BsdfSpec::Conductor { roughness, .. } if roughness.alpha_u == 0.2))
        .expect("gold");
    if let BsdfSpec::Conductor { eta, k, .. } = gold.bsdf {
        assert!(
            (eta - Vec3::new(0.143036, 0.375307, 1.44205))
                .abs()
                .max_element()
                < 1e-6
        );
        assert!((k - Vec3::new(3.983, 2.38556, 1.60336)).abs().max_element() < 1e-6);
    }
    assert!(s.lights.iter().any(|l| matches!(l, Light::Constant { .. })));
    assert!(s
        .materials
        .iter()
        .any(|m| m.emission == Vec3::new(12.0, 11.0, 10.0)));
}

fn first_mesh_positions(body: &str) -> Vec<Vec3> {
    let dir = temp_dir(&format!("tf{}", body.len()));
    let p = write(&dir, "t.xml", mitsuba(body));
    let loaded = load(&p).unwrap();
    let inst = &loaded.scene.instances[0];
    loaded.scene.meshes[inst.mesh]
        .positions
        .iter()
        .map(|p| inst.transform.transform_point3(*p))
        .collect()
}

#[test]
fn transform_operations_apply_in_order() {
    // Scale x by 2, then rotate 90° about z, then translate: (1, 1, 0) → (2, 1) → (−1, 2) →
    // (4, 2, 0).
    let p = first_mesh_positions(
        r#"<shape type="rectangle"><transform name="to_world">
            <scale x="2"/><rotate z="1" angle="90"/><translate x="5"/>
        </transform></shape>"#,
    );
    assert!(
        p.iter()
            .any(|v| (*v - Vec3::new(4.0, 2.0, 0.0)).length() < 1e-5),
        "{p:?}"
    );
    // The same as one row-major matrix.
    let m = first_mesh_positions(
        r#"<shape type="rectangle"><transform name="to_world">
            <matrix value="0 -1 0 5  2 0 0 0  0 0 1 0  0 0 0 1"/>
        </transform></shape>"#,
    );
    for (a, b) in p.iter().zip(&m) {
        assert!((*a - *b).length() < 1e-5, "{a} vs {b}");
    }
}

#[test]
fn lookat_camera_and_fov_axis() {
    let dir = temp_dir("lookat");
    let p = write(
        &dir,
        "c.xml",
        r#"<scene version="3.0.0"><sensor type="perspective">
            <float name="fov" value="30"/><string name="fov_axis" value="y"/>
            <transform name="to_world"><rotate y="1" angle="90"/><translate x="1"/></transform>
            <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="32"/></film>
        </sensor><shape type="cube"/><emitter type="constant"/></scene>"#,
    );
    let s = load(&p).unwrap();
    let cam = &s.scene.camera;
    assert_eq!(cam.fov_axis, FovAxis::Y);
    assert_eq!(cam.fov, 30.0);
    assert!((cam.origin - Vec3::X).length() < 1e-6);
    // Local +z rotated 90° about y is +x.
    assert!(((cam.target - cam.origin).normalize() - Vec3::X).length() < 1e-5);
    assert_eq!(s.settings.size, Some((64, 32)));
}

#[test]
fn material_presets_and_named_media() {
    let dir = temp_dir("presets");
    let p = write(
        &dir,
        "m.xml",
        mitsuba(
            r#"<shape type="cube"><bsdf type="conductor"><string name="material" value="Ag"/></bsdf></shape>
            <shape type="sphere"><bsdf type="dielectric"><string name="int_ior" value="water"/></bsdf></shape>
            <shape type="disk"><bsdf type="roughplastic"><string name="distribution" value="ggx"/>
              <float name="alpha" value="0.3"/><float name="int_ior" value="1.6"/><float name="ext_ior" value="1.0"/></bsdf></shape>
            <emitter type="constant"/>"#,
        ),
    );
    let s = load(&p).unwrap().scene;
    let bsdfs: Vec<&BsdfSpec> = s
        .meshes
        .iter()
        .map(|m| &s.materials[m.material].bsdf)
        .collect();
    match bsdfs[0] {
        BsdfSpec::Conductor { eta, k, roughness } => {
            assert_eq!(*eta, Vec3::new(0.155276, 0.116728, 0.138388));
            assert_eq!(*k, Vec3::new(4.82835, 3.12222, 2.1469));
            assert_eq!(*roughness, Roughness::SMOOTH);
        }
        other => panic!("{other:?}"),
    }
    match bsdfs[1] {
        BsdfSpec::Dielectric { ior, .. } => assert!((ior - 1.333 / 1.00028).abs() < 1e-6),
        other => panic!("{other:?}"),
    }
    match bsdfs[2] {
        BsdfSpec::Plastic { ior, roughness, .. } => {
            assert!((ior - 1.6).abs() < 1e-6);
            assert_eq!(*roughness, Roughness::ggx(0.3));
        }
        other => panic!("{other:?}"),
    }
    let bad = write(
        &dir,
        "bad.xml",
        mitsuba(
            r#"<shape type="cube"><bsdf type="conductor"><string name="material" value="Unobtainium"/></bsdf></shape>"#,
        ),
    );
    let e = load(&bad).unwrap_err().to_string();
    assert!(e.contains("Unobtainium") && e.contains("Au"), "{e}");
}

#[test]
fn unknown_plugins_and_parameters_warn_with_line_or_fail_in_strict_mode() {
    let dir = temp_dir("unknown");
    let p = write(
        &dir,
        "u.xml",
        mitsuba(
            "<shape type=\"cube\">\n  <float name=\"wobble\" value=\"1\"/>\n</shape>\n<shape type=\"hyperboloid\"/>\n<emitter type=\"constant\"/>",
        ),
    );
    let loaded = load(&p).unwrap();
    let text: Vec<String> = loaded.warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(text.len(), 2, "{text:?}");
    assert!(
        text[0].contains("u.xml:4") && text[0].contains("wobble"),
        "{text:?}"
    );
    assert!(
        text[1].contains("u.xml:6") && text[1].contains("hyperboloid"),
        "{text:?}"
    );
    assert_eq!(loaded.scene.meshes.len(), 1, "the unknown shape is skipped");
    match load_strict(&p).unwrap_err() {
        LoadError::Strict { at, message } => {
            assert_eq!(at.line, Some(4));
            assert!(message.contains("wobble"));
        }
        other => panic!("{other}"),
    }
}

#[test]
fn approximations_are_reported() {
    let dir = temp_dir("approx");
    let p = write(
        &dir,
        "a.xml",
        mitsuba(
            r#"<shape type="cube"><bsdf type="principled"><rgb name="base_color" value="0.8, 0.1, 0.1"/>
                <float name="metallic" value="0"/><float name="roughness" value="0.5"/><float name="clearcoat" value="1"/></bsdf></shape>
               <shape type="sphere"><bsdf type="roughconductor"/></shape>
               <shape type="disk"><bsdf type="thindielectric"/></shape>
               <emitter type="constant"/>"#,
        ),
    );
    let loaded = load(&p).unwrap();
    let all: String = loaded.warnings.iter().map(|w| format!("{w}\n")).collect();
    // principled is Mitsuba's own model now, not an approximation.
    assert!(!all.contains("principled"), "{all}");
    // Beckmann (Mitsuba's default distribution) is rendered as such: nothing to report.
    assert!(!all.contains("beckmann"), "{all}");
    let rough = &loaded.scene.materials[loaded.scene.meshes[1].material].bsdf;
    assert!(
        matches!(
            rough,
            BsdfSpec::Conductor { roughness, .. } if *roughness == Roughness {
                distribution: Distribution::Beckmann,
                alpha_u: 0.1,
                alpha_v: 0.1,
                maps: None,
            }
        ),
        "{rough:?}"
    );
    // A thin sheet is its own BSDF, not an approximation.
    assert!(!all.contains("thindielectric"), "{all}");
    let s = &loaded.scene;
    assert!(matches!(
        s.materials[s.meshes[2].material].bsdf,
        BsdfSpec::ThinDielectric { ior } if (ior - 1.5046 / 1.00028).abs() < 1e-6
    ));
    assert!(matches!(
        &s.materials[s.meshes[0].material].bsdf,
        BsdfSpec::Principled(p) if matches!(p.clearcoat, Texture::Constant(c) if c == Vec3::ONE)
    ));
}

#[test]
fn emitters() {
    let dir = temp_dir("emitters");
    let env = dir.join("sky.pfm");
    lumo_image::write_image(&env, &lumo_image::Image::new(8, 4, 3, 0.5)).unwrap();
    let p = write(
        &dir,
        "e.xml",
        mitsuba(
            r#"<shape type="cube"/>
            <emitter type="point"><point name="position" x="1" y="2" z="3"/><rgb name="intensity" value="5"/></emitter>
            <emitter type="spot"><transform name="to_world"><lookat origin="0,4,0" target="0,0,0" up="0,0,1"/></transform>
               <float name="cutoff_angle" value="30"/></emitter>
            <emitter type="directional"><vector name="direction" x="0" y="-2" z="0"/></emitter>
            <emitter type="envmap"><string name="filename" value="sky.pfm"/><float name="scale" value="2"/></emitter>"#,
        ),
    );
    let s = load(&p).unwrap().scene;
    assert_eq!(s.lights.len(), 4);
    assert!(
        matches!(s.lights[0], Light::Point { position, intensity, range: None }
        if position == Vec3::new(1.0, 2.0, 3.0) && intensity == Vec3::splat(5.0))
    );
    match &s.lights[1] {
        Light::Spot {
            position,
            direction,
            beam_width,
            cutoff,
            falloff,
            ..
        } => {
            assert_eq!(*falloff, lumo_scene::SpotFalloff::LinearAngle);
            assert!((*position - Vec3::new(0.0, 4.0, 0.0)).length() < 1e-6);
            assert!((*direction + Vec3::Y).length() < 1e-5, "{direction}");
            assert_eq!((*beam_width, *cutoff), (22.5, 30.0));
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(s.lights[2], Light::Directional { direction, .. } if direction == -Vec3::Y));
    assert!(
        matches!(&s.lights[3], Light::Environment(e) if e.scale == 2.0 && e.to_world == Mat4::IDENTITY)
    );
}

#[test]
fn bad_input_is_a_clear_error() {
    let dir = temp_dir("bad");
    let cases: &[(&str, String, &[&str])] = &[
        ("malformed.xml", "<scene version=\"3.0.0\">\n<shape type=\"cube\">\n</scene>".into(), &["malformed.xml:", "malformed XML"]),
        ("root.xml", "<bsdf type=\"diffuse\"/>".into(), &["root element is <bsdf>"]),
        ("ref.xml", mitsuba("<shape type=\"cube\"><ref id=\"nope\"/></shape>"), &["ref.xml:3", "nope"]),
        ("include.xml", mitsuba("<include filename=\"missing.xml\"/>"), &["include.xml:3", "missing.xml"]),
        ("obj.xml", mitsuba("<shape type=\"obj\"><string name=\"filename\" value=\"gone.obj\"/></shape>"), &["gone.obj"]),
        ("nan.xml", mitsuba("<shape type=\"sphere\"><float name=\"radius\" value=\"nan\"/></shape>"), &["nan.xml:3", "not finite"]),
        ("rgb.xml", mitsuba("<shape type=\"cube\"><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"1, 2\"/></bsdf></shape>"), &["rgb.xml:3", "3 values"]),
        ("dup.xml", mitsuba("<bsdf type=\"diffuse\" id=\"a\"/>\n<bsdf type=\"diffuse\" id=\"a\"/>"), &["dup.xml:4", "already used at line 3"]),
        ("cycle.xml", mitsuba("<include filename=\"cycle.xml\"/>"), &["recurse"]),
    ];
    for (name, text, needles) in cases {
        let p = write(&dir, name, text);
        let e = load(&p).unwrap_err().to_string();
        for n in *needles {
            assert!(e.contains(n), "{name}: {e:?} lacks {n:?}");
        }
    }
    let e = load(&dir.join("absent.xml")).unwrap_err().to_string();
    assert!(e.contains("absent.xml") && e.contains("cannot read"), "{e}");
    let e = load(&dir.join("scene.blend")).unwrap_err().to_string();
    assert!(e.contains("unknown scene format"), "{e}");
}

#[test]
fn zero_area_light_and_no_emitters_warn() {
    let dir = temp_dir("zero");
    let p = write(
        &dir,
        "z.xml",
        mitsuba(
            r#"<shape type="rectangle"><transform name="to_world"><scale x="0"/></transform>
            <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#,
        ),
    );
    let loaded = load(&p).unwrap();
    let all: String = loaded.warnings.iter().map(|w| format!("{w}\n")).collect();
    assert!(all.contains("degenerate"), "{all}");
    assert!(
        all.contains("no emitters") || all.contains("zero area"),
        "{all}"
    );
}

#[test]
fn default_bsdf_is_grey_but_black_on_emitters() {
    // Mitsuba 3 gives a shape without a BSDF diffuse 0.5, and an emitting one diffuse 0:
    // with 0.5 a light would also reflect, and the scene around it came out brighter than
    // Mitsuba's (docs/mitsuba-materials.md).
    let dir = temp_dir("default-bsdf");
    let p = write(
        &dir,
        "d.xml",
        mitsuba(
            r#"<shape type="cube"/>
            <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="2"/></emitter></shape>
            <shape type="disk"><bsdf type="diffuse"><rgb name="reflectance" value="0.3"/></bsdf>
                <emitter type="area"><rgb name="radiance" value="2"/></emitter></shape>"#,
        ),
    );
    let s = load(&p).unwrap().scene;
    let reflectance = |mesh: usize| match &s.materials[s.meshes[mesh].material].bsdf {
        BsdfSpec::Diffuse {
            reflectance: Texture::Constant(c),
        } => *c,
        other => panic!("{other:?}"),
    };
    assert_eq!(reflectance(0), Vec3::splat(0.5));
    assert_eq!(reflectance(1), Vec3::ZERO);
    assert_eq!(reflectance(2), Vec3::splat(0.3));
}

#[test]
fn microfacet_distribution_and_anisotropic_alpha_are_kept() {
    let dir = temp_dir("microfacet");
    let p = write(
        &dir,
        "m.xml",
        mitsuba(
            r#"<shape type="cube"><bsdf type="roughconductor"><string name="distribution" value="GGX"/>
                <float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.35"/></bsdf></shape>
               <shape type="sphere"><bsdf type="roughdielectric"><float name="alpha" value="0.2"/></bsdf></shape>
               <shape type="disk"><bsdf type="roughplastic"><boolean name="nonlinear" value="true"/></bsdf></shape>
               <emitter type="constant"/>"#,
        ),
    );
    let loaded = load(&p).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let s = &loaded.scene;
    let bsdf = |i: usize| &s.materials[s.meshes[i].material].bsdf;
    assert!(matches!(
        bsdf(0),
        BsdfSpec::Conductor { roughness, .. } if *roughness == Roughness {
            distribution: Distribution::Ggx,
            alpha_u: 0.05,
            alpha_v: 0.35,
            maps: None,
        }
    ));
    assert!(matches!(
        bsdf(1),
        BsdfSpec::Dielectric { roughness, .. } if *roughness == Roughness {
            distribution: Distribution::Beckmann,
            alpha_u: 0.2,
            alpha_v: 0.2,
            maps: None,
        }
    ));
    assert!(matches!(
        bsdf(2),
        BsdfSpec::Plastic { roughness, nonlinear: true, exact_rough_coat: true, .. }
            if roughness.distribution == Distribution::Beckmann && roughness.alpha_u == 0.1
    ));
    // What Mitsuba refuses, lumo refuses too, naming the fix.
    for (name, body) in [
        (
            "aniso_plastic.xml",
            r#"<float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.3"/>"#,
        ),
        ("one_axis.xml", r#"<float name="alpha_u" value="0.1"/>"#),
        (
            "bad_distribution.xml",
            r#"<string name="distribution" value="phong"/>"#,
        ),
    ] {
        let p = write(
            &dir,
            name,
            mitsuba(&format!(
                r#"<shape type="cube"><bsdf type="roughplastic">{body}</bsdf></shape>"#
            )),
        );
        let err = load(&p).unwrap_err().to_string();
        assert!(
            err.contains("alpha") || err.contains("distribution"),
            "{name}: {err}"
        );
    }
}

#[test]
fn textured_alpha_is_kept_per_texel_except_on_roughplastic() {
    let dir = temp_dir("alpha_texture");
    let p = write(
        &dir,
        "a.xml",
        mitsuba(
            r#"<shape type="cube"><bsdf type="roughconductor">
                <texture type="checkerboard" name="alpha"><rgb name="color0" value="0.1"/><rgb name="color1" value="0.5"/></texture></bsdf></shape>
               <shape type="sphere"><bsdf type="roughdielectric">
                <texture type="checkerboard" name="alpha_u"><rgb name="color0" value="0.1"/><rgb name="color1" value="0.5"/></texture>
                <float name="alpha_v" value="0.2"/></bsdf></shape>
               <shape type="disk"><bsdf type="roughplastic">
                <texture type="checkerboard" name="alpha"><rgb name="color0" value="0.1"/><rgb name="color1" value="0.5"/></texture></bsdf></shape>
               <emitter type="constant"/>"#,
        ),
    );
    let loaded = load(&p).unwrap();
    let s = &loaded.scene;
    let roughness = |i: usize| match &s.materials[s.meshes[i].material].bsdf {
        BsdfSpec::Conductor { roughness, .. }
        | BsdfSpec::Dielectric { roughness, .. }
        | BsdfSpec::Plastic { roughness, .. } => roughness.clone(),
        other => panic!("unexpected {other:?}"),
    };
    // Mitsuba's checkerboard: color0 where floor(2u) + floor(2v) is even.
    let (conductor, dielectric, plastic) = (roughness(0), roughness(1), roughness(2));
    assert!(!conductor.is_anisotropic());
    assert_eq!(conductor.alpha_at(Vec2::new(0.25, 0.25)), (0.1, 0.1));
    assert_eq!(conductor.alpha_at(Vec2::new(0.75, 0.25)), (0.5, 0.5));
    assert!(
        (conductor.alpha_u - 0.3).abs() < 1e-6,
        "the average stands for the map"
    );
    assert!(dielectric.is_anisotropic());
    assert_eq!(dielectric.alpha_at(Vec2::new(0.75, 0.25)), (0.5, 0.2));
    // roughplastic takes a number only: the map's average, with a warning naming the slot.
    assert!(plastic.maps.is_none());
    assert!((plastic.alpha_u - 0.3).abs() < 1e-6);
    assert_eq!(loaded.warnings.len(), 1, "{:?}", loaded.warnings);
    assert!(loaded.warnings[0]
        .to_string()
        .contains("roughplastic takes alpha as a number"));
}

#[test]
fn shapegroup_meshes_are_shared_by_its_instances() {
    let dir = temp_dir("shapegroup");
    let p = write(
        &dir,
        "g.xml",
        mitsuba(
            r#"<shape type="rectangle" id="floor"/>
               <shape type="shapegroup" id="pair">
                 <shape type="cube"><transform name="to_world"><translate y="2"/></transform></shape>
                 <shape type="sphere"><emitter type="area"><rgb name="radiance" value="3"/></emitter></shape>
               </shape>
               <shape type="instance"><ref id="pair"/></shape>
               <shape type="instance"><ref id="pair"/><transform name="to_world"><translate x="5"/></transform></shape>
               <shape type="instance"><ref id="pair"/><transform name="to_world"><scale value="2"/></transform></shape>"#,
        ),
    );
    let loaded = load_strict(&p).unwrap();
    let s = &loaded.scene;
    // The floor, then the group's two shapes converted once each.
    assert_eq!(s.meshes.len(), 3);
    // The cube keeps its own to_world inside the group.
    assert!(s.meshes[1].positions.iter().all(|p| p.y >= 1.0 - 1e-6));
    // The floor once, then one instance per (instance, shape of the group).
    assert_eq!(s.instances.len(), 1 + 3 * 2);
    let placed: Vec<(usize, Mat4)> = s.instances.iter().map(|i| (i.mesh, i.transform)).collect();
    let shift = Mat4::from_translation(Vec3::new(5.0, 0.0, 0.0));
    let scale = Mat4::from_scale(Vec3::splat(2.0));
    assert_eq!(
        placed,
        [
            (0, Mat4::IDENTITY),
            (1, Mat4::IDENTITY),
            (2, Mat4::IDENTITY),
            (1, shift),
            (2, shift),
            (1, scale),
            (2, scale),
        ]
    );
    // Emitters inside a group stay emissive in every instance (an extension: Mitsuba refuses
    // them).
    assert!(s.materials[s.meshes[2].material].is_emissive());
    s.validate().unwrap();

    // A group may hold no groups or instances, and an instance refers to a group.
    for bad in [
        r#"<shape type="shapegroup" id="g"><shape type="shapegroup"/></shape>"#,
        r#"<shape type="cube" id="c"/><shape type="instance"><ref id="c"/></shape>"#,
        r#"<shape type="instance"/>"#,
    ] {
        let p = write(&dir, "bad.xml", mitsuba(bad));
        assert!(load(&p).is_err(), "{bad}");
    }
}

/// What spectral rendering needs survives loading: `<spectrum>` pairs on a reflectance and an
/// area emitter, a conductor preset's measured spectra, a named glass's dispersion (through a
/// `twosided` wrapper too); RGB values leave the spectra empty.
#[test]
fn spectral_data_is_kept_for_spectral_rendering() {
    let dir =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/mitsuba/scenes");
    let emitters = load(&dir.join("spectral_emitters.xml")).unwrap().scene;
    let floor = &emitters.materials[emitters.meshes[0].material];
    let refl = floor
        .spectra
        .reflectance
        .as_ref()
        .expect("floor reflectance spectrum");
    assert!((refl.eval(540.0) - 0.15).abs() < 1e-6 && refl.eval(300.0) == 0.0);
    let narrow = emitters.materials.iter().find_map(|m| {
        m.spectra
            .emission
            .as_ref()
            .filter(|e| e.eval(460.0) == 30.0)
    });
    assert!(
        narrow.is_some(),
        "the narrow-band emitter keeps its spectrum"
    );
    let cube = &emitters.materials[emitters.meshes.last().unwrap().material];
    assert!(
        cube.spectra.reflectance.is_none(),
        "an RGB reflectance has no spectrum"
    );

    let conductors = load(&dir.join("spectral_conductors.xml")).unwrap().scene;
    let gold = conductors
        .materials
        .iter()
        .find_map(|m| m.spectra.conductor.as_ref())
        .expect("a conductor preset keeps its spectra");
    assert!(gold.1.eval(650.0) > 3.0);

    let glass = load(&dir.join("spectral_dispersion.xml")).unwrap().scene;
    let (bk7, exterior) = glass
        .materials
        .iter()
        .find_map(|m| m.spectra.dispersion)
        .expect("bk7 is dispersive");
    assert_eq!(bk7, lumo_spectrum::Glass::named("bk7").unwrap());
    assert!((exterior - 1.00028).abs() < 1e-6);
}
