//! End-to-end tests of `lumo export`: the written Mitsuba file renders like the scene it came
//! from, and what Mitsuba cannot hold is refused with the item's name.

use std::path::{Path, PathBuf};

use lumo_image::read_image;

fn temp_dir(name: &str) -> PathBuf {
    super::common::temp_dir("export-cli", name)
}

use super::common::lumo;

fn mean(path: &Path) -> [f64; 3] {
    let img = read_image(path).expect("image");
    let mut m = [0.0f64; 3];
    for p in img.data.chunks(img.channels) {
        for c in 0..3 {
            m[c] += p[c] as f64;
        }
    }
    m.map(|v| v / (img.width * img.height) as f64)
}

/// The exported Cornell box and the built-in one give the same image mean at 64 spp (the same
/// triangles, materials, light and camera; the sampler's stream differs with the triangle
/// order, so means, not bits).
#[test]
fn the_exported_cornell_box_renders_as_the_built_in_one() {
    let dir = temp_dir("cornell");
    let xml = dir.join("cornell.xml");
    let o = lumo(&["export", "cornell", "-o", xml.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(dir.join("meshes").read_dir().unwrap().count() > 0);
    let a = dir.join("a.pfm");
    let b = dir.join("b.pfm");
    for (scene, out) in [("cornell", &a), (xml.to_str().unwrap(), &b)] {
        let o = lumo(&[
            "render",
            scene,
            "--strict",
            "--pipeline",
            "none",
            "--size",
            "48x48",
            "--spp",
            "64",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let (ma, mb) = (mean(&a), mean(&b));
    for c in 0..3 {
        assert!(
            (ma[c] / mb[c] - 1.0).abs() < 0.01,
            "channel {c}: {ma:?} vs {mb:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_scene_mitsuba_cannot_hold_is_refused_with_the_item_named() {
    let dir = temp_dir("refused");
    let xml = dir.join("x.xml");
    // The glTF test scene's materials are glTF's metallic-roughness BSDF.
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/animated.gltf");
    let o = lumo(&["export", scene, "-o", xml.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("material") && err.contains("Mitsuba"), "{err}");
    assert!(
        !xml.exists(),
        "nothing half-written under the name asked for"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
