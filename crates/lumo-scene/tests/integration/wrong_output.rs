//! Inputs that used to render silently wrong images with exit 0 (issue 49): each is now an
//! error or a warning naming the file and the field.

use crate::common;

use common::{load, temp_dir, write};

/// An emissive factor × strength that overflows f32 (or whose film sums of squares would)
/// rendered all black with exit 0; refused naming the material and the product.
#[test]
fn emission_beyond_what_the_film_can_sum_is_refused() {
    let dir = temp_dir("emission-overflow");
    let gltf = std::fs::read_to_string(common::scenes().join("hierarchy.gltf")).unwrap();
    let at = "\"name\": \"gold\",";
    assert!(
        gltf.contains(at),
        "the gold material is where the test expects it"
    );
    for (strength, says) in [("1e39", "not finite"), ("1e20", "too bright")] {
        let edited = gltf
            .replacen(
                at,
                &format!(
                    "{at} \"emissiveFactor\": [1, 1, 1], \"extensions\": \
                     {{\"KHR_materials_emissive_strength\": {{\"emissiveStrength\": {strength}}}}},"
                ),
                1,
            )
            .replacen(
                "\"KHR_lights_punctual\"\n",
                "\"KHR_lights_punctual\", \"KHR_materials_emissive_strength\"\n",
                1,
            );
        let e = load(&write(&dir, "bright.gltf", &edited))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bright.gltf")
                && e.contains("emissiveFactor × KHR_materials_emissive_strength")
                && e.contains(says),
            "{e}"
        );
    }
    let xml = common::mitsuba(
        r#"<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1e38"/></emitter></shape>"#,
    );
    let e = load(&write(&dir, "bright.xml", xml))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bright.xml:3")
            && e.contains("[1e38, 1e38, 1e38]")
            && e.contains("radiance")
            && e.contains("too bright"),
        "{e}"
    );
}

/// `mtllib /etc/shadow` echoed every line of that file to stderr (each line's first word
/// quoted as an unknown statement): a loader never quotes what is not a keyword, warns once
/// per kind of odd line, and keeps at most MAX_WARNINGS warnings per load.
#[test]
fn foreign_files_are_not_quoted_and_warnings_are_capped() {
    let dir = temp_dir("foreign-mtl");
    let shadow: String = (0..2000)
        .map(|i| format!("user{i}:$6$SECRETHASH{i}:19000:0:99999:7:::\n"))
        .collect();
    write(&dir, "shadow", shadow);
    let obj = "mtllib shadow\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let scene = load(&write(&dir, "a.obj", obj)).expect("loads");
    let w: Vec<String> = scene.warnings.iter().map(ToString::to_string).collect();
    let all = w.join("\n");
    assert!(
        !all.contains("SECRETHASH") && !all.contains("user1"),
        "{all}"
    );
    assert!(all.contains("not a statement"), "{all}");
    assert!(w.len() <= 3, "{all}");
    // Many distinct (keyword-like) statements: capped, with a count of the rest.
    let odd: String = (0..500).map(|i| format!("kw{i} 1 2\n")).collect();
    let scene = load(&write(
        &dir,
        "b.obj",
        format!("{}{odd}", &obj["mtllib shadow\n".len()..]),
    ))
    .expect("loads");
    let w: Vec<String> = scene.warnings.iter().map(ToString::to_string).collect();
    assert_eq!(w.len(), lumo_scene::load::MAX_WARNINGS + 1);
    assert!(
        w.last().unwrap().contains("400 more warning(s) not shown"),
        "{w:?}"
    );
}

