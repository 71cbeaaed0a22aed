use glam::{Vec2, Vec3};
use lumo_scene::{builtin_scene, Light, Scene};

use super::*;
use crate::lights::SelectionRefusal;
use crate::{Integrator, IntegratorOptions, PathSettings, RenderSettings};

/// The Cornell box with a sun shining in through its open front (partly shadowed by the walls
/// and boxes) and one from above that the ceiling shadows entirely: by power the two suns
/// take most light samples, by measurement the area light does.
fn cornell_with_suns() -> Scene {
    let mut scene = builtin_scene("cornell").expect("built-in scene");
    scene.lights.push(Light::Directional {
        direction: Vec3::new(0.3, -0.5, -1.0),
        irradiance: Vec3::splat(2.0),
    });
    scene.lights.push(Light::Directional {
        direction: Vec3::new(0.0, -1.0, 0.0),
        irradiance: Vec3::splat(3.0),
    });
    scene
}

fn settings(w: usize, spp: u32, seed: u32) -> RenderSettings {
    RenderSettings {
        width: w,
        height: w,
        spp,
        seed,
        path: PathSettings {
            max_depth: 4,
            ..Default::default()
        },
    }
}

fn mean(image: &lumo_image::Image) -> f64 {
    image.channel_means().iter().sum::<f64>() / 3.0
}

fn piloted(scene: Scene) -> (RenderScene, PilotReport) {
    let mut rs = RenderScene::new(scene).expect("valid scene");
    let report = rs.select_lights_by_pilot(64, 64, &LightPilot::default());
    (rs, report)
}

#[test]
fn the_pilot_moves_samples_off_the_shadowed_suns_and_keeps_them_above_zero() {
    let (rs, report) = piloted(cornell_with_suns());
    assert!(report.applied);
    let power = RenderScene::new(cornell_with_suns()).expect("scene");
    let before = power.lights.group_pmf();
    let after = &report.group_pmf;
    assert_eq!(before.len(), 3, "area light, two suns");
    // The area light (group 0) gains; the sun the ceiling hides measures nothing and keeps
    // only the power term of the mixture.
    let mix = LightPilot::default().mix;
    assert!(after[0] > 2.0 * before[0], "{before:?} -> {after:?}");
    assert_eq!(
        report.shares[2], 0.0,
        "the sun above is shadowed everywhere"
    );
    assert!(
        (after[2] - mix * before[2]).abs() < 1e-5,
        "{before:?} -> {after:?}"
    );
    // No light with power falls to 0: at least `mix` of its power share.
    for (i, (p, q)) in power
        .lights
        .selection_pmf()
        .iter()
        .zip(rs.lights.selection_pmf())
        .enumerate()
    {
        assert!(q >= mix * p * 0.999, "light {i}: {q} < {mix}·{p}");
        assert!(*p == 0.0 || q > 0.0, "light {i} lost its probability");
    }
}

#[test]
fn the_mixture_refuses_a_mix_that_could_leave_a_light_out() {
    let mut rs = RenderScene::new(cornell_with_suns()).expect("scene");
    let shares = vec![1.0, 0.0, 0.0];
    assert_eq!(
        rs.lights.select_by_groups(&shares, 0.0),
        Err(SelectionRefusal::BadMix)
    );
    assert_eq!(
        rs.lights.select_by_groups(&[1.0], 0.2),
        Err(SelectionRefusal::WrongLength)
    );
    assert_eq!(
        rs.lights.select_by_groups(&[0.0; 3], 0.2),
        Err(SelectionRefusal::NoShares)
    );
    assert!(rs.lights.selection_is_power());
}

