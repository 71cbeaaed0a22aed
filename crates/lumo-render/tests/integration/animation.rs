//! Dynamic scenes: `RenderScene::update` after instances, vertices and emissive geometry move
//! renders the same image, bit for bit, as a render scene built afresh from the moved scene.

use crate::common;

use glam::{Mat4, Vec3};
use lumo_render::{render, render_light, PathSettings, RenderScene, RenderSettings, SceneUpdate};
use lumo_scene::shapes::{cube, rectangle, sphere};
use lumo_scene::{Instance, Material, Scene};

/// The Cornell box (identity instances, merged into one BVH) plus three things that move:
/// a sphere placed by a transform, a small emissive panel placed by a transform (a light that
/// moves), and a cube whose vertices move in place (identity instance: the merged BVH refits).
/// Returns the scene and the index of the deforming cube's mesh.
fn dynamic_box() -> (Scene, usize) {
    let mut scene = common::small_room();
    let grey = scene.add_material(Material::diffuse("grey", Vec3::splat(0.6)));
    let lamp = scene.add_material(
        Material::diffuse("lamp", Vec3::splat(0.2)).with_emission(Vec3::new(6.0, 5.0, 4.0)),
    );
    let ball = scene.meshes.len();
    scene.meshes.push(sphere(&Mat4::IDENTITY, grey, 12, 24));
    scene.instances.push(Instance {
        mesh: ball,
        transform: Mat4::from_translation(Vec3::new(-0.4, -0.6, 0.2))
            * Mat4::from_scale(Vec3::splat(0.3)),
    });
    let panel = scene.meshes.len();
    scene.meshes.push(rectangle(&Mat4::IDENTITY, lamp));
    scene.instances.push(Instance {
        mesh: panel,
        transform: Mat4::from_translation(Vec3::new(0.3, 0.2, 0.0))
            * Mat4::from_scale(Vec3::splat(0.15)),
    });
    let deforming = scene.add_mesh(cube(
        &(Mat4::from_translation(Vec3::new(0.45, -0.75, -0.3))
            * Mat4::from_scale(Vec3::splat(0.2))),
        grey,
    ));
    (scene, deforming)
}

fn settings(scene: &Scene) -> RenderSettings {
    RenderSettings {
        width: scene.defaults.width,
        height: scene.defaults.height,
        spp: 2,
        seed: 3,
        path: PathSettings {
            max_depth: 4,
            ..Default::default()
        },
    }
}

/// Path-traced colour and albedo planes and the light tracer's image, as bits.
fn images(rs: &RenderScene) -> Vec<u32> {
    let s = settings(&rs.scene);
    let (frame, _) = render(rs, &s, &|_| {});
    let (light, _) = render_light(rs, &s, &|_| {});
    [&frame.color, &frame.albedo, &frame.depth, &light]
        .iter()
        .flat_map(|img| img.data.iter().map(|v| v.to_bits()))
        .collect()
}

/// Moves the sphere and the panel (still non-identity) and deforms the cube.
fn move_things(scene: &mut Scene, deforming: usize) {
    let n = scene.instances.len();
    scene.instances[n - 3].transform = Mat4::from_translation(Vec3::new(0.1, -0.5, -0.1))
        * Mat4::from_rotation_y(0.8)
        * Mat4::from_scale(Vec3::splat(0.35));
    scene.instances[n - 2].transform = Mat4::from_translation(Vec3::new(-0.3, 0.5, -0.2))
        * Mat4::from_rotation_x(0.6)
        * Mat4::from_scale(Vec3::splat(0.2));
    for p in &mut scene.meshes[deforming].positions {
        *p = Vec3::new(p.x + 0.3 * p.y, p.y * 1.5, p.z);
    }
}

#[test]
fn updated_render_scene_renders_like_a_fresh_one() {
    let (scene, deforming) = dynamic_box();
    let mut rs = RenderScene::new(scene).unwrap();
    let before = images(&rs);
    move_things(&mut rs.scene, deforming);
    assert_eq!(rs.update(&[deforming]).unwrap(), SceneUpdate::Refitted);
    let updated = images(&rs);
    let fresh = images(&RenderScene::new(rs.scene.clone()).unwrap());
    assert_ne!(before, updated, "the motion must show in the image");
    let differing = updated.iter().zip(&fresh).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "{differing} values differ from a fresh build");
}

#[test]
fn joining_the_identity_transform_rebuilds_the_accel_and_structure_changes_rebuild_all() {
    let (scene, _) = dynamic_box();
    let mut rs = RenderScene::new(scene).unwrap();
    // The sphere's instance becomes the identity: it joins the merged BVH.
    let n = rs.scene.instances.len();
    rs.scene.instances[n - 3].transform = Mat4::IDENTITY;
    assert_eq!(rs.update(&[]).unwrap(), SceneUpdate::RebuiltAccel);
    assert_eq!(
        images(&rs),
        images(&RenderScene::new(rs.scene.clone()).unwrap())
    );
    // A new instance is not a pose: everything is rebuilt.
    rs.scene.instances.push(Instance {
        mesh: 0,
        transform: Mat4::from_translation(Vec3::new(0.0, 0.0, -0.5)),
    });
    assert_eq!(rs.update(&[]).unwrap(), SceneUpdate::Rebuilt);
    assert_eq!(
        images(&rs),
        images(&RenderScene::new(rs.scene.clone()).unwrap())
    );
}

#[test]
fn invalid_updates_are_errors() {
    let (scene, deforming) = dynamic_box();
    let mut rs = RenderScene::new(scene).unwrap();
    let n = rs.scene.instances.len();
    rs.scene.instances[n - 3].transform = Mat4::from_scale(Vec3::ZERO);
    let e = rs.update(&[]).unwrap_err().to_string();
    assert!(e.contains("singular"), "{e}");
    rs.scene.instances[n - 3].transform = Mat4::IDENTITY;
    rs.scene.meshes[deforming].positions[0].x = f32::NAN;
    let e = rs.update(&[deforming]).unwrap_err().to_string();
    assert!(e.contains("position"), "{e}");
    let e = rs.update(&[999]).unwrap_err().to_string();
    assert!(e.contains("999"), "{e}");
}
