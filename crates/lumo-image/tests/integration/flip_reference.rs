//! lumo's LDR-FLIP against NVIDIA's `flip-evaluator` package on the image pairs that
//! `scripts/check_flip.py` generated (numbers in tests/data/flip/reference.json).

use std::path::PathBuf;

use lumo_image::metrics::{flip, flip_map, FlipSettings, FLIP_DEFAULT_PPD};
use lumo_image::read_image;

/// Largest accepted |lumo − flip-evaluator| of the mean FLIP of a pair. Measured with
/// flip-evaluator 1.7: at most 5.1e-6 (the "random" pair); the two differ only in float
/// rounding and the last digits of the colour-space constants.
const MEAN_TOLERANCE: f64 = 2e-5;
/// Largest accepted difference of a single pixel's FLIP value. Measured over every pixel of
/// every pair: at most 4.8e-5, borders included (both repeat edge pixels outside the image).
const PIXEL_TOLERANCE: f32 = 2e-4;

fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/flip")
}

/// The numbers of one pair in reference.json, parsed by hand to keep lumo-image free of a
/// JSON dependency: the file is machine-written with one key per line.
struct Pair {
    name: String,
    reference: String,
    test: String,
    mean: f64,
    samples: Vec<(usize, usize, f32)>,
}

fn value<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    let rest = line.trim().strip_prefix(&format!("\"{key}\": "))?;
    Some(rest.trim_end_matches(',').trim_matches('"'))
}

fn load() -> (f32, Vec<Pair>) {
    let text = std::fs::read_to_string(data_dir().join("reference.json")).unwrap();
    let mut ppd = 0.0;
    let mut pairs: Vec<Pair> = Vec::new();
    let mut sample: (usize, usize) = (0, 0);
    for line in text.lines() {
        if let Some(v) = value(line, "ppd") {
            ppd = v.parse().unwrap();
        } else if let Some(v) = value(line, "name") {
            pairs.push(Pair {
                name: v.into(),
                reference: String::new(),
                test: String::new(),
                mean: f64::NAN,
                samples: Vec::new(),
            });
        } else if let Some(p) = pairs.last_mut() {
            if let Some(v) = value(line, "reference") {
                p.reference = v.into();
            } else if let Some(v) = value(line, "test") {
                p.test = v.into();
            } else if let Some(v) = value(line, "mean_flip") {
                p.mean = v.parse().unwrap();
            } else if let Some(v) = value(line, "x") {
                sample.0 = v.parse().unwrap();
            } else if let Some(v) = value(line, "y") {
                sample.1 = v.parse().unwrap();
            } else if let Some(v) = value(line, "flip") {
                p.samples.push((sample.0, sample.1, v.parse().unwrap()));
            }
        }
    }
    (ppd, pairs)
}

#[test]
fn flip_matches_flip_evaluator() {
    let (ppd, pairs) = load();
    assert!(
        (ppd - FLIP_DEFAULT_PPD).abs() < 1e-3,
        "ppd {ppd} vs {FLIP_DEFAULT_PPD}"
    );
    assert!(
        pairs.len() >= 5,
        "reference.json lists {} pairs",
        pairs.len()
    );
    let settings = FlipSettings::default();
    for p in &pairs {
        let r = read_image(&data_dir().join(&p.reference)).unwrap();
        let t = read_image(&data_dir().join(&p.test)).unwrap();
        let mean = flip(&r, &t, &settings).unwrap();
        println!(
            "{:8} lumo {mean:.6}  flip-evaluator {:.6}  diff {:+.2e}",
            p.name,
            p.mean,
            mean - p.mean
        );
        assert!(
            (mean - p.mean).abs() < MEAN_TOLERANCE,
            "{}: lumo {mean} vs flip-evaluator {}",
            p.name,
            p.mean
        );
        let map = flip_map(&r, &t, &settings).unwrap();
        assert_eq!(p.samples.len(), 6, "{}", p.name);
        for &(x, y, expected) in &p.samples {
            let got = map.pixel(x, y)[0];
            assert!(
                (got - expected).abs() < PIXEL_TOLERANCE,
                "{} pixel ({x},{y}): lumo {got} vs flip-evaluator {expected}",
                p.name
            );
        }
    }
}

#[test]
fn exposure_scales_before_clamping() {
    // One stop up on a half-exposed pair is the same as comparing the doubled images.
    let (_, pairs) = load();
    let p = &pairs[0];
    let r = read_image(&data_dir().join(&p.reference)).unwrap();
    let t = read_image(&data_dir().join(&p.test)).unwrap();
    let half = |img: &lumo_image::Image| {
        let mut h = img.clone();
        h.data.iter_mut().for_each(|v| *v *= 0.5);
        h
    };
    let up = FlipSettings {
        exposure: 1.0,
        ..FlipSettings::default()
    };
    let a = flip(&half(&r), &half(&t), &up).unwrap();
    let b = flip(&r, &t, &FlipSettings::default()).unwrap();
    assert!((a - b).abs() < 1e-6, "{a} vs {b}");
}