/// `<spectrum value="550:0.5"/>` (meant as 0.5 everywhere) is one wavelength, zero at every
/// other: it rendered almost black without a word; now a warning names the element and the fix.
#[test]
fn a_single_wavelength_spectrum_is_warned_about() {
    let dir = temp_dir("one-pair");
    let body = r#"<bsdf type="diffuse" id="b"><spectrum name="reflectance" value="550:0.5"/></bsdf>
<shape type="rectangle"><ref id="b"/></shape>"#;
    let scene = load(&write(&dir, "one.xml", common::mitsuba(body))).expect("loads");
    let w: Vec<String> = scene.warnings.iter().map(ToString::to_string).collect();
    let all = w.join("\n");
    assert!(
        all.contains("one.xml:3")
            && all.contains("single pair 550:0.5")
            && all.contains("value=\"0.5\""),
        "{all}"
    );
    // Two pairs spanning the visible range are fine.
    let body = body.replace("550:0.5", "360:0.5, 830:0.5");
    let scene = load(&write(&dir, "two.xml", common::mitsuba(&body))).expect("loads");
    let w: Vec<String> = scene.warnings.iter().map(ToString::to_string).collect();
    assert!(!w.join("\n").contains("single pair"), "{w:?}");
}

/// Texels of 1e9–3e38 in a reflectance texture gave infinite radiance without a word: read
/// as 1, with a warning that counts them. The same file as a radiance texture is light and
/// keeps its values.
#[test]
fn a_reflectance_texture_above_one_is_bounded_with_a_warning() {
    let dir = temp_dir("bright-texture");
    let img = lumo_image::Image::from_vec(2, 1, 3, vec![0.5, 1e9, 0.25, 3e38, 0.1, 0.2]);
    lumo_image::write_image(&dir.join("hot.pfm"), &img).unwrap();
    let body = r#"<bsdf type="diffuse" id="b"><texture type="bitmap" name="reflectance"><string name="filename" value="hot.pfm"/></texture></bsdf>
<shape type="rectangle"><ref id="b"/></shape>"#;
    let scene = load(&write(&dir, "hot.xml", common::mitsuba(body))).expect("loads");
    let w: Vec<String> = scene.warnings.iter().map(ToString::to_string).collect();
    let all = w.join("\n");
    assert!(
        all.contains("hot.xml:3") && all.contains("2 value(s) above 1 (up to 3e38)"),
        "{all}"
    );
    let m = &scene.scene.materials[scene.scene.meshes[0].material];
    let lumo_scene::BsdfSpec::Diffuse {
        reflectance: lumo_scene::Texture::Bitmap { image, .. },
    } = &m.bsdf
    else {
        panic!("a diffuse bitmap: {:?}", m.bsdf);
    };
    assert!(image.data.iter().all(|&v| v <= 1.0), "{:?}", image.data);
}

/// A buffer view at byte 2^64 − 1 wrapped around the bounds check and loaded; at 2^64 the
/// message spoke of a "floating point" value. Both now say what is wrong with the number.
#[test]
fn gltf_offsets_near_2_64_are_reported_as_such() {
    let dir = temp_dir("offset-2-64");
    let tri =
        "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA";
    let gltf = |offset: &str| {
        format!(
            r#"{{"asset": {{"version": "2.0"}}, "buffers": [{{"byteLength": 36, "uri": "{tri}"}}],
"bufferViews": [{{"buffer": 0, "byteLength": 36, "byteOffset": {offset}}}],
"accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
  "min": [0, 0, 0], "max": [1, 1, 0]}}],
"meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
"nodes": [{{"mesh": 0}}], "scenes": [{{"nodes": [0]}}], "scene": 0}}"#
        )
    };
    let e = load(&write(&dir, "wrap.gltf", gltf("18446744073709551615")))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("wrap.gltf") && e.contains("reads past the end"),
        "{e}"
    );
    let e = load(&write(&dir, "big.gltf", gltf("18446744073709551616")))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("big.gltf") && e.contains("beyond 2^64 − 1") && !e.contains("floating"),
        "{e}"
    );
}

/// Messages that named the wrong thing: `focal_length 0mm` spoke of a 180° field of view; an
/// ASCII PLY vertex with extra values said the file had no faces.
#[test]
fn focal_length_and_extra_ply_values_are_named_as_written() {
    let dir = temp_dir("misleading");
    let xml = r#"<scene version="3.0.0">
<sensor type="perspective"><string name="focal_length" value="0mm"/></sensor>
<shape type="rectangle"/>
</scene>"#;
    let e = load(&write(&dir, "fl.xml", xml)).unwrap_err().to_string();
    assert!(
        e.contains("fl.xml:2") && e.contains("focal_length 0mm") && !e.contains("180"),
        "{e}"
    );
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
               end_header\n0 0 0 9 9\n1 0 0\n0 1 0\n3 0 1 2\n";
    let e = load(&write(&dir, "extra.ply", ply))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("extra.ply:10")
            && e.contains("vertex 0 has 2 value(s) more than the header's 3"),
        "{e}"
    );
}

