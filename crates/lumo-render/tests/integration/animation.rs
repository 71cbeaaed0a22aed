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
    rs.scene.meshes[deforming].positions[0].x = 0.0;
    // A huge scale: beyond single precision's reach the trees once made a ray traversal index
    // out of bounds (a panic); now the pose is refused naming the instance.
    rs.scene.instances[n - 3].transform = Mat4::from_scale(Vec3::splat(1e20));
    let e = rs.update(&[]).unwrap_err().to_string();
    assert!(
        e.contains(&format!("instance {}", n - 3)) && e.contains("1e18"),
        "{e}"
    );
    // The same as a scene to build.
    let e = RenderScene::new(rs.scene.clone())
        .err()
        .expect("refused")
        .to_string();
    assert!(e.contains("reaches 1e20"), "{e}");
    rs.scene.instances[n - 3].transform = Mat4::IDENTITY;
    // A collapsed camera (a keyframed zero scale) is refused, not rendered black.
    let camera = rs.scene.camera.clone();
    rs.scene.camera.target = rs.scene.camera.origin;
    let e = rs.update(&[]).unwrap_err().to_string();
    assert!(e.contains("camera is singular"), "{e}");
    rs.scene.camera = camera;
    assert!(rs.update(&[]).is_ok());
}

/// The atrium with its placed instances (columns and drapes) moved: every instance with a
/// transform turns a little about its own vertical axis and rises.
fn sway(scene: &mut Scene, angle: f32) {
    for inst in &mut scene.instances {
        if inst.transform != Mat4::IDENTITY {
            let p = inst.transform.transform_point3(Vec3::ZERO);
            inst.transform = Mat4::from_translation(p + Vec3::new(0.0, 0.05 * angle, 0.0))
                * Mat4::from_rotation_y(angle)
                * Mat4::from_translation(-p)
                * inst.transform;
        }
    }
}

#[test]
fn atrium_with_moving_instances_renders_like_a_fresh_build() {
    let mut scene = lumo_scene::builtin_scene("atrium").unwrap();
    scene.defaults.width = 20;
    scene.defaults.height = 16;
    let mut rs = RenderScene::new(scene).unwrap();
    sway(&mut rs.scene, 0.3);
    assert_eq!(rs.update(&[]).unwrap(), SceneUpdate::Refitted);
    let fresh = RenderScene::new(rs.scene.clone()).unwrap();
    let s = settings(&rs.scene);
    let (a, _) = render(&rs, &s, &|_| {});
    let (b, _) = render(&fresh, &s, &|_| {});
    let bits = |f: &lumo_render::Frame| -> Vec<u32> {
        [&f.color, &f.depth, &f.normal]
            .iter()
            .flat_map(|i| i.data.iter().map(|v| v.to_bits()))
            .collect()
    };
    assert_eq!(bits(&a), bits(&b));
}

/// Median time of `f` over `n` runs, in milliseconds.
fn median_ms(n: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..n)
        .map(|_| {
            let start = std::time::Instant::now();
            f();
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[n / 2]
}

/// The update-versus-build table of docs/animation.md: run with
/// `cargo test --release -p lumo-render --test integration update_timings -- --ignored --nocapture`.
#[test]
#[ignore = "timing; prints the table of docs/animation.md"]
fn update_timings() {
    let scene = lumo_scene::builtin_scene("atrium").unwrap();
    let tris = scene.triangle_count();
    let placed = scene
        .instances
        .iter()
        .filter(|i| i.transform != Mat4::IDENTITY)
        .count();
    // The first build of the process also does one-time work (lazily built tables, fresh
    // memory); the median of later builds is what rebuilding every frame would cost.
    // Copies made beforehand, so the clone is not timed.
    let mut copies: Vec<Scene> = (0..6).map(|_| scene.clone()).collect();
    let mut build_one = || {
        RenderScene::new(copies.pop().unwrap()).unwrap();
    };
    let first = median_ms(1, &mut build_one);
    let build = median_ms(5, &mut build_one);
    let mut rs = RenderScene::new(scene).unwrap();
    let mut angle = 0.0;
    let replace = median_ms(21, || {
        angle += 0.01;
        sway(&mut rs.scene, angle);
        assert_eq!(rs.update(&[]).unwrap(), SceneUpdate::Refitted);
    });
    // Vertex motion: the largest mesh placed with the identity transform deforms in place
    // (it lives in the merged BVH of identity instances, which is refitted whole).
    let mesh = (0..rs.scene.meshes.len())
        .filter(|&m| {
            rs.scene
                .instances
                .iter()
                .any(|i| i.mesh == m && i.transform == Mat4::IDENTITY)
        })
        .max_by_key(|&m| rs.scene.meshes[m].indices.len())
        .unwrap();
    let mesh_tris = rs.scene.meshes[mesh].indices.len();
    let refit = median_ms(11, || {
        for p in &mut rs.scene.meshes[mesh].positions {
            p.y += 0.001 * p.x.sin();
        }
        assert_eq!(rs.update(&[mesh]).unwrap(), SceneUpdate::Refitted);
    });
    println!("first build of the process: {first:.1} ms");
    println!("| scene | what moves | update (ms) | full build (ms) |");
    println!("|---|---|---:|---:|");
    println!("| atrium ({tris} triangles) | its {placed} placed instances (columns, drapes) | {replace:.2} | {build:.1} |");
    println!(
        "| atrium | the vertices of {:?} ({mesh_tris} triangles, in the merged BVH) | {refit:.1} | {build:.1} |",
        rs.scene.meshes[mesh].name
    );
}
