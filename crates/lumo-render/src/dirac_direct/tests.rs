use super::*;
use crate::{render, PathSettings};
use lumo_scene::{builtin_scene, Light, Scene};

/// The Cornell box with its ceiling light switched off and `lights` instead.
fn lit_by(lights: Vec<Light>) -> Scene {
    let mut scene = builtin_scene("cornell").expect("built-in");
    for m in &mut scene.materials {
        m.emission = Vec3::ZERO;
    }
    scene.lights = lights;
    scene
}

fn point() -> Light {
    Light::Point {
        position: Vec3::new(0.1, 0.6, 0.2),
        intensity: Vec3::new(1.5, 1.2, 0.9),
        range: None,
    }
}

fn settings(spp: u32, max_depth: u32) -> RenderSettings {
    RenderSettings {
        width: 24,
        height: 24,
        spp,
        seed: 7,
        path: PathSettings {
            max_depth,
            ..PathSettings::default()
        },
    }
}

/// With one point light and direct light only (max depth 2), every camera sample of the path
/// tracer holds exactly the pass's value (it can pick no other light), so the pixel means
/// agree to rounding; with two Dirac lights the path tracer picks one per sample and its
/// mean over many samples converges to the pass. Below [`MIN_SAMPLES`] the pass takes that
/// many of the frame's samples: a 1-spp frame's pass is its 4-spp frame's.
#[test]
fn the_pass_is_the_path_tracers_dirac_light_at_the_first_hit() {
    let rs = RenderScene::new(lit_by(vec![point()])).expect("scene");
    for spp in [MIN_SAMPLES, 2 * MIN_SAMPLES] {
        let s = settings(spp, 2);
        let camera = PinholeCamera::new(&rs.scene.camera, s.width, s.height);
        let pass = dirac_direct(&rs, &camera, &s).expect("a point light");
        let (frame, _) = render(&rs, &s, &|_| {});
        let mut lit = 0;
        for (a, b) in pass.data.iter().zip(&frame.color.data) {
            assert!((a - b).abs() <= 1e-5 * b.abs().max(1e-3), "{a} vs {b}");
            lit += (*b > 0.0) as usize;
        }
        assert!(lit > pass.data.len() / 2, "{lit} lit values");
    }
    let camera = PinholeCamera::new(&rs.scene.camera, 24, 24);
    assert_eq!(
        dirac_direct(&rs, &camera, &settings(1, 2)).map(|p| p.data),
        dirac_direct(&rs, &camera, &settings(MIN_SAMPLES, 2)).map(|p| p.data)
    );
    let sun = Light::Directional {
        direction: Vec3::new(0.2, -1.0, -0.3),
        irradiance: Vec3::splat(0.8),
    };
    let rs = RenderScene::new(lit_by(vec![point(), sun])).expect("scene");
    let s = settings(1024, 2);
    let camera = PinholeCamera::new(&rs.scene.camera, s.width, s.height);
    let pass = dirac_direct(&rs, &camera, &settings(4, 2)).expect("Dirac lights");
    let (frame, _) = render(&rs, &s, &|_| {});
    let mean = |d: &[f32]| d.iter().map(|&v| v as f64).sum::<f64>() / d.len() as f64;
    let (p, c) = (mean(&pass.data), mean(&frame.color.data));
    assert!((p / c - 1.0).abs() < 0.01, "pass mean {p}, path tracer {c}");
}

/// At a full depth the pass is only the first hit's share: below the colour everywhere.
#[test]
fn the_pass_stays_below_the_full_colour() {
    let rs = RenderScene::new(lit_by(vec![point()])).expect("scene");
    let s = settings(4, 6);
    let camera = PinholeCamera::new(&rs.scene.camera, s.width, s.height);
    let pass = dirac_direct(&rs, &camera, &s).expect("a point light");
    let (frame, _) = render(&rs, &s, &|_| {});
    for (a, b) in pass.data.iter().zip(&frame.color.data) {
        assert!(*a <= b + 1e-5 * b.abs().max(1e-3), "{a} vs {b}");
    }
}

/// No pass without Dirac lights, with spectral transport, without next-event estimation or
/// with direct light cut off.
#[test]
fn no_pass_where_the_renderer_would_differ() {
    let none = RenderScene::new(builtin_scene("cornell").expect("built-in")).expect("scene");
    let s = settings(1, 4);
    let camera = PinholeCamera::new(&none.scene.camera, s.width, s.height);
    assert!(dirac_direct(&none, &camera, &s).is_none());
    let rs = RenderScene::new(lit_by(vec![point()])).expect("scene");
    assert!(dirac_direct(&rs, &camera, &s).is_some());
    let with = |f: &dyn Fn(&mut RenderSettings)| {
        let mut s = settings(1, 4);
        f(&mut s);
        dirac_direct(&rs, &camera, &s)
    };
    assert!(with(&|s| s.path.spectral = true).is_none());
    assert!(with(&|s| s.path.nee = false).is_none());
    assert!(with(&|s| s.path.max_depth = 1).is_none());
}
