//! Photon mapping against the path tracer, across thread counts, and its warnings.

use glam::Vec3;
use lumo_image::luminance;
use lumo_scene::{builtin_scene, BsdfSpec};

use super::*;
use crate::{render, render_ppm, RenderSettings};

/// Mean luminance over `b`×`b` blocks of an RGB image.
fn blocks(rgb: impl Fn(usize, usize) -> [f32; 3], w: usize, h: usize, b: usize) -> Vec<f32> {
    let mut out = vec![0.0; (w / b) * (h / b)];
    for y in 0..h {
        for x in 0..w {
            out[(y / b) * (w / b) + x / b] += luminance(rgb(x, y)) / (b * b) as f32;
        }
    }
    out
}

fn cornell() -> RenderScene {
    RenderScene::new(builtin_scene("cornell").expect("builtin")).expect("scene")
}

/// PPM converges to the path tracer: on the Cornell box at 32×32, the image means agree
/// within 2 % and every 8×8 block mean within 6 % (of the block, or of 0.05 for dark ones).
/// Radius 2 % of the diagonal at pass 0 (the default setting at this pass size) and 96 passes of 4 photon paths per pixel: the
/// remaining bias (light smeared over r ≈ 1 % of the box at the end) is below the noise.
#[test]
fn cornell_matches_the_path_tracer() {
    let rs = cornell();
    let (w, h) = (32, 32);
    let path = PathSettings {
        max_depth: 4,
        ..Default::default()
    };
    let reference = RenderSettings {
        width: w,
        height: h,
        spp: 256,
        seed: 1,
        path,
    };
    let (pt, _) = render(&rs, &reference, &|_| {});
    let ppm = PpmSettings {
        photons_per_pass: 4 * (w * h) as u64,
        // 2 % of the diagonal at 4096 paths per pass.
        radius: 0.0025,
        ..Default::default()
    };
    let settings = RenderSettings {
        spp: 96,
        seed: 2,
        ..reference
    };
    let (img, stats) = render_ppm(&rs, &settings, &ppm, &|_| {});
    assert!(stats.photons_gathered > 0 && stats.generations == 0);
    let a = blocks(|x, y| pt.color.rgb(x, y), w, h, 8);
    let b = blocks(|x, y| img.rgb(x, y), w, h, 8);
    let mean_a = a.iter().sum::<f32>() / a.len() as f32;
    let mean_b = b.iter().sum::<f32>() / b.len() as f32;
    assert!(
        (mean_a - mean_b).abs() < 0.02 * mean_a,
        "image means differ: path {mean_a}, ppm {mean_b}"
    );
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs() / x.max(0.05))
        .fold(0.0f32, f32::max);
    eprintln!("means: path {mean_a}, ppm {mean_b}; worst block {worst}");
    for (i, (x, y)) in a.iter().zip(&b).enumerate() {
        assert!(
            (x - y).abs() < 0.06 * x.max(0.05),
            "block {i}: path {x}, ppm {y}"
        );
    }
}

/// Without photons (indirect light off) the image is visibly darker than the path tracer's:
/// the convergence test above is not passing on direct light alone.
#[test]
fn photons_carry_the_indirect_light() {
    let rs = cornell();
    let path = PathSettings {
        max_depth: 4,
        ..Default::default()
    };
    let settings = RenderSettings {
        width: 16,
        height: 16,
        spp: 8,
        seed: 3,
        path,
    };
    let with = PpmSettings {
        photons_per_pass: 4096,
        ..Default::default()
    };
    let without = PpmSettings {
        max_photons: 0,
        ..with
    };
    let mean = |img: &lumo_image::Image| img.data.iter().sum::<f32>() / img.data.len() as f32;
    let (a, _) = render_ppm(&rs, &settings, &with, &|_| {});
    let (b, sb) = render_ppm(&rs, &settings, &without, &|_| {});
    assert_eq!(sb.photons_stored, 0);
    assert!(mean(&a) > 1.15 * mean(&b), "{} vs {}", mean(&a), mean(&b));
}

#[test]
fn same_image_on_one_and_two_threads() {
    let rs = cornell();
    let settings = RenderSettings {
        width: 24,
        height: 16,
        spp: 3,
        seed: 9,
        path: PathSettings::default(),
    };
    let ppm = PpmSettings {
        photons_per_pass: 5000,
        // Small enough that the map starts a new generation within the render.
        max_photons: 12_000,
        ..Default::default()
    };
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        pool.install(|| render_ppm(&rs, &settings, &ppm, &|_| {}))
    };
    let (a, sa) = run(1);
    let (b, sb) = run(2);
    assert!(sa.generations > 0, "the capacity was never reached");
    // Insertions and gathers run in separate phases: the lock never waits.
    assert_eq!((sa.lock.read_waits, sa.lock.write_waits), (0, 0));
    assert_eq!((sb.lock.read_waits, sb.lock.write_waits), (0, 0));
    assert_eq!((sa.photons_stored, sa.rays), (sb.photons_stored, sb.rays));
    let bits = |i: &lumo_image::Image| i.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert!(
        bits(&a) == bits(&b),
        "images differ between 1 and 2 threads"
    );
}

#[test]
fn warns_once_about_scenes_it_cannot_render_fully() {
    let rs = cornell();
    let camera = PinholeCamera::new(&rs.scene.camera, 32, 32);
    let path = PathSettings::default();
    assert_eq!(scene_warning(&rs, &camera, &path), None);
    // No emitter: nothing emits photons.
    let mut dark = builtin_scene("cornell").expect("builtin");
    for m in &mut dark.materials {
        m.emission = Vec3::ZERO;
    }
    let dark = RenderScene::new(dark).expect("scene");
    let w = scene_warning(&dark, &camera, &path).expect("a warning");
    assert!(
        w.contains("no light emits photons") && !w.contains('\n'),
        "{w}"
    );
    // Every surface a mirror: nowhere to gather (and it still renders).
    let mut mirrors = builtin_scene("cornell").expect("builtin");
    for m in &mut mirrors.materials {
        m.bsdf = BsdfSpec::Mirror {
            reflectance: Vec3::splat(0.9),
        };
    }
    let mirrors = RenderScene::new(mirrors).expect("scene");
    let w = scene_warning(&mirrors, &camera, &path).expect("a warning");
    assert!(w.contains("no diffuse or glossy surface"), "{w}");
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 1,
        seed: 0,
        path,
    };
    let (img, _) = render_ppm(&mirrors, &settings, &PpmSettings::default(), &|_| {});
    assert!(img.data.iter().all(|v| v.is_finite()));
}

/// A pass far larger than the map stops tracing once it holds more photons than the map can
/// keep: 2^32 photon paths per pass with room for 1000 photons used to grow by 135 MB/s; it
/// now finishes at once, and the map still holds its longest prefix of whole paths that fits.
#[test]
fn a_pass_larger_than_the_map_stops_tracing_when_the_map_is_full() {
    let rs = cornell();
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 2,
        seed: 1,
        path: PathSettings::default(),
    };
    let ppm = PpmSettings {
        photons_per_pass: u32::MAX as u64,
        max_photons: 1000,
        ..Default::default()
    };
    let (img, stats) = render_ppm(&rs, &settings, &ppm, &|_| {});
    assert!(
        stats.photon_paths < 1 << 20,
        "{} paths traced",
        stats.photon_paths
    );
    assert!(
        stats.photons_stored > 0 && stats.photons_stored <= 1000,
        "{stats:?}"
    );
    assert_eq!(img.non_finite_count(), 0);
}