/// Point, spot, directional, constant and environment lights were not held to the limit
/// emission has: an intensity of 1e38 (or a scale that overflows an environment's texels)
/// loaded and rendered black or Inf with exit 0. Each is refused naming the file and field.
#[test]
fn lights_beyond_what_the_film_can_sum_are_refused() {
    let dir = temp_dir("light-overflow");
    // A 1×1 PFM of radiance 1e30 for the environment.
    let mut pfm = b"PF\n1 1\n-1\n".to_vec();
    for _ in 0..3 {
        pfm.extend_from_slice(&1e30f32.to_le_bytes());
    }
    std::fs::write(dir.join("sky.pfm"), pfm).unwrap();
    for (emitter, field, says) in [
        (
            r#"<emitter type="point"><rgb name="intensity" value="1e16"/></emitter>"#,
            "intensity",
            "too bright",
        ),
        (
            r#"<emitter type="spot"><rgb name="intensity" value="3e38"/></emitter>"#,
            "intensity",
            "too bright",
        ),
        (
            r#"<emitter type="directional"><vector name="direction" x="0" y="-1" z="0"/><rgb name="irradiance" value="2e15"/></emitter>"#,
            "irradiance",
            "too bright",
        ),
        (
            r#"<emitter type="constant"><rgb name="radiance" value="1e20"/></emitter>"#,
            "radiance",
            "too bright",
        ),
        (
            r#"<emitter type="envmap"><string name="filename" value="sky.pfm"/><float name="scale" value="1e10"/></emitter>"#,
            "scale × brightest texel",
            "not finite",
        ),
        (
            r#"<emitter type="envmap"><string name="filename" value="sky.pfm"/><float name="scale" value="1e-14"/></emitter>"#,
            "scale × brightest texel",
            "too bright",
        ),
    ] {
        let e = load(&write(&dir, "bright.xml", common::mitsuba(emitter)))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bright.xml:3") && e.contains(field) && e.contains(says),
            "{emitter}: {e}"
        );
    }
    // At the limit's scale the environment loads (the check is not a blanket refusal).
    let ok = r#"<emitter type="envmap"><string name="filename" value="sky.pfm"/><float name="scale" value="1e-16"/></emitter>"#;
    load(&write(&dir, "ok.xml", common::mitsuba(ok))).expect("an environment of 1e14 loads");

    let gltf = std::fs::read_to_string(common::scenes().join("hierarchy.gltf")).unwrap();
    for (old, new, says) in [
        ("\"intensity\": 20", "\"intensity\": 1e39", "not finite"),
        ("\"intensity\": 30", "\"intensity\": 1e16", "too bright"),
    ] {
        assert!(gltf.contains(old), "hierarchy.gltf has {old}");
        let e = load(&write(&dir, "bright.gltf", gltf.replacen(old, new, 1)))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bright.gltf") && e.contains("intensity × color") && e.contains(says),
            "{new}: {e}"
        );
    }
}

/// Scenes built in code (not through a loader) are held to the same limit by
/// `Scene::validate`, which every render runs.
#[test]
fn validate_refuses_lights_beyond_the_limit() {
    let mut scene = lumo_scene::builtin_scene("cornell").expect("a built-in scene");
    scene.validate().expect("the built-in scene is valid");
    scene.lights.push(lumo_scene::Light::Point {
        position: lumo_scene::Vec3::ZERO,
        intensity: lumo_scene::Vec3::splat(f32::MAX),
        range: None,
    });
    let e = scene.validate().unwrap_err().to_string();
    assert!(
        e.contains("intensity") && e.contains("scale the light down"),
        "{e}"
    );
}
