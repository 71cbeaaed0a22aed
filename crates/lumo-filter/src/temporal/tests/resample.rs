//! Tests of the history resampling (Catmull-Rom), the neighbourhood clamp and the
//! short-history À-Trous.

use lumo_image::{luminance, Image};

use super::super::gradient::clamp_bounds;
use super::super::reproject::{catmull_rom_weights, clamp_history, Prev};
use super::super::*;
use super::{bare_input, still_input};
use crate::bench::synthetic::{splitmix, synthetic_frame};

/// A flat G-buffer (every pixel faces the camera at depth 2), no albedo.
fn planes(w: usize, h: usize) -> (Image, Image) {
    let mut normal = Image::new(w, h, 3, 0.0);
    for n in normal.data.chunks_exact_mut(3) {
        n[2] = 1.0;
    }
    (normal, Image::new(w, h, 1, 2.0))
}

/// The reprojected history after a first frame `f(x, y)` (grey) and a second frame moved by
/// `motion`, with `resample`.
fn reprojected(resample: Resample, f: &dyn Fn(f32, f32) -> f32, motion: [f32; 2]) -> Image {
    let (w, h) = (24, 20);
    let (normal, depth) = planes(w, h);
    let mut color = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            color.pixel_mut(x, y).fill(f(x as f32, y as f32));
        }
    }
    let mut m = Image::new(w, h, 2, 0.0);
    for v in m.data.chunks_exact_mut(2) {
        v.copy_from_slice(&motion);
    }
    let p = TemporalParams {
        resample,
        // The history is then the first frame itself.
        filtered_history: false,
        ..TemporalParams::default()
    };
    let mut filter = TemporalFilter::new(p).unwrap();
    let mut frame = bare_input(&color, &normal, &depth);
    filter.filter(&frame).unwrap();
    frame.motion = Some(&m);
    filter.filter(&frame).unwrap();
    filter.reprojected_history().clone()
}

/// The largest error of the reprojected history against `f` at the moved positions, over the
/// pixels whose 4×4 taps lie inside the image.
fn max_error(re: &Image, f: &dyn Fn(f32, f32) -> f32, motion: [f32; 2]) -> f32 {
    let mut worst = 0.0f32;
    for y in 3..re.height - 3 {
        for x in 3..re.width - 3 {
            let want = f(x as f32 + motion[0], y as f32 + motion[1]);
            for &v in re.pixel(x, y) {
                worst = worst.max((v - want).abs());
            }
        }
    }
    worst
}

#[test]
fn catmull_rom_weights_partition_unity_and_interpolate() {
    for t in [0.0, 0.25, 0.5, 0.9] {
        let w = catmull_rom_weights(t);
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6, "{t}: {w:?}");
        // First moment: the weighted tap positions −1, 0, 1, 2 give t.
        let m: f32 = w
            .iter()
            .enumerate()
            .map(|(k, w)| (k as f32 - 1.0) * w)
            .sum();
        assert!((m - t).abs() < 1e-6, "{t}: {m}");
    }
    assert_eq!(catmull_rom_weights(0.0), [0.0, 1.0, 0.0, 0.0]);
}

#[test]
fn resampling_reads_a_ramp_exactly_and_catmull_rom_a_parabola() {
    let motion = [0.3, -0.6];
    let ramp = |x: f32, y: f32| 1.0 + 0.1 * x + 0.05 * y;
    for r in [Resample::Bilinear, Resample::CatmullRom] {
        let e = max_error(&reprojected(r, &ramp, motion), &ramp, motion);
        assert!(e < 1e-5, "{r:?}: {e}");
    }
    // A parabola: Catmull-Rom reproduces it, bilinear is off by 0.02·f(1 − f) per axis.
    let parabola = |x: f32, y: f32| 1.0 + 0.02 * x * x + 0.01 * y * y;
    let e_cr = max_error(
        &reprojected(Resample::CatmullRom, &parabola, motion),
        &parabola,
        motion,
    );
    let e_bl = max_error(
        &reprojected(Resample::Bilinear, &parabola, motion),
        &parabola,
        motion,
    );
    assert!(e_cr < 1e-4, "{e_cr}");
    assert!(e_bl > 4e-3, "{e_bl}");
}

#[test]
fn catmull_rom_does_not_ring_at_a_step() {
    let step = |x: f32, _: f32| if x < 12.0 { 0.0 } else { 1.0 };
    for dx in [0.25, 0.5, 0.75] {
        let re = reprojected(Resample::CatmullRom, &step, [dx, 0.0]);
        for (i, v) in re.data.iter().enumerate() {
            assert!(v.is_nan() || (0.0..=1.0).contains(v), "{dx}: {i}: {v}");
        }
    }
}

