//! OBJ/MTL and PLY loading, lone-mesh defaults and bad-input errors.

use crate::common;

use common::{load, scenes, temp_dir, write};
use lumo_scene::{BsdfSpec, Light, Texture, Vec2, Vec3};

#[test]
fn ply_encodings_agree_and_quads_are_triangulated() {
    let dir = scenes().join("meshes");
    let le = load(&dir.join("pyramid_le.ply")).unwrap();
    let be = load(&dir.join("pyramid_be.ply")).unwrap();
    let ascii = load(&dir.join("pyramid_ascii.ply")).unwrap();
    let (a, b, c) = (
        &le.scene.meshes[0],
        &be.scene.meshes[0],
        &ascii.scene.meshes[0],
    );
    assert_eq!(a.positions.len(), 5);
    assert_eq!(a.positions, b.positions);
    assert_eq!(a.positions, c.positions);
    assert_eq!(a.normals, c.normals);
    assert_eq!(a.uvs, c.uvs);
    assert_eq!(a.positions[4], Vec3::new(0.0, 1.5, 0.0));
    assert_eq!(a.normals[4], Vec3::Y);
    assert_eq!(a.uvs[1], Vec2::new(1.0, 0.0));
    // The ASCII quad base is fanned into the same two triangles the binary files list.
    assert_eq!(a.indices, c.indices);
    assert_eq!(a.indices.len(), 6);
    assert!(le.warnings.is_empty(), "{:?}", le.warnings);
    // 8-bit colours are sRGB: 255 → 1, 0 → 0.
    assert_eq!(a.colors, c.colors);
    assert_eq!(a.colors[0], Vec3::X);
    assert_eq!(a.colors[3], Vec3::new(1.0, 1.0, 0.0));
}

#[test]
fn lone_mesh_gets_a_framing_camera_and_a_sky() {
    let s = load(&scenes().join("meshes/pyramid_le.ply")).unwrap().scene;
    let (lo, hi) = s.bounds();
    let center = (lo + hi) * 0.5;
    assert!((s.camera.target - center).length() < 1e-6);
    // The whole bounding sphere is inside the field of view.
    let radius = (hi - lo).length() * 0.5;
    let dist = (s.camera.origin - center).length();
    assert!((radius / dist).asin().to_degrees() < s.camera.fov * 0.5);
    assert!(s.lights.iter().any(|l| matches!(l, Light::Constant { .. })));
    assert!(s
        .lights
        .iter()
        .any(|l| matches!(l, Light::Directional { .. })));
    assert_eq!(s.name, "pyramid_le");
}

