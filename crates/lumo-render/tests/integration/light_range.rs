//! glTF's light `range` (KHR_lights_punctual): a point or spot light of range r lights a point
//! at distance d by I · window(d) / d², window(d) = clamp(1 − (d/r)⁴, 0, 1), and not at all
//! from d ≥ r. Checked against the closed form over a diffuse floor (the path tracer, one ray
//! at a time and as whole frames, and the `dirac` plane of the Dirac lights' exact light), and
//! across the integrators: the light tracer, BDPT (whose light subpaths carry the window on
//! their first segment) and photon mapping (whose photons do) converge to the path tracer's
//! image of a room lit by ranged lights only, in RGB and (light tracer) spectral transport.

use std::f32::consts::{FRAC_PI_2, PI};

use glam::{Mat4, Vec3};
use lumo_render::camera::PinholeCamera;
use lumo_render::integrators::bdpt::BdptSettings;
use lumo_render::lights::SpotCone;
use lumo_render::sampler::PixelSampler;
use lumo_render::{
    dirac_direct, render, render_bdpt, render_light, render_ppm, trace_path, PathSettings,
    PpmSettings, RenderScene, RenderSettings,
};
use lumo_scene::shapes::rectangle;
use lumo_scene::{range_window, Light, Material, Scene, SpotFalloff};

use crate::common;
use crate::common::media_room::{assert_matches_path, path_jittered, room_scene, settings};

const RHO: f32 = 0.5;
const HEIGHT: f32 = 1.0;

/// A diffuse floor (y = 0, 40 m square) and `light`, seen from above.
fn floor_with(light: Light) -> RenderScene {
    RenderScene::new(floor_scene(light)).unwrap()
}

/// The scene of [`floor_with`]: the camera 3 m above the floor looks straight down.
fn floor_scene(light: Light) -> Scene {
    let mut scene = common::empty_scene(Vec3::new(0.0, 3.0, 0.0), Vec3::ZERO);
    scene.camera.up = Vec3::Z;
    scene.camera.fov = 100.0;
    let floor = scene.add_material(Material::diffuse("floor", Vec3::splat(RHO)));
    scene.add_mesh(rectangle(
        &(Mat4::from_rotation_x(-FRAC_PI_2) * Mat4::from_scale(Vec3::splat(20.0))),
        floor,
    ));
    scene.lights.push(light);
    scene
}

/// The radiance leaving floor point (x, 0, 0) straight up, from one path (the light is a
/// Dirac delta above a plane that reflects nothing back: next-event estimation alone,
/// deterministic).
fn floor_radiance(rs: &RenderScene, x: f32) -> Vec3 {
    let mut sampler = PixelSampler::new(0, 0, 0, 5);
    let eye = Vec3::new(x, 0.5, 0.0);
    let settings = PathSettings::default();
    let r = trace_path(rs, eye, -Vec3::Y, &mut sampler, &settings, None);
    assert_eq!(r.indirect, Vec3::ZERO);
    r.direct
}

