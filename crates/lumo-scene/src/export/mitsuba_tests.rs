use std::path::PathBuf;

use glam::{Vec2, Vec4Swizzles};

use super::*;
use crate::load::{load_scene, LoadOptions};
use crate::{builtin_scene, Instance, Mesh};

/// A fresh folder for one test's files.
fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lumo-export-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp folder");
    dir
}

/// The scene written and read back by lumo's own Mitsuba loader, without a warning.
fn round_trip(scene: &Scene, name: &str) -> Scene {
    let xml = folder(name).join("scene.xml");
    write_mitsuba(scene, &xml).expect("exports");
    let options = LoadOptions {
        strict: true,
        ..Default::default()
    };
    let loaded = load_scene(&xml, &options).unwrap_or_else(|e| panic!("{xml:?}: {e}"));
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let _ = std::fs::remove_dir_all(xml.parent().expect("folder"));
    loaded.scene
}

/// Every world-space triangle with its material's name, sorted by position (the loader may
/// order meshes and instances otherwise, and names materials by their ids).
fn world_triangles(scene: &Scene) -> Vec<(String, [i64; 9])> {
    let mut out = vec![];
    for inst in &scene.instances {
        let mesh = &scene.meshes[inst.mesh];
        if mesh.analytic.is_some() {
            continue;
        }
        let name = scene.materials[mesh.material].name.clone();
        for t in 0..mesh.triangle_count() {
            let p = mesh
                .triangle(t)
                .map(|p| (inst.transform * p.extend(1.0)).xyz());
            // Rounded to 1e-4: the loader multiplies the same matrices in its own order.
            let key = p.map(|v| v.to_array().map(|c| (c * 1e4).round() as i64));
            out.push((name.clone(), key.concat().try_into().expect("9")));
        }
    }
    out.sort_by_key(|t: &(String, [i64; 9])| t.1);
    out
}

#[test]
fn the_cornell_box_reads_back_as_itself() {
    let scene = builtin_scene("cornell").expect("built in");
    let back = round_trip(&scene, "cornell");
    let (a, b) = (world_triangles(&scene), world_triangles(&back));
    assert_eq!(a.len(), b.len());
    for ((ma, ta), (mb, tb)) in a.iter().zip(&b) {
        assert_eq!(ta, tb, "{ma} / {mb}");
    }
    let c = (&scene.camera, &back.camera);
    assert!((c.0.origin - c.1.origin).length() < 1e-5);
    assert!(
        ((c.0.target - c.0.origin).normalize() - (c.1.target - c.1.origin).normalize()).length()
            < 1e-5
    );
    assert!((c.0.fov - c.1.fov).abs() < 1e-4);
    assert_eq!(back.defaults.width, scene.defaults.width);
    // The light: the same radiance on the same triangles.
    let emitted = |s: &Scene| -> Vec<Vec3> {
        s.materials
            .iter()
            .filter(|m| m.is_emissive())
            .map(|m| m.emission)
            .collect()
    };
    assert_eq!(emitted(&scene), emitted(&back));
}

#[test]
fn materials_textures_and_lights_of_the_atrium_read_back() {
    let scene = builtin_scene("atrium").expect("built in");
    let back = round_trip(&scene, "atrium");
    assert_eq!(back.triangle_count(), scene.triangle_count());
    assert_eq!(world_triangles(&scene).len(), world_triangles(&back).len());
    // Every kind of BSDF, one- or two-sided, comes back.
    let by_kind = |s: &Scene| {
        let mut v: Vec<String> = s
            .materials
            .iter()
            .map(|m| format!("{}/{}", bsdf_kind(&m.bsdf), if m.two_sided { 2 } else { 1 }))
            .collect();
        v.sort();
        v.dedup();
        v
    };
    assert_eq!(by_kind(&scene), by_kind(&back));
    let sun = |s: &Scene| {
        s.lights
            .iter()
            .find_map(|l| match l {
                Light::Directional {
                    direction,
                    irradiance,
                } => Some((*direction, *irradiance)),
                _ => None,
            })
            .expect("a sun")
    };
    let (d0, e0) = sun(&scene);
    let (d1, e1) = sun(&back);
    assert!((d0 - d1).length() < 1e-6 && e0 == e1);
}

#[test]
fn a_checkerboard_evaluates_the_same_after_the_round_trip() {
    for scale in [1.0, 2.0, 8.0, 3.0] {
        let mut scene = builtin_scene("cornell").expect("built in");
        let floor = scene.add_material(Material {
            name: "checks".into(),
            bsdf: BsdfSpec::Diffuse {
                reflectance: Texture::Checkerboard {
                    color0: Vec3::new(0.8, 0.1, 0.1),
                    color1: Vec3::new(0.1, 0.1, 0.8),
                    scale,
                },
            },
            emission: Vec3::ZERO,
            emission_map: None,
            two_sided: true,
            spectra: Default::default(),
        });
        let mut quad = Mesh {
            name: "quad".into(),
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            material: floor,
            ..Default::default()
        };
        quad.normals = vec![];
        scene.meshes.push(quad);
        scene.instances.push(Instance {
            mesh: scene.meshes.len() - 1,
            transform: Mat4::IDENTITY,
        });
        let back = round_trip(&scene, &format!("checks{scale}"));
        let tex = back
            .materials
            .iter()
            .find_map(|m| match &m.bsdf {
                BsdfSpec::Diffuse { reflectance }
                    if !matches!(reflectance, Texture::Constant(_)) =>
                {
                    Some(reflectance.clone())
                }
                _ => None,
            })
            .expect("the checkerboard");
        let original = Texture::Checkerboard {
            color0: Vec3::new(0.8, 0.1, 0.1),
            color1: Vec3::new(0.1, 0.1, 0.8),
            scale,
        };
        for i in 0..23 {
            for j in 0..23 {
                // Off the square edges, where rounding could pick either side.
                let uv = Vec2::new(i as f32 + 0.37, j as f32 + 0.61) / 23.0;
                assert_eq!(tex.eval(uv), original.eval(uv), "scale {scale}, uv {uv}");
            }
        }
    }
}

#[test]
fn what_mitsuba_cannot_hold_is_refused_by_name() {
    let mut scene = builtin_scene("cornell").expect("built in");
    scene.lights.push(Light::Point {
        position: Vec3::ONE,
        intensity: Vec3::ONE,
        range: Some(2.0),
    });
    let xml = folder("refused").join("scene.xml");
    let e = write_mitsuba(&scene, &xml).expect_err("a ranged light is refused");
    assert!(e.to_string().contains("range"), "{e}");
    let mut scene = builtin_scene("cornell").expect("built in");
    scene.materials[0].bsdf = BsdfSpec::Mirror {
        reflectance: Vec3::splat(0.5),
    };
    let name = scene.materials[0].name.clone();
    let e = write_mitsuba(&scene, &xml).expect_err("a grey mirror is refused");
    assert!(e.to_string().contains(&name), "{e}");
    let _ = std::fs::remove_dir_all(xml.parent().expect("folder"));
}