fn ply_header(format: &str, vertices: usize, faces: usize) -> Vec<u8> {
    format!(
        "ply\nformat {format} 1.0\nelement vertex {vertices}\nproperty float x\nproperty float y\n\
         property float z\nelement face {faces}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    .into_bytes()
}

fn binary_triangle(coords: [[f32; 3]; 3], face: [i32; 3]) -> Vec<u8> {
    let mut b = ply_header("binary_little_endian", 3, 1);
    for v in coords {
        for c in v {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    b.push(3);
    for i in face {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b
}

#[test]
fn ply_bad_input() {
    let dir = temp_dir("ply");
    let good = binary_triangle([[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], [0, 1, 2]);
    let ok = write(&dir, "ok.ply", &good);
    assert_eq!(load(&ok).unwrap().scene.meshes[0].indices, vec![[0, 1, 2]]);

    let truncated = write(&dir, "trunc.ply", &good[..good.len() - 5]);
    let e = load(&truncated).unwrap_err().to_string();
    assert!(
        e.contains("trunc.ply") && e.contains("truncated") && e.contains("face 0"),
        "{e}"
    );

    let range = write(
        &dir,
        "range.ply",
        binary_triangle([[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], [0, 1, 7]),
    );
    let e = load(&range).unwrap_err().to_string();
    assert!(e.contains("range.ply") && e.contains("vertex 7"), "{e}");

    let nan = write(
        &dir,
        "nan.ply",
        binary_triangle([[0.0; 3], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]], [0, 1, 2]),
    );
    let e = load(&nan).unwrap_err().to_string();
    assert!(
        e.contains("nan.ply") && e.contains("vertex 1") && e.contains("non-finite"),
        "{e}"
    );

    let mut huge = ply_header("binary_little_endian", 4_000_000_000, 1);
    huge.extend_from_slice(&[0; 16]);
    let e = load(&write(&dir, "huge.ply", huge))
        .unwrap_err()
        .to_string();
    assert!(e.contains("more than the file can hold"), "{e}");

    let e = load(&write(&dir, "text.ply", "hello"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a PLY file"), "{e}");
    let e = load(&write(&dir, "nohdr.ply", "ply\nformat ascii 1.0\n"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("end_header"), "{e}");

    // A degenerate triangle is dropped with a warning; the rest renders.
    let mut ascii = ply_header("ascii", 4, 2);
    ascii.extend_from_slice(b"0 0 0\n1 0 0\n0 1 0\n2 0 0\n3 0 1 2\n3 0 1 3\n");
    let loaded = load(&write(&dir, "degen.ply", ascii)).unwrap();
    assert_eq!(loaded.scene.meshes[0].indices.len(), 1);
    assert!(loaded.warnings[0]
        .message
        .contains("1 of 2 triangles are degenerate"));

    let mut bad_ascii = ply_header("ascii", 3, 1);
    bad_ascii.extend_from_slice(b"0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n");
    let e = load(&write(&dir, "badascii.ply", bad_ascii))
        .unwrap_err()
        .to_string();
    assert!(e.contains("badascii.ply:11"), "{e}");
}

#[test]
fn obj_with_mtl() {
    let loaded = load(&scenes().join("meshes/box.obj")).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let s = &loaded.scene;
    assert_eq!(s.meshes.len(), 2);
    let painted = &s.meshes[0];
    assert_eq!(painted.indices.len(), 10, "five quads");
    assert_eq!(painted.uvs.len(), painted.positions.len());
    assert_eq!(painted.normals.len(), painted.positions.len());
    match &s.materials[painted.material].bsdf {
        BsdfSpec::Plastic {
            diffuse: Texture::Bitmap { image, .. },
            roughness,
            ..
        } => {
            assert_eq!((image.width, image.height), (8, 8));
            assert!((roughness.alpha_u - (2.0f32 / 202.0).sqrt()).abs() < 1e-6);
            assert_eq!(roughness.alpha_u, roughness.alpha_v);
        }
        other => panic!("{other:?}"),
    }
    let lid = &s.meshes[1];
    assert_eq!(lid.indices.len(), 2);
    assert!(lid.normals.is_empty() && lid.uvs.is_empty());
    assert_eq!(s.materials[lid.material].emission, Vec3::new(4.0, 3.5, 3.0));
    // Every face of the closed box points outward.
    let center = Vec3::new(0.0, 0.5, 0.0);
    for m in &s.meshes {
        for t in 0..m.triangle_count() {
            let [a, b, c] = m.triangle(t);
            assert!((b - a).cross(c - a).dot((a + b + c) / 3.0 - center) > 0.0);
        }
    }
}

#[test]
fn obj_relative_indices_and_errors() {
    let dir = temp_dir("obj");
    let rel = write(
        &dir,
        "rel.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf -4 -3 -2\nf 2 4 3\nmtllib nowhere.mtl\n",
    );
    let loaded = load(&rel).unwrap();
    assert_eq!(loaded.scene.meshes[0].indices, vec![[0, 1, 2], [1, 3, 2]]);
    let w = loaded.warnings[0].to_string();
    assert!(w.contains("rel.obj:7") && w.contains("nowhere.mtl"), "{w}");

    for (name, text, needle) in [
        ("range.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n", "range.obj:3"),
        ("nan.obj", "v 0 0 0\nv inf 0 0\n", "nan.obj:2"),
        ("short.obj", "v 0 0\n", "short.obj:1"),
        ("empty.obj", "# nothing\n", "no faces"),
        ("zero.obj", "v 0 0 0\nf 0 0 0\n", "zero.obj:2"),
    ] {
        let e = load(&write(&dir, name, text)).unwrap_err().to_string();
        assert!(e.contains(needle), "{name}: {e}");
    }
}