/// The MIS lookups (`triangle_pdf`, `environment_pdf`) give each light sample the density it
/// was drawn with, and the choice's frequencies are its probabilities.
#[test]
fn mis_densities_are_the_sampling_densities() {
    let mut scene = cornell_with_suns();
    scene.lights.push(Light::Constant {
        radiance: Vec3::splat(0.1),
    });
    let (rs, report) = piloted(scene);
    assert!(report.applied);
    let lights = &rs.lights;
    let pmf = lights.selection_pmf();
    let area = (0..rs.scene.instances.len())
        .find(|&i| {
            let mesh = &rs.scene.meshes[rs.scene.instances[i].mesh];
            rs.scene.materials[mesh.material].is_emissive()
        })
        .expect("the area light") as u32;
    let p = Vec3::new(0.1, -0.6, 0.2);
    let n = 20_000;
    let mut counts = vec![0usize; pmf.len()];
    let (mut triangles, mut environment) = (0, 0);
    for k in 0..n {
        let u = (k as f32 + 0.5) / n as f32;
        let v = Vec2::new(((k * 7919) % n) as f32 / n as f32, 0.37);
        let Some(ls) = lights.sample(p, u, v) else {
            continue;
        };
        counts[ls.light as usize] += 1;
        if lights.is_environment(ls.light) {
            let q = lights.environment_pdf(ls.wi);
            assert!((q - ls.pdf).abs() <= 1e-4 * ls.pdf, "{q} vs {}", ls.pdf);
            environment += 1;
        } else if ls.pdf > 0.0 {
            // The area light's triangles come first among the lights.
            let q = lights.triangle_pdf(area, ls.light, p, ls.point);
            assert!((q - ls.pdf).abs() <= 1e-3 * ls.pdf, "{q} vs {}", ls.pdf);
            triangles += 1;
        }
    }
    assert!(
        triangles > 1000 && environment > 10,
        "{triangles} {environment}"
    );
    for (i, &c) in counts.iter().enumerate() {
        let f = c as f32 / n as f32;
        assert!((f - pmf[i]).abs() < 2e-3, "light {i}: {f} vs {}", pmf[i]);
    }
}

/// Image means with the pilot's choice equal those by power, for the path tracer (RGB and
/// spectral) and BDPT (each image is unbiased; a density lookup that disagreed with the
/// choice would move the mean by several per cent).
#[test]
fn the_pilot_keeps_every_integrators_mean() {
    let power = RenderScene::new(cornell_with_suns()).expect("scene");
    let (pilot, _) = piloted(cornell_with_suns());
    let options = IntegratorOptions::default();
    let runs = [
        (Integrator::Path, false, 64, 0.01),
        (Integrator::Path, true, 64, 0.015),
        (Integrator::Bdpt, false, 32, 0.015),
    ];
    for (integrator, spectral, spp, tolerance) in runs {
        let mut s = settings(32, spp, 5);
        s.path.spectral = spectral;
        let a = mean(&integrator.render_image(&power, &s, &options, &|_| {}).image);
        let b = mean(&integrator.render_image(&pilot, &s, &options, &|_| {}).image);
        assert!(
            (a / b - 1.0).abs() < tolerance,
            "{integrator:?} (spectral {spectral}): power {a}, pilot {b}"
        );
    }
}

/// The pilot gives the same shares, bit for bit, on one thread and on two.
#[test]
fn the_pilot_does_not_depend_on_the_thread_count() {
    let rs = RenderScene::new(cornell_with_suns()).expect("scene");
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
            .install(|| measure(&rs, 96, 64, &LightPilot::default()))
    };
    let one = run(1);
    assert!(one.first.iter().any(|&s| s > 0.0));
    let bits = |v: &[f64]| v.iter().map(|s| s.to_bits()).collect::<Vec<_>>();
    let two = run(2);
    assert_eq!(bits(&one.first), bits(&two.first));
    assert_eq!(bits(&one.second), bits(&two.second));
    assert_eq!(bits(&one.weighted), bits(&two.weighted));
}

/// An update (a new pose) keeps the measured choice; a scene with one light group skips the
/// pilot.
#[test]
fn updates_keep_the_choice_and_one_group_needs_none() {
    let (mut rs, _) = piloted(cornell_with_suns());
    let before = rs.lights.selection_pmf();
    rs.update(&[]).expect("update");
    assert!(!rs.lights.selection_is_power());
    assert_eq!(before, rs.lights.selection_pmf());
    let (single, report) = piloted(builtin_scene("cornell").expect("scene"));
    assert!(!report.applied);
    assert!(single.lights.selection_is_power());
}