/// At distances inside and beyond the range, the floor's radiance is ρ/π · I · falloff ·
/// window(d) · cos θ / d² (to 1e-4), exactly zero from d ≥ r, and the window is the spec's
/// (1 − (d/r)⁴ clamped) — checked against the unranged light's image, so a window applied
/// twice, or left out, fails.
#[test]
fn ranged_lights_follow_the_windowed_inverse_square_law() {
    let intensity = Vec3::new(2.0, 3.0, 4.0);
    let range = 2.5;
    let cone = SpotCone::new(30.0, 70.0, SpotFalloff::SquaredCosine);
    let point = |range| Light::Point {
        position: Vec3::new(0.0, HEIGHT, 0.0),
        intensity,
        range,
    };
    let spot = |range| Light::Spot {
        position: Vec3::new(0.0, HEIGHT, 0.0),
        direction: -Vec3::Y,
        intensity,
        beam_width: 30.0,
        cutoff: 70.0,
        falloff: SpotFalloff::SquaredCosine,
        range,
    };
    for (name, ranged, unranged, is_spot) in [
        ("point", point(Some(range)), point(None), false),
        ("spot", spot(Some(range)), spot(None), true),
    ] {
        let (rs, plain) = (floor_with(ranged), floor_with(unranged));
        let mut beyond = 0;
        for x in [0.0, 0.5, 1.0, 1.5, 2.0, 2.2, 2.29, 2.3, 2.5, 3.0, 6.0] {
            let d = (x * x + HEIGHT * HEIGHT).sqrt();
            let cos = HEIGHT / d;
            let falloff = if is_spot { cone.falloff(cos) } else { 1.0 };
            let window = {
                let q = (d / range).powi(4);
                (1.0 - q).clamp(0.0, 1.0)
            };
            assert!(
                (range_window(d, range) - window).abs() < 1e-6,
                "{name} at d = {d}"
            );
            let expected = RHO / PI * intensity * falloff * window * cos / (d * d);
            let got = floor_radiance(&rs, x);
            let tolerance = 1e-4 * expected.max_element() + 1e-7;
            assert!(
                (got - expected).abs().max_element() <= tolerance,
                "{name} at x = {x} (d = {d}): {got} vs {expected}"
            );
            if d >= range {
                assert_eq!(got, Vec3::ZERO, "{name} at d = {d} ≥ range");
                beyond += 1;
            } else if falloff > 0.0 {
                // The unranged light's image times the window.
                let without = floor_radiance(&plain, x);
                let ratio = got / without;
                assert!(
                    (ratio - Vec3::splat(window)).abs().max_element() < 1e-5,
                    "{name} at d = {d}: ratio {ratio} vs window {window}"
                );
            }
        }
        assert!(beyond >= 3, "{name}: points beyond the range were checked");
    }
}

/// Whole frames of the floor under a ranged point light, then a ranged spot light: the path
/// tracer's direct light (the wavefront renderer's next-event estimation) equals the `dirac`
/// plane (the Dirac lights' exact light at the same camera samples, which `lumo denoise` keeps
/// out of the filter) pixel by pixel (one light each: with two, the path tracer picks one per
/// sample and agrees only in expectation); the frame is black where every camera sample lies
/// beyond the range, and lit near the light.
#[test]
fn the_dirac_plane_and_the_frame_agree_on_ranged_lights() {
    let point = Light::Point {
        position: Vec3::new(-1.0, HEIGHT, 0.0),
        intensity: Vec3::splat(3.0),
        range: Some(1.5),
    };
    let spot = Light::Spot {
        position: Vec3::new(1.2, HEIGHT, 0.5),
        direction: -Vec3::Y,
        intensity: Vec3::splat(5.0),
        beam_width: 20.0,
        cutoff: 70.0,
        falloff: SpotFalloff::SquaredCosine,
        range: Some(1.8),
    };
    for (name, light) in [("point", point), ("spot", spot)] {
        let rs = floor_with(light);
        let s = RenderSettings {
            width: 32,
            height: 32,
            spp: 4,
            seed: 3,
            path: PathSettings::default(),
        };
        let (frame, _) = render(&rs, &s, &|_| {});
        let camera = PinholeCamera::new(&rs.scene.camera, s.width, s.height);
        let dirac = dirac_direct(&rs, &camera, &s).expect("the scene has a Dirac light");
        let (mut black, mut lit) = (0, 0);
        for (i, (&f, &d)) in frame.direct.data.iter().zip(&dirac.data).enumerate() {
            assert!(
                (f - d).abs() <= 1e-4 * f.abs().max(d.abs()) + 1e-7,
                "{name}, value {i}: frame {f} vs dirac {d}"
            );
            assert_eq!(frame.indirect.data[i], 0.0, "nothing reflects back");
            if f == 0.0 {
                black += 1;
            } else {
                lit += 1;
            }
        }
        // The view spans about ±3.6 m of floor; the lights reach 1.1 m and 1.5 m from their
        // feet: a tenth to a sixth of the floor is lit.
        assert!(
            black > 2000 && lit > 150,
            "{name}: black {black}, lit {lit}"
        );
    }
}

