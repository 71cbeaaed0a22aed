//! Scene files that attack the loader (issue 25): images that are empty, lie about their size
//! or hold NaN and negative light; an include fan-out bomb; includes and material libraries
//! that are devices or FIFOs; negative colours; a glTF camera with a zero rotation; and the
//! messages of missing files. Each must be an error or a warning naming the file and the
//! element, returned fast, never a panic, a hang or an allocation of what a header claims.
//! The inputs are in tests/data/bad/ (written by make.py there).

use crate::common;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use common::{load, load_strict, temp_dir, write};
use lumo_scene::load::{LoadError, LoadedScene};
use lumo_scene::{Light, Texture, Vec3};

fn bad(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data/bad")
        .join(name)
}

/// Loads `path` on another thread; fails the test if that takes more than 30 s (a loader that
/// blocks on a FIFO or reads a device forever must not hang the suite).
fn load_within_time(path: PathBuf) -> Result<LoadedScene, LoadError> {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        // The receiver may have given up; nothing to do then.
        let _ = tx.send(load(&path));
    });
    rx.recv_timeout(Duration::from_secs(30))
        .expect("loading blocked or ran on")
}

/// The error text of a scene that must be refused.
fn error_text(path: PathBuf) -> String {
    load_within_time(path)
        .expect_err("the scene must be refused")
        .to_string()
}

/// The error text of a scene that must be refused; it names the scene file.
fn error_of(path: PathBuf) -> String {
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    let text = error_text(path);
    assert!(text.contains(&name), "the error must name {name}: {text}");
    text
}

fn warnings(scene: &LoadedScene) -> Vec<String> {
    scene.warnings.iter().map(ToString::to_string).collect()
}

#[test]
fn an_empty_image_as_envmap_or_texture_is_an_error_not_a_panic() {
    // Item 7: a 0×4 PFM used to reach the renderer and panic indexing it.
    for (scene, line) in [("envmap_empty.xml", 4), ("texture_empty.xml", 3)] {
        let text = error_of(bad(scene));
        assert!(text.contains(&format!("{scene}:{line}:")), "{text}");
        assert!(
            text.contains("empty.pfm: the image is empty (0x4 pixels)"),
            "{text}"
        );
    }
}

#[test]
fn image_headers_over_the_pixel_budget_are_refused_naming_file_size_and_limit() {
    // Item 8: each of these files is under 300 bytes and claims gigabytes of pixels.
    for (scene, image, claim) in [
        ("envmap_huge_exr.xml", "huge_window.exr", "100000x100000"),
        ("texture_huge_png.xml", "huge_ihdr.png", "100000x100000"),
        ("texture_huge_hdr.xml", "huge.hdr", "16384x16384"),
        ("texture_huge_jpg.xml", "huge.jpg", "60000x60000"),
    ] {
        let start = Instant::now();
        let text = error_of(bad(scene));
        let bytes = std::fs::metadata(bad(image)).unwrap().len();
        assert!(text.contains(image) && text.contains(claim), "{text}");
        assert!(text.contains(&format!("{bytes} bytes")), "{text}");
        assert!(
            text.contains("over the image limit of 134217728 pixels"),
            "{text}"
        );
        assert!(!text.contains('\n'), "{text}");
        assert!(
            start.elapsed() < Duration::from_secs(5),
            "{scene} took long"
        );
    }
    // Within the budget, but more pixels than the compressed data can hold.
    let text = error_of(bad("texture_short_png.xml"));
    assert!(
        text.contains("short_8k.png: truncated or corrupt PNG"),
        "{text}"
    );
}

#[test]
fn an_include_fan_out_bomb_is_bounded() {
    // Item 10: 13 files of 148 bytes, each including the next four times: 4^12 includes.
    let start = Instant::now();
    let text = error_text(bad("include_bomb/b00.xml"));
    // At the <include> where the count runs out, deep in the chain.
    assert!(text.contains("include_bomb/b1") && text.contains(".xml:1: <include> of"));
    assert!(text.contains("includes more than 4096 files"), "{text}");
    assert!(
        start.elapsed() < Duration::from_secs(10),
        "took {:?}",
        start.elapsed()
    );
}

