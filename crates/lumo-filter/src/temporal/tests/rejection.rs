//! Tests of the history rejection where the lighting changes, and of the unfiltered history.

use lumo_image::Image;

use super::super::*;
use super::bare_input;
use crate::bench::synthetic::{splitmix, synthetic_frame};

/// A flat, camera-facing G-buffer (depth 2).
fn flat_planes(w: usize, h: usize) -> (Image, Image) {
    let mut normal = Image::new(w, h, 3, 0.0);
    for n in normal.data.chunks_exact_mut(3) {
        n[2] = 1.0;
    }
    (normal, Image::new(w, h, 1, 2.0))
}

/// Lighting `light(x)` with ±50 % uniform noise per pixel and channel (seeded per frame).
fn lit(w: usize, h: usize, seed: u64, light: impl Fn(usize) -> f32) -> Image {
    let mut s = seed;
    let mut img = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            let l = light(x);
            for c in img.pixel_mut(x, y) {
                *c = l * (0.5 + splitmix(&mut s));
            }
        }
    }
    img
}

fn mean_over(img: &Image, xs: std::ops::Range<usize>, ys: std::ops::Range<usize>) -> f32 {
    let (mut s, mut n) = (0.0, 0.0);
    for y in ys {
        for x in xs.clone() {
            s += img.pixel(x, y)[0];
            n += 1.0;
        }
    }
    s / n
}

/// Runs 12 frames of uniform light 1, then 2 frames where the left half dims to 0.2 under the
/// same still camera (the reprojection tests all pass); returns the last output and the mean
/// rejection over the frames before the change and the rejection on the frame of the change.
fn dimmed(params: TemporalParams) -> (Image, f32, Vec<f32>) {
    let (w, h) = (48, 32);
    let (normal, depth) = flat_planes(w, h);
    let mut f = TemporalFilter::new(params).unwrap();
    let mut out = Image::new(0, 0, 3, 0.0);
    let mut still = 0.0;
    let mut at_change = vec![];
    for k in 0..14u64 {
        let color = lit(
            w,
            h,
            77 + k,
            |x| if k >= 12 && x < w / 2 { 0.2 } else { 1.0 },
        );
        let fr = bare_input(&color, &normal, &depth);
        out = f.filter(&fr).unwrap().image;
        if (1..12).contains(&k) {
            still += f.rejection().iter().sum::<f32>() / (w * h) as f32 / 11.0;
        }
        if k == 12 {
            at_change = f.rejection().to_vec();
        }
    }
    (out, still, at_change)
}

#[test]
fn lighting_change_under_a_still_camera_drops_the_history() {
    let (out, still, lambda) = dimmed(TemporalParams::default());
    let left = mean_over(&out, 2..19, 2..30);
    assert!((left - 0.2).abs() < 0.05, "dimmed half shows {left}");
    let right = mean_over(&out, 29..46, 2..30);
    assert!((right - 1.0).abs() < 0.05, "lit half shows {right}");
    // The rejection fired where the light changed, and (nearly) never on the still frames.
    let w = 48;
    assert!(lambda[16 * w + 8] > 0.9, "{}", lambda[16 * w + 8]);
    assert_eq!(lambda[16 * w + 40], 0.0);
    assert!(still < 0.01, "mean rejection {still} with unchanged light");
    // Without the rejection the history keeps yesterday's light: the test means something.
    let off = TemporalParams {
        gradient_radius: 0,
        ..TemporalParams::default()
    };
    let (out, still, _) = dimmed(off);
    assert!(mean_over(&out, 2..19, 2..30) > 0.6);
    assert_eq!(still, 0.0);
}

#[test]
fn unfiltered_history_converges_on_a_still_scene() {
    // As `static_noisy_scene_converges_below_single_frame_atrous`, with the accumulated colour
    // as history (the CLI's setting) and the rejection on: the error keeps falling.
    let (w, h, runs) = (96, 96, 4u64);
    let mut errors = [0.0f64; 10];
    for run in 0..runs {
        let p = TemporalParams {
            filtered_history: false,
            ..TemporalParams::default()
        };
        let mut f = TemporalFilter::new(p).unwrap();
        for k in 0..10u64 {
            let fr = synthetic_frame(w, h, 1, 500 + 1000 * run + k);
            let out = f.filter(&super::tests::still_input(&fr)).unwrap();
            let e: f64 = out
                .image
                .data
                .iter()
                .zip(&fr.reference.data)
                .map(|(a, b)| ((a - b) as f64).powi(2))
                .sum::<f64>()
                / out.image.data.len() as f64;
            errors[k as usize] += e / runs as f64;
        }
    }
    eprintln!("MSE per frame {errors:?}");
    assert!(errors[9] < 0.4 * errors[0], "{errors:?}");
    assert!(errors[9] < errors[4], "{errors:?}");
}

#[test]
fn gradient_parameters_are_checked() {
    for p in [
        TemporalParams {
            gradient_radius: 17,
            ..TemporalParams::default()
        },
        TemporalParams {
            gradient_sigmas: f32::NAN,
            ..TemporalParams::default()
        },
        TemporalParams {
            gradient_gain: -1.0,
            ..TemporalParams::default()
        },
    ] {
        assert!(TemporalFilter::new(p).is_err());
    }
}

/// Runs 40 frames of a uniform light brightening by 3 % a frame under a still camera, with
/// re-shaded samples at every ninth pixel reporting that change (same paths: the same random
/// value times the light then and now); returns the last output's mean over the light.
fn brightening(params: TemporalParams) -> (f32, f32) {
    let (w, h) = (36, 27);
    let (normal, depth) = flat_planes(w, h);
    let mut f = TemporalFilter::new(params).unwrap();
    let light = |k: u64| 1.03f32.powi(k as i32);
    let mut out = Image::new(0, 0, 3, 0.0);
    for k in 0..40u64 {
        let color = lit(w, h, 300 + k, |_| light(k));
        let changes: Vec<ShadingChange> = (0..w * h)
            .step_by(9)
            .map(|i| {
                let u = 0.5 + (i % 7) as f32 / 7.0;
                ShadingChange {
                    pixel: i,
                    now: u * light(k),
                    before: u * light(k.saturating_sub(1)),
                }
            })
            .collect();
        let fr = bare_input(&color, &normal, &depth);
        out = f.filter_reshaded(&fr, Some(&changes)).unwrap().image;
    }
    (mean_over(&out, 4..32, 4..23), light(39))
}

#[test]
fn a_rescaled_history_follows_a_brightening_light() {
    let seq = TemporalParams::sequence();
    let (rescaled, truth) = brightening(seq.clone());
    let (rejected, _) = brightening(TemporalParams {
        reshade_rescale: false,
        ..seq.clone()
    });
    let (ignored, _) = brightening(TemporalParams {
        reshade_radius: 0,
        ..seq
    });
    let err = |v: f32| (v / truth - 1.0).abs();
    assert!(err(rescaled) < 0.03, "rescaled {rescaled} vs {truth}");
    // Rejection alone shortens the history but still lags; no rejection lags most.
    assert!(
        err(rejected) > 2.0 * err(rescaled),
        "{rejected} vs {rescaled}"
    );
    assert!(err(ignored) > err(rejected), "{ignored} vs {rejected}");
}