/// The media tests' room (back wall, floor; box pixel filter) lit only by a point light of
/// range 1.3 near the floor (its range cuts the floor at 1.15 m from its foot and touches the
/// back wall) and a spot light of range 2 whose axis meets the floor at 1.8 (the window 0.34
/// there): without the window on every integrator's side the images differ by far more than
/// their noise.
fn ranged_room() -> RenderScene {
    let mut scene: Scene = room_scene("", "");
    for m in &mut scene.materials {
        // The room's own area light off: the ranged lights alone.
        m.emission = Vec3::ZERO;
        m.emission_map = None;
    }
    scene.lights.push(Light::Point {
        position: Vec3::new(-0.8, -0.6, -0.5),
        intensity: Vec3::new(3.0, 2.5, 2.0),
        range: Some(1.3),
    });
    scene.lights.push(Light::Spot {
        position: Vec3::new(0.9, 0.6, 0.0),
        direction: Vec3::new(-0.2, -1.0, -0.4),
        intensity: Vec3::splat(6.0),
        beam_width: 25.0,
        cutoff: 45.0,
        falloff: SpotFalloff::SquaredCosine,
        range: Some(2.0),
    });
    RenderScene::new(scene).unwrap()
}

#[test]
fn the_light_tracer_matches_the_path_tracer_under_ranged_lights() {
    let rs = ranged_room();
    assert!(rs.lights.range(0).is_some() && rs.lights.range(1).is_some());
    let light = |rs: &RenderScene, s: &RenderSettings| render_light(rs, s, &|_| {}).0.data;
    assert_matches_path(&rs, "light tracer, ranged lights", (32, 32), false, light);
    assert_matches_path(&rs, "spectral light tracer, ranged", (32, 32), true, light);
}

#[test]
fn bdpt_matches_the_path_tracer_under_ranged_lights() {
    let rs = ranged_room();
    let bdpt = |rs: &RenderScene, s: &RenderSettings| {
        let b = BdptSettings {
            path: s.path,
            only: None,
        };
        render_bdpt(rs, s, &b, &|_| {}).0.data
    };
    assert_matches_path(&rs, "bdpt, ranged lights", (32, 16), false, bdpt);
}

/// Photon mapping's image mean (its direct light is next-event estimation's; its photons,
/// stored from the second vertex on, carry the window of their first segment) agrees with
/// the path tracer's within 2 %, and its indirect light is a sizeable part of the image, so
/// photons that ignored the range (lighting the walls beyond it) would show.
#[test]
fn photon_mapping_matches_the_path_tracer_under_ranged_lights() {
    let rs = ranged_room();
    let s = settings(7, 64, false);
    let mean = |img: &[f32]| img.iter().map(|&v| v as f64).sum::<f64>() / img.len() as f64;
    let path = mean(&path_jittered(&rs, &settings(8, 256, false)));
    let direct_only = {
        let mut d = settings(8, 256, false);
        d.path.max_depth = 2;
        mean(&path_jittered(&rs, &d))
    };
    let ppm = PpmSettings {
        photons_per_pass: 1 << 15,
        ..PpmSettings::default()
    };
    let photons = mean(&render_ppm(&rs, &s, &ppm, &|_| {}).0.data);
    eprintln!("ranged room: path {path:.5} (direct {direct_only:.5}), ppm {photons:.5}");
    assert!(
        path - direct_only > 0.1 * path,
        "indirect light {:.5} of {path:.5}",
        path - direct_only
    );
    assert!(
        (photons / path - 1.0).abs() < 0.02,
        "photon mapping {photons:.5} vs path tracer {path:.5}"
    );
}
