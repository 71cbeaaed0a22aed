//! Spectral transport: furnaces with the answer integrated independently over wavelength, a
//! grey scene that must render as the RGB renderer renders it, dispersion at a glass surface,
//! and thread-count independence.

use crate::common;

use glam::Vec3;
use lumo_render::{render, PathSettings, RenderScene, RenderSettings};
use lumo_scene::{BsdfSpec, Material, Roughness};
use lumo_spectrum::cie::{d65, spectrum_to_xyz, XYZ_TO_SRGB};
use lumo_spectrum::upsample::reflectance;
use lumo_spectrum::{coefficients, Glass, Wavelengths};

fn settings(w: usize, h: usize, spp: u32, max_depth: u32, spectral: bool) -> RenderSettings {
    RenderSettings {
        width: w,
        height: h,
        spp,
        seed: 3,
        path: PathSettings {
            max_depth,
            spectral,
            ..Default::default()
        },
    }
}

fn mean(img: &lumo_image::Image) -> Vec3 {
    let m = img.channel_means();
    Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32)
}

/// Inside a closed sphere of reflectance ρ emitting Le the radiance is Le / (1 − ρ) at every
/// wavelength. For a coloured ρ that is not the RGB formula applied per channel: the expected
/// RGB is integrated here over wavelength from the upsampled spectrum (D65-weighted emitter),
/// independently of the renderer.
#[test]
fn spectral_furnace_sums_the_series_per_wavelength() {
    for (rho, le) in [(Vec3::splat(0.6), 1.0f32), (Vec3::new(0.8, 0.45, 0.2), 0.5)] {
        let mut scene = common::furnace_sphere(0.5, le);
        scene.materials[0] = Material::diffuse("wall", rho).with_emission(Vec3::splat(le));
        let rs = RenderScene::new(scene).unwrap();
        let (frame, _) = render(&rs, &settings(12, 12, 64, 400, true), &|_| {});
        let got = mean(&frame.color);
        let s = coefficients(rho);
        let want = XYZ_TO_SRGB * spectrum_to_xyz(|l| le * d65(l) / (1.0 - s.eval(l)));
        // The RGB renderer's per-channel answer, to show the test tells the two apart.
        let rgb_formula = Vec3::splat(le) / (Vec3::ONE - rho);
        assert!(
            (got - want).abs().max_element() < 0.015 * want.max_element(),
            "ρ {rho}: spectral furnace {got}, integrated {want} (RGB formula {rgb_formula})"
        );
        if rho.x != rho.y {
            // Multiple bounces saturate a spectrum differently from its RGB: the coloured case
            // separates spectral transport from RGB transport by far more than the tolerance.
            assert!(
                (rgb_formula - want).abs().max_element() > 0.05 * want.max_element(),
                "{rgb_formula} vs {want}"
            );
        }
    }
}

/// Grey reflectances and a white light have flat spectra: spectral and RGB transport render
/// the same image (up to noise).
#[test]
fn a_grey_scene_renders_as_in_rgb() {
    let scene = common::light_over_floor(4.0, 1.0);
    let rs = RenderScene::new(scene).unwrap();
    let rgb = mean(
        &render(&rs, &settings(24, 24, 64, 5, false), &|_| {})
            .0
            .color,
    );
    let spectral = mean(&render(&rs, &settings(24, 24, 64, 5, true), &|_| {}).0.color);
    assert!(
        (spectral - rgb).abs().max_element() < 0.01 * rgb.max_element(),
        "spectral {spectral} vs RGB {rgb}"
    );
    // Grey stays grey: no colour cast from D65 or the observer.
    assert!(
        (spectral.x - spectral.z).abs() < 0.01 * spectral.y,
        "{spectral}"
    );
}

/// A coloured diffuse surface seen under the white light reflects its upsampled spectrum.
#[test]
fn reflectance_spectra_come_from_the_upsampling() {
    let wl = Wavelengths::fixed([450.0, 550.0, 650.0]);
    let red = Vec3::new(0.7, 0.1, 0.05);
    let r = reflectance(red, &wl);
    assert!(r.z > 0.5 && r.x < 0.15, "{r}");
}

/// The same seed gives the same bits on one and two threads under spectral transport.
#[test]
fn spectral_images_are_thread_count_independent() {
    let scene = lumo_scene::builtin_scene("cornell-spheres").unwrap();
    let rs = RenderScene::new(scene).unwrap();
    let s = settings(32, 24, 2, 6, true);
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| render(&rs, &s, &|_| {}).0.color)
    };
    let (a, b) = (run(1), run(2));
    assert!(a
        .data
        .iter()
        .zip(&b.data)
        .all(|(p, q)| p.to_bits() == q.to_bits()));
}

/// A dispersive glass takes its index at the hero wavelength and stops the other lanes; a
/// glass without dispersion keeps its index and all lanes.
#[test]
fn dispersive_glass_refracts_the_hero_alone() {
    let mut scene = common::light_over_floor(1.0, 1.0);
    let bk7 = Glass::named("bk7").unwrap();
    for m in &mut scene.materials {
        m.bsdf = BsdfSpec::Dielectric {
            ior: 1.5046,
            roughness: Roughness::SMOOTH,
        };
        m.spectra.dispersion = Some((bk7, 1.0));
    }
    let rs = RenderScene::new(scene).unwrap();
    let (o, d) = (Vec3::new(0.0, 3.0, 0.3), Vec3::new(0.0, -1.0, 0.0));
    let hit = rs
        .accel
        .intersect(o, d, 0.0, f32::INFINITY)
        .expect("hits the floor");
    let s = rs.surface(&hit, o, d);
    for hero in [420.0f32, 587.56, 680.0] {
        let mut wl = Wavelengths::fixed([hero, 500.0, 600.0]);
        let b = rs.spectral_bsdf(rs.bsdf(&s), &s, &mut wl);
        let lumo_render::bsdf::Bsdf::Dielectric(g) = b.bsdf else {
            panic!("not a dielectric")
        };
        let want = 1.5046 + bk7.sellmeier(hero) - bk7.sellmeier(587.56);
        assert!(
            (g.eta - want).abs() < 1e-6,
            "{hero} nm: η {} vs {want}",
            g.eta
        );
        assert!(wl.is_terminated());
    }
    // Blue bends more than red.
    assert!(bk7.ior(1.5046, 420.0) > bk7.ior(1.5046, 680.0) + 0.008);
}

/// The spectral light tracer estimates the spectral path tracer's image: per channel, on a
/// scene with saturated walls (where spectral and RGB transport differ).
#[test]
fn spectral_light_tracing_agrees_with_spectral_path_tracing() {
    let rs = RenderScene::new(lumo_scene::builtin_scene("cornell").unwrap()).unwrap();
    let s = settings(24, 24, 256, 4, true);
    let (light, _) = lumo_render::render_light(&rs, &s, &|_| {});
    let path = render(&rs, &s, &|_| {}).0.color;
    let (l, p) = (mean(&light), mean(&path));
    assert!(
        (l / p - Vec3::ONE).abs().max_element() < 0.03,
        "light tracer {l} vs path tracer {p}"
    );
    let rgb = mean(
        &render(&rs, &settings(24, 24, 256, 4, false), &|_| {})
            .0
            .color,
    );
    eprintln!("spectral path {p}, spectral light {l}, RGB path {rgb}");
}
