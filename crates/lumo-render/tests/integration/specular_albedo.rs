//! The albedo plane behind glass: the albedo of what the glass shows, each branch weighted by
//! its Fresnel share (the denoisers divide by it, so the refracted texture is not blurred).

use lumo_render::camera::PinholeCamera;
use lumo_render::integrators::path::wavefront::render_pixels;
use lumo_render::{PathSettings, RenderScene, RenderSettings};
use lumo_scene::shapes::{rectangle, sphere};
use lumo_scene::{Mat4, Material, Vec3};

use crate::common::empty_scene;

/// A smooth glass ball (η = 1.5) in front of a grey wall, nothing behind the camera. Through
/// the ball's centre the view refracts in and out at normal incidence, (1 − F₀)² = 0.9216 of
/// it reaching the wall; the reflections go back past the camera and see nothing. So the
/// albedo there is 0.9216 × the wall's, where the glass's own constant (1) was recorded before.
#[test]
fn glass_shows_the_albedo_behind_it_weighted_by_its_transmittance() {
    let mut scene = empty_scene(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO);
    let wall = scene.add_material(Material::diffuse("wall", Vec3::splat(0.5)));
    let glass = scene.add_material(Material::glass("glass", 1.5));
    scene.add_mesh(rectangle(
        &(Mat4::from_translation(Vec3::new(0.0, 0.0, -2.0)) * Mat4::from_scale(Vec3::splat(10.0))),
        wall,
    ));
    scene.add_mesh(sphere(&Mat4::from_scale(Vec3::splat(0.5)), glass, 64, 128));
    let rs = RenderScene::new(scene).expect("scene");
    let (w, h) = (15, 15);
    let settings = RenderSettings {
        width: w,
        height: h,
        spp: 1,
        seed: 1,
        path: PathSettings::default(),
    };
    let camera = PinholeCamera::new(&rs.scene.camera, w, h);
    let centre = render_pixels(&rs, &camera, &settings, h / 2, w / 2..w / 2 + 1)[0];
    let want = 0.96f32 * 0.96 * 0.5;
    let got = centre.first_hit.albedo;
    for c in 0..3 {
        assert!(
            (got[c] - want).abs() < 0.01 * want,
            "centre albedo {got} (want {want})"
        );
    }
    // The wall beside the ball keeps its own albedo.
    let side = render_pixels(&rs, &camera, &settings, h / 2, 0..1)[0];
    assert_eq!(side.first_hit.albedo, Vec3::splat(0.5));
}
