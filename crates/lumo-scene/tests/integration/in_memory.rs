//! The in-memory entry points (`load_mitsuba_str`, `load_ply_bytes`): the same scene as from
//! the file, and no file-system access from the text.

use crate::common;

use std::path::Path;

use common::{load, scenes};
use lumo_scene::load::{load_mitsuba_str, load_ply_bytes, LoadOptions};

#[test]
fn mitsuba_text_loads_like_the_file() {
    let path = scenes().join("cornell.xml");
    let text = std::fs::read_to_string(&path).unwrap();
    let from_file = load(&path).unwrap();
    let from_text = load_mitsuba_str(&text, &path, &LoadOptions::default()).unwrap();
    assert_eq!(from_text.settings, from_file.settings);
    assert_eq!(from_text.warnings, from_file.warnings);
    let (a, b) = (&from_text.scene, &from_file.scene);
    assert_eq!(a.meshes.len(), b.meshes.len());
    for (m, n) in a.meshes.iter().zip(&b.meshes) {
        assert_eq!(m.positions, n.positions);
        assert_eq!(m.indices, n.indices);
        assert_eq!(m.material, n.material);
    }
    assert_eq!(a.materials.len(), b.materials.len());
    assert_eq!(a.camera.origin, b.camera.origin);
}

#[test]
fn mitsuba_text_reads_no_other_files() {
    // Each names a file that exists next to the virtual path; all must be refused, at the
    // element that names it.
    let base = scenes().join("virtual.xml");
    let cases = [
        (r#"<include filename="include/room.xml"/>"#, "include"),
        (
            r#"<shape type="ply"><string name="filename" value="meshes/pyramid_le.ply"/></shape>"#,
            "ply",
        ),
        (
            r#"<shape type="obj"><string name="filename" value="meshes/box.obj"/></shape>"#,
            "obj",
        ),
        (
            r#"<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="textures/checker.png"/></texture></bsdf></shape>"#,
            "bitmap",
        ),
    ];
    for (body, what) in cases {
        let xml = format!("<scene version=\"3.0.0\">\n{body}\n</scene>");
        let e = load_mitsuba_str(&xml, &base, &LoadOptions::default())
            .err()
            .unwrap_or_else(|| panic!("{what}: loaded a file"));
        let text = e.to_string();
        assert!(text.contains("virtual.xml:2"), "{what}: {text}");
        assert!(text.contains("reads no files"), "{what}: {text}");
    }
}

#[test]
fn ply_bytes_load_like_the_file() {
    for name in ["pyramid_ascii.ply", "pyramid_le.ply", "pyramid_be.ply"] {
        let path = scenes().join("meshes").join(name);
        let bytes = std::fs::read(&path).unwrap();
        let from_file = load(&path).unwrap();
        let from_bytes = load_ply_bytes(&bytes, &path, &LoadOptions::default()).unwrap();
        let (m, n) = (&from_bytes.scene.meshes[0], &from_file.scene.meshes[0]);
        assert_eq!(m.name, n.name);
        assert_eq!(m.positions, n.positions);
        assert_eq!(m.normals, n.normals);
        assert_eq!(m.uvs, n.uvs);
        assert_eq!(m.colors, n.colors);
        assert_eq!(m.indices, n.indices);
        // Errors name the virtual path.
        let e = load_ply_bytes(&bytes[..40], Path::new("cut.ply"), &LoadOptions::default())
            .err()
            .unwrap();
        assert!(e.to_string().starts_with("cut.ply"), "{e}");
    }
}
