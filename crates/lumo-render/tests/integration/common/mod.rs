//! Scenes shared by the integration tests.
#![allow(dead_code)]

pub mod bsdf_grid;
pub mod chi2;
pub mod media_room;

use lumo_scene::shapes::{rectangle, sphere};
use lumo_scene::{Camera, FovAxis, Mat4, Material, Scene, Vec3};

/// An empty scene with a camera at `origin` looking at `target` (60° horizontal field of view).
pub fn empty_scene(origin: Vec3, target: Vec3) -> Scene {
    Scene::empty(Camera {
        origin,
        target,
        up: Vec3::Y,
        fov: 60.0,
        fov_axis: FovAxis::X,
        lens: Default::default(),
        filter: Default::default(),
    })
}

/// The inside of a closed sphere of radius 1 with diffuse albedo `rho` emitting `le`.
pub fn furnace_sphere(rho: f32, le: f32) -> Scene {
    let mut scene = empty_scene(Vec3::new(0.1, 0.05, 0.0), Vec3::new(0.0, 0.0, -1.0));
    let m = scene
        .add_material(Material::diffuse("wall", Vec3::splat(rho)).with_emission(Vec3::splat(le)));
    let mut s = sphere(&Mat4::IDENTITY, m, 24, 48);
    // Face inwards: flip the winding so the emitting side is the inside.
    for t in &mut s.indices {
        t.swap(1, 2);
    }
    scene.add_mesh(s);
    scene
}

/// A small diffuse room lit by one rectangular area light.
pub fn small_room() -> Scene {
    let mut scene = lumo_scene::builtin_scene("cornell").expect("built-in cornell");
    scene.defaults.width = 24;
    scene.defaults.height = 24;
    scene
}

/// A unit square light of radiance `le` at height `h` above the origin, facing down, and a
/// large floor.
pub fn light_over_floor(le: f32, h: f32) -> Scene {
    let mut scene = empty_scene(Vec3::new(0.0, 3.0, 3.0), Vec3::ZERO);
    let floor = scene.add_material(Material::diffuse("floor", Vec3::splat(0.5)));
    let light =
        scene.add_material(Material::diffuse("light", Vec3::ZERO).with_emission(Vec3::splat(le)));
    scene.add_mesh(rectangle(
        &(Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2)
            * Mat4::from_scale(Vec3::splat(10.0))),
        floor,
    ));
    scene.add_mesh(rectangle(
        &(Mat4::from_translation(Vec3::new(0.0, h, 0.0))
            * Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2)
            * Mat4::from_scale(Vec3::splat(0.5))),
        light,
    ));
    scene
}