#[test]
fn clamping_never_widens() {
    let mut s = 11u64;
    for _ in 0..2000 {
        let c = [0, 1, 2].map(|_| 3.0 * splitmix(&mut s));
        let lo = 2.0 * splitmix(&mut s) - 0.5;
        let hi = lo + 2.0 * splitmix(&mut s);
        let prev = Prev {
            color: c,
            moments: [1.0, 2.0],
            len: 3,
        };
        let out = clamp_history(prev, Some([lo, hi]));
        let (l0, l1) = (luminance(c), luminance(out.color));
        let dist = |l: f32| (lo - l).max(l - hi).max(0.0);
        assert!(dist(l1) <= dist(l0) + 1e-5, "{l0} → {l1} in [{lo}, {hi}]");
        // Inside afterwards, unless the interval lies below 0 (the colour stops at black).
        if l0 > 0.0 && hi >= 0.0 {
            assert!(dist(l1) < 1e-4 * (1.0 + l0), "{l0} → {l1} in [{lo}, {hi}]");
        }
        if (lo..=hi).contains(&l0) {
            assert_eq!(out.color, c, "inside: unchanged");
        }
        assert_eq!((out.moments, out.len), (prev.moments, prev.len));
    }
    let prev = Prev {
        color: [1.0; 3],
        ..Prev::default()
    };
    assert_eq!(clamp_history(prev, None).color, [1.0; 3]);
}

#[test]
fn clamp_bounds_are_mean_plus_minus_gamma_sd() {
    // Samples 1 and 3: mean 2, standard deviation 1.
    let b = clamp_bounds([2.0, 4.0, 10.0, 0.0, 0.0], 1.5);
    assert!(
        (b[0] - 0.5).abs() < 1e-6 && (b[1] - 3.5).abs() < 1e-6,
        "{b:?}"
    );
    assert_eq!(
        clamp_bounds([1.0, 1.0, 1.0, 0.0, 0.0], 1.0)[1],
        f32::INFINITY
    );
}

#[test]
fn short_history_levels_take_over_on_a_fresh_history() {
    let fr = synthetic_frame(40, 32, 1, 5);
    let run = |p: TemporalParams| {
        let mut f = TemporalFilter::new(p).unwrap();
        f.filter(&still_input(&fr)).unwrap().image
    };
    let mut two = TemporalParams::default();
    two.atrous.iterations = 2;
    let mut five = two.clone();
    five.atrous.iterations = 5;
    let short = TemporalParams {
        short_history_levels: 5,
        short_history_frames: 4,
        ..two.clone()
    };
    // Every pixel starts with a history of 1: the short-history output is the 5-level one.
    assert_eq!(run(short), run(five.clone()));
    assert_ne!(run(two), run(five));
    assert_eq!(super::short_weight(1, 4.0), 1.0);
    assert_eq!(super::short_weight(3, 4.0), 0.5);
    assert_eq!(super::short_weight(5, 4.0), 0.0);
    assert_eq!(super::short_weight(0, 4.0), 0.0);
}

#[test]
fn new_parameters_are_checked() {
    for p in [
        TemporalParams {
            clamp_sigmas: -1.0,
            ..TemporalParams::default()
        },
        TemporalParams {
            clamp_sigmas: f32::NAN,
            ..TemporalParams::default()
        },
        TemporalParams {
            short_history_levels: 17,
            ..TemporalParams::default()
        },
    ] {
        assert!(TemporalFilter::new(p).is_err());
    }
}

#[test]
fn scaled_variance_is_the_sample_variance_times_the_history_share() {
    let (w, h) = (32, 24);
    let frames: Vec<_> = (0..12).map(|k| synthetic_frame(w, h, 1, 70 + k)).collect();
    let run = |scale_variance: bool| {
        let p = TemporalParams {
            alpha: 0.2,
            alpha_moments: 0.2,
            filtered_history: false,
            gradient_radius: 0,
            scale_variance,
            ..TemporalParams::default()
        };
        let mut f = TemporalFilter::new(p).unwrap();
        let mut out = vec![];
        for fr in &frames {
            f.filter(&still_input(fr)).unwrap();
            out.push((f.variance().clone(), f.history_length().to_vec()));
        }
        out
    };
    let (plain, scaled) = (run(false), run(true));
    let mut checked = 0;
    for ((v0, len), (v1, _)) in plain.iter().zip(&scaled) {
        for i in 0..w * h {
            let n = len[i];
            if n < 4 {
                // The spatial estimate of a short history is not scaled.
                assert_eq!(v0.data[i], v1.data[i]);
                continue;
            }
            // 1/n while the mean is plain (n ≤ 5), then α/(2 − α) = 1/9.
            let share = (1.0 / n as f32).max(0.2 / 1.8);
            assert!(
                (v1.data[i] - share * v0.data[i]).abs() <= 1e-6 * (1.0 + v0.data[i]),
                "n {n}: {} vs {}",
                v1.data[i],
                v0.data[i]
            );
            checked += 1;
        }
    }
    assert!(checked > 1000, "{checked}");
}