#[cfg(unix)]
fn mkfifo(path: &Path) {
    let made = std::process::Command::new("mkfifo").arg(path).status();
    assert!(made.is_ok_and(|s| s.success()), "mkfifo failed");
}

#[cfg(unix)]
#[test]
fn includes_that_are_devices_or_fifos_are_refused_without_reading() {
    // Item 10: /dev/zero read 4 GB; a FIFO blocked forever.
    let dir = temp_dir("hostile-include");
    mkfifo(&dir.join("pipe.xml"));
    for (target, kind) in [("/dev/zero", "device"), ("pipe.xml", "FIFO (named pipe)")] {
        let scene = write(
            &dir,
            "scene.xml",
            format!("<scene version=\"3.0.0\">\n<include filename=\"{target}\"/>\n</scene>\n"),
        );
        let text = error_of(scene);
        assert!(text.contains("scene.xml:2:"), "{text}");
        assert!(
            text.contains(&format!("it is a {kind}, not a regular file")),
            "{text}"
        );
    }
}

#[cfg(unix)]
#[test]
fn material_libraries_and_buffers_that_are_devices_or_fifos_are_refused() {
    let dir = temp_dir("hostile-mtllib");
    mkfifo(&dir.join("pipe.mtl"));
    for target in ["/dev/zero", "pipe.mtl"] {
        let obj = write(
            &dir,
            "mesh.obj",
            format!("mtllib {target}\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
        );
        let scene = load_within_time(obj).expect("an unreadable mtllib is a warning");
        let w = warnings(&scene).join("\n");
        assert!(w.contains("mesh.obj:1: warning: mtllib"), "{w}");
        assert!(w.contains("not a regular file"), "{w}");
    }
    mkfifo(&dir.join("pipe.bin"));
    let gltf = write(
        &dir,
        "scene.gltf",
        r#"{"asset": {"version": "2.0"}, "buffers": [{"uri": "pipe.bin", "byteLength": 4}]}"#,
    );
    let text = error_of(gltf);
    assert!(text.contains("pipe.bin: it is a FIFO"), "{text}");
}

#[test]
fn an_all_nan_envmap_is_an_error() {
    let text = error_of(bad("envmap_nan.xml"));
    assert!(text.contains("envmap_nan.xml:4:"), "{text}");
    assert!(
        text.contains("nan_envmap.pfm: every value is NaN or infinite"),
        "{text}"
    );
}

#[test]
fn negative_and_nan_envmap_values_are_read_as_zero_with_a_warning() {
    let scene = load(&bad("envmap_negative.xml")).expect("loads");
    let w = warnings(&scene).join("\n");
    assert!(
        w.contains("envmap_negative.xml:4: warning: image")
            && w.contains("negative_envmap.pfm: 1 NaN or infinite and 1 negative of its 6 values"),
        "{w}"
    );
    let env = scene.scene.lights.iter().find_map(|l| match l {
        Light::Environment(env) => Some(env),
        _ => None,
    });
    let data = &env.expect("an envmap").image.data;
    assert!(data.iter().all(|v| v.is_finite() && *v >= 0.0), "{data:?}");
    assert!(load_strict(&bad("envmap_negative.xml")).is_err());
}

#[test]
fn negative_colours_in_mitsuba_xml_are_warned_about_and_read_as_zero() {
    // Item 12: negative reflectance, radiance and (spectral) intensity.
    let scene = load(&bad("negative_values.xml")).expect("loads");
    let w = warnings(&scene).join("\n");
    for (line, name) in [(4, "reflectance"), (5, "radiance"), (7, "intensity")] {
        assert!(
            w.contains(&format!("negative_values.xml:{line}: warning: {name}: <"))
                && w.contains("has a negative value"),
            "{name}: {w}"
        );
    }
    for m in &scene.scene.materials {
        assert!(m.emission.min_element() >= 0.0, "{:?}", m.emission);
        if let lumo_scene::BsdfSpec::Diffuse {
            reflectance: Texture::Constant(c),
        } = &m.bsdf
        {
            assert!(c.min_element() >= 0.0, "{c}");
        }
    }
    for l in &scene.scene.lights {
        if let Light::Point { intensity, .. } = l {
            assert!(intensity.min_element() >= 0.0, "{intensity}");
        }
    }
}

#[test]
fn a_gltf_camera_with_a_zero_rotation_is_warned_about_and_not_rotated() {
    let scene = load(&bad("zero_rotation.gltf")).expect("loads");
    let w = warnings(&scene).join("\n");
    assert!(
        w.contains("zero_rotation.gltf (node 0): warning: rotation [0.0, 0.0, 0.0, 0.0]"),
        "{w}"
    );
    let cam = &scene.scene.camera;
    assert!(cam.origin.is_finite() && cam.target.is_finite() && cam.up.is_finite());
    // No rotation: at (0, 0, 5) looking down -Z.
    assert!((cam.origin - lumo_scene::Vec3::new(0.0, 0.0, 5.0)).length() < 1e-5);
    assert!((cam.target - cam.origin).normalize().z < -0.999, "{cam:?}");
}

/// Item 14: the path once, the cause once, a fix, and no OS error codes.
fn assert_says_once(text: &str, path: &str, fix: &str) {
    assert_eq!(
        text.matches(path).count(),
        1,
        "{path} must appear once: {text}"
    );
    assert!(text.contains(fix), "{text}");
    assert!(!text.contains("os error"), "{text}");
    assert_eq!(text.matches("no such file").count(), 1, "{text}");
}

#[test]
fn missing_files_are_named_once_with_their_cause_once() {
    let fix = "no such file; check the name and the directory";
    let text = error_of(bad("missing_include.xml"));
    assert!(
        text.contains("missing_include.xml:3: cannot read included file"),
        "{text}"
    );
    assert_says_once(&text, "no_such_file.xml", fix);
    let text = error_of(bad("texture_missing.xml"));
    assert!(text.contains("texture_missing.xml:3: image"), "{text}");
    assert_says_once(&text, "no_such_texture.png", fix);
    // A missing mesh is named at the shape element that names it.
    let text = error_text(bad("missing_mesh.xml"));
    assert!(text.contains("missing_mesh.xml:"), "{text}");
    assert!(text.contains(": cannot read mesh file"), "{text}");
    assert_says_once(&text, "no_such_mesh.ply", fix);
    let text = load(&bad("no_such_scene.xml")).unwrap_err().to_string();
    assert_says_once(&text, "no_such_scene.xml", fix);
    let text = load(&bad("no_such_scene.gltf")).unwrap_err().to_string();
    assert_says_once(&text, "no_such_scene.gltf", fix);
}

#[test]
fn negative_gltf_colours_are_warned_about_and_read_as_zero() {
    let scene = load(&bad("negative_color.gltf")).expect("loads");
    let w = warnings(&scene).join("\n");
    assert!(
        w.contains("negative_color.gltf (material 0): warning: baseColorFactor [0.5, -0.5, 0.5]")
            && w.contains("warning: emissiveFactor × KHR_materials_emissive_strength [-1, 0, 0]"),
        "{w}"
    );
    let m = &scene.scene.materials[scene.scene.meshes[0].material];
    assert!(m.emission.min_element() >= 0.0, "{:?}", m.emission);
    let lumo_scene::BsdfSpec::GltfPbr {
        base_color: Texture::Constant(c),
        ..
    } = &m.bsdf
    else {
        panic!(
            "a glTF material is glTF's metallic-roughness BSDF: {:?}",
            m.bsdf
        );
    };
    assert!(c.min_element() >= 0.0, "{c}");
}

/// Lights that cannot emit as written used to render black (or as something else) without a
/// word: a spot with a zero cone or a singular transform, a negative cone, an envmap with a
/// negative scale, a glTF spot outside KHR_lights_punctual's cone limits. Each is an error
/// naming the element and the rule; an envmap scale of 0 is a warning.
#[test]
fn lights_that_cannot_emit_as_written_are_refused() {
    let dir = temp_dir("light-limits");
    let spot = |inner: &str| {
        common::mitsuba(&format!(
            r#"<emitter type="spot">{inner}<rgb name="intensity" value="10"/></emitter>"#
        ))
    };
    let mut one = Vec::from(&b"PF\n2 1\n-1.0\n"[..]);
    for _ in 0..6 {
        one.extend_from_slice(&1.0f32.to_le_bytes());
    }
    write(&dir, "one.pfm", &one);
    let env = |scale: &str| {
        common::mitsuba(&format!(
            r#"<emitter type="envmap"><string name="filename" value="one.pfm"/><float name="scale" value="{scale}"/></emitter>"#
        ))
    };
    for (name, xml, says) in [
        (
            "cone0.xml",
            spot(r#"<float name="cutoff_angle" value="0"/>"#),
            "cutoff_angle 0",
        ),
        (
            "cone-30.xml",
            spot(r#"<float name="cutoff_angle" value="-30"/>"#),
            "cutoff_angle -30",
        ),
        (
            "beam.xml",
            spot(r#"<float name="beam_width" value="-5"/>"#),
            "beam_width -5",
        ),
        (
            "flat.xml",
            spot(r#"<transform name="to_world"><scale value="0"/></transform>"#),
            "singular",
        ),
        ("env.xml", env("-2"), "envmap scale -2"),
    ] {
        let text = error_of(write(&dir, name, xml));
        assert!(text.contains(says), "{name}: {text}");
    }
    let scene = load(&write(&dir, "env0.xml", env("0"))).expect("loads");
    assert!(warnings(&scene).join("\n").contains("envmap scale 0"));

    let gltf = std::fs::read_to_string(common::scenes().join("hierarchy.gltf")).unwrap();
    for (inner, outer) in [("0.3", "0.0"), ("0.3", "2.0"), ("0.6", "0.5")] {
        let edited = gltf.replace(
            r#""innerConeAngle": 0.3,"#,
            &format!(r#""innerConeAngle": {inner},"#),
        );
        let edited = edited.replace(
            r#""outerConeAngle": 0.5"#,
            &format!(r#""outerConeAngle": {outer}"#),
        );
        assert_ne!(
            edited, gltf,
            "the spot's angles are where the test expects them"
        );
        let text = error_of(write(&dir, "spot.gltf", edited));
        assert!(text.contains("0 < outer ≤ π/2"), "{inner} {outer}: {text}");
    }
}

/// MTL `Ni 0` (or below) on a transparent material made the object vanish (glass of index
/// 0); it is now ignored with a warning and the glass takes 1.5.
#[test]
fn an_mtl_index_of_refraction_at_or_below_zero_is_ignored_with_a_warning() {
    let dir = temp_dir("mtl-ni");
    write(&dir, "x.mtl", "newmtl a\nKd 0.5 0.5 0.5\nNi 0\nd 0.2\n");
    let obj = write(
        &dir,
        "x.obj",
        "mtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n",
    );
    let scene = load(&obj).expect("loads");
    let w = warnings(&scene).join("\n");
    assert!(w.contains("x.mtl:3:") && w.contains("Ni 0"), "{w}");
    let ior = scene.scene.materials.iter().find_map(|m| match m.bsdf {
        lumo_scene::BsdfSpec::Dielectric { ior, .. } => Some(ior),
        _ => None,
    });
    assert_eq!(ior, Some(1.5));
}

/// Messages that blamed the wrong thing: a spectrum plugin said a "value" attribute was
/// missing (now blackbody, d65, regular, irregular and uniform load; another type is named
/// with the ones there are), so did a spectrum file, and a sample count of 0 was reported
/// together with the seed.
#[test]
fn unsupported_spectra_and_bad_sample_counts_say_what_is_wrong() {
    let dir = temp_dir("messages");
    let spectrum = |s: &str| {
        common::mitsuba(&format!(
            r#"<shape type="sphere"><emitter type="area">{s}</emitter></shape>"#
        ))
    };
    let blackbody = spectrum(
        r#"<spectrum name="radiance" type="blackbody"><float name="temperature" value="6500"/></spectrum>"#,
    );
    let loaded = load(&write(&dir, "bb.xml", blackbody)).unwrap();
    let e = loaded
        .scene
        .materials
        .iter()
        .map(|m| m.emission)
        .fold(Vec3::ZERO, Vec3::max);
    // Planck at 6500 K is about 4.3e4 W/(m²·sr·nm) at 550 nm and near-white.
    assert!(e.min_element() > 3.5e4 && e.max_element() < 5.0e4, "{e}");
    let text = error_of(write(
        &dir,
        "ray.xml",
        spectrum(r#"<spectrum name="radiance" type="rayleigh"/>"#),
    ));
    assert!(
        text.contains(r#"spectrum type "rayleigh" is not one of blackbody"#),
        "{text}"
    );
    let text = error_of(write(
        &dir,
        "file.xml",
        spectrum(r#"<spectrum name="radiance" filename="lamp.spd"/>"#),
    ));
    assert!(
        text.contains("lamp.spd")
            && text.contains("irregular")
            && !text.contains("value\" attribute"),
        "{text}"
    );
    let sampler = r#"<scene version="3.0.0"><sensor type="perspective"><sampler type="independent"><integer name="sample_count" value="0"/></sampler></sensor></scene>"#;
    let text = error_of(write(&dir, "spp.xml", sampler));
    assert!(
        text.contains("sample_count 0: use 1 to") && !text.contains("seed"),
        "{text}"
    );
}

/// An exact sphere of radius 0, or a sphere or disk scaled by 0, was refused with "mesh 0
/// ("sphere"): analytic shape transform is singular" — no line, no fix. Now the shape's
/// element is named with what to change.
#[test]
fn exact_shapes_of_zero_size_are_refused_at_their_element() {
    let dir = temp_dir("zero-shapes");
    for (name, body, says) in [
        (
            "r0.xml",
            r#"<shape type="sphere"><float name="radius" value="0"/></shape>"#,
            "sphere radius 0",
        ),
        (
            "s0.xml",
            r#"<shape type="disk"><transform name="to_world"><scale value="1,0,1"/></transform></shape>"#,
            "disk: its to_world is singular",
        ),
    ] {
        let text = error_of(write(&dir, name, common::mitsuba(body)));
        assert!(
            text.contains(&format!("{name}:3:")) && text.contains(says),
            "{text}"
        );
    }
}

/// Two `<bsdf>` in one `<shape>`: the last one won without a word; Mitsuba refuses it.
#[test]
fn a_shape_with_two_bsdfs_is_refused_at_the_second() {
    let dir = temp_dir("two-bsdfs");
    let body = r#"<shape type="sphere">
<bsdf type="diffuse"/>
<bsdf type="conductor"/></shape>"#;
    let text = error_of(write(&dir, "two.xml", common::mitsuba(body)));
    assert!(
        text.contains("two.xml:5:") && text.contains("a second <bsdf>"),
        "{text}"
    );
}

/// A diffuse reflectance of 5 was accepted without a word; it creates energy. It still loads
/// (Mitsuba accepts it), with a warning naming the element.
#[test]
fn a_reflectance_above_one_is_warned_about() {
    let dir = temp_dir("bright");
    let body = r#"<shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="5,5,5"/></bsdf></shape>"#;
    let scene = load(&write(&dir, "bright.xml", common::mitsuba(body))).expect("loads");
    let w = warnings(&scene).join("\n");
    assert!(
        w.contains("bright.xml:3: warning: reflectance") && w.contains("above 1"),
        "{w}"
    );
    let body = r#"<shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="1,0.5,0"/></bsdf></shape>"#;
    let scene = load(&write(&dir, "ok.xml", common::mitsuba(body))).expect("loads");
    let w = warnings(&scene).join("\n");
    assert!(!w.contains("above 1"), "{w}");
}

/// A `<matrix>` with a projective bottom row was read as affine without a word (its bottom row
/// dropped); it is refused, naming the row.
#[test]
fn a_projective_matrix_is_refused() {
    let dir = temp_dir("matrix");
    let body = r#"<shape type="sphere"><transform name="to_world"><matrix value="1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 0"/></transform></shape>"#;
    let text = error_of(write(&dir, "proj.xml", common::mitsuba(body)));
    assert!(
        text.contains("bottom row") && text.contains("0 0 0 1"),
        "{text}"
    );
}

/// A glTF camera's aspectRatio of 0 or below was ignored, and one of 1e9 clamped to a
/// 16384-pixel width, without a word; both now warn.
#[test]
fn odd_gltf_aspect_ratios_are_warned_about() {
    let dir = temp_dir("aspect");
    let gltf = std::fs::read_to_string(common::scenes().join("hierarchy.gltf")).unwrap();
    for (aspect, says) in [
        ("0", "not a positive number"),
        ("-2", "not a positive number"),
        ("1e9", "clamped to 16384"),
    ] {
        let edited = gltf.replace(
            r#""aspectRatio": 1.5"#,
            &format!(r#""aspectRatio": {aspect}"#),
        );
        assert_ne!(edited, gltf);
        let scene = load(&write(&dir, "cam.gltf", edited)).expect("loads");
        let w = warnings(&scene).join("\n");
        assert!(
            w.contains("aspectRatio") && w.contains(says),
            "{aspect}: {w}"
        );
    }
}

/// A spectrum with light only outside 360–830 nm converts to black; the loader said only "the
/// scene has no emitters", though one was given. The element is now named with the reason.
#[test]
fn an_invisible_spectrum_is_named_at_its_element() {
    let dir = temp_dir("invisible");
    let body = r#"<shape type="sphere"><emitter type="area"><spectrum name="radiance" value="100:1, 200:1"/></emitter></shape>"#;
    let scene = load(&write(&dir, "uv.xml", common::mitsuba(body))).expect("loads");
    let w = warnings(&scene).join("\n");
    assert!(
        w.contains("uv.xml:3: warning: radiance") && w.contains("outside the visible range"),
        "{w}"
    );
}

/// A glTF base-colour texture on a primitive without TEXCOORD_0 reads one texel everywhere;
/// that now comes with a warning naming the primitive.
#[test]
fn a_texture_without_texture_coordinates_is_warned_about() {
    let dir = temp_dir("no-uvs");
    let gltf = std::fs::read_to_string(common::scenes().join("hierarchy.gltf")).unwrap();
    // The gold material (on the primitive that has only POSITION) gets a 1×1 PNG texture.
    let png = "data:image/png;base64,iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAIAAACQd1PeAAAADElEQVR4nGNoaGgAAAMEAYFL09IQAAAAAElFTkSuQmCC";
    let edited = gltf
        .replacen(
            "{\n",
            &format!(
                "{{\n \"images\": [{{\"uri\": \"{png}\"}}],\n \"textures\": [{{\"source\": 0}}],\n"
            ),
            1,
        )
        .replace(
            "    \"metallicFactor\": 1,\n    \"roughnessFactor\": 0.4",
            "    \"metallicFactor\": 1,\n    \"roughnessFactor\": 0.4,\n    \"baseColorTexture\": {\"index\": 0}",
        );
    assert!(
        edited.contains("baseColorTexture"),
        "the gold material is where the test expects it"
    );
    let scene = load(&write(&dir, "tex.gltf", edited)).expect("loads");
    let w = warnings(&scene).join("\n");
    assert!(w.contains("no TEXCOORD_0"), "{w}");
    // The unedited file (its textured-free materials) gets no such warning.
    let scene = load(&common::scenes().join("hierarchy.gltf")).expect("loads");
    assert!(!warnings(&scene).join("\n").contains("TEXCOORD_0"));
}
