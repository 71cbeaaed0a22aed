//! The input and output passes against their per-pixel rules, and the `multiversion!` copies
//! of the input, output and normalisation loops against their baseline copies, bit for bit.

use lumo_image::Image;

use super::super::fill::{fill_block, fill_block_impl};
use super::super::input::{block_stats, block_stats_impl, FillScales, Input};
use super::super::kernel::{normalise, normalise_impl, K, KA};
use super::super::lanes::variance_run;
use super::super::layout::{Layout, CW, M, QW};
use super::super::output::{output_row, output_row_impl};
use crate::bench::synthetic::synthetic_frame;
use crate::common::gbuffer::Features;

/// The copies `multiversion!` compiles for this CPU (AVX-512 or AVX2) give the baseline
/// copy's results bit for bit: the claim that lets the input passes use them freely.
#[test]
fn simd_copies_match_the_baseline_bit_for_bit() {
    // Two strips (the second 18 columns wide: runs with a remainder).
    let (w, h) = (530, 9);
    let f = synthetic_frame(w, h, 1, 3);
    let mut color = f.noisy.clone();
    color.data[5] = f32::NAN;
    color.data[3 * 700 + 1] = f32::INFINITY;
    let mut albedo = f.albedo.clone();
    albedo.data[3 * 40] = f32::NAN;
    let features = Features {
        normal: Some(&f.normal),
        position: Some(&f.position),
        depth: Some(&f.depth),
        albedo: Some(&albedo),
        variance: Some(&f.variance),
    };
    let lay = Layout::new(w, h);
    let scales = FillScales {
        inv_ml2: 0.5,
        normal: Some(2.0),
        position: Some(1.5),
        inv_extent: 0.25,
        position_background: [9.0; 3],
    };
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for (demodulate, use_variance) in [(false, false), (true, false), (true, true)] {
        let inp = Input {
            color: &color,
            features: &features,
            demodulate,
            use_variance,
        };
        for b in 0..lay.nch * lay.h {
            let (x, y) = (block_stats(&inp, lay, b), block_stats_impl(&inp, lay, b));
            assert_eq!(x.lum.to_bits(), y.lum.to_bits(), "block {b}");
            assert_eq!((x.valid, x.missing), (y.valid, y.missing), "block {b}");
            assert_eq!(bits(&x.lo), bits(&y.lo), "block {b}");
            assert_eq!(bits(&x.hi), bits(&y.hi), "block {b}");
        }
        for c in 0..lay.nch {
            for y in 0..lay.h {
                let (mut b1, mut a1) = (vec![0.0; K * QW], vec![0.0; KA * QW]);
                let (mut b2, mut a2) = (vec![0.0; K * QW], vec![0.0; KA * QW]);
                fill_block(&inp, lay, 1, &scales, c, y, &mut b1, &mut a1);
                fill_block_impl(&inp, lay, 1, &scales, c, y, &mut b2, &mut a2);
                assert_eq!(bits(&b1), bits(&b2), "strip {c} row {y}");
                assert_eq!(bits(&a1), bits(&a2), "strip {c} row {y}");
                let (x0, len) = lay.strip(c);
                let (mut o1, mut o2) = (vec![0.0; 3 * len], vec![0.0; 3 * len]);
                output_row(&inp, y * w + x0, &b1, &mut o1);
                output_row_impl(&inp, y * w + x0, &b1, &mut o2);
                assert_eq!(bits(&o1), bits(&o2), "strip {c} row {y}");
            }
        }
    }
}

/// The vectorised variance conversion equals `Input::variance` (times the scale, tiny
/// values flushed) bit for bit, for every variance and albedo layout it specialises and
/// one it does not, with missing, negative and zero values.
#[test]
fn variance_runs_match_the_per_pixel_rule() {
    let (w, h) = (37, 3);
    let f = synthetic_frame(w, h, 1, 9);
    let mut seed = 7u64;
    let mut rnd = || crate::bench::synthetic::splitmix(&mut seed);
    for vc in [1usize, 2, 3, 4] {
        let mut var = Image::new(w, h, vc, 0.0);
        for v in &mut var.data {
            *v = rnd() * 2.0 - 0.2;
        }
        var.data[4] = f32::NAN;
        var.data[9] = f32::INFINITY;
        var.data[vc * 20] = 1e-20;
        for ac in [1usize, 3, 4] {
            let mut albedo = Image::new(w, h, ac, 0.0);
            for (k, a) in albedo.data.iter_mut().enumerate() {
                *a = if k % 11 == 0 { 0.0 } else { rnd() };
            }
            albedo.data[ac * 30] = f32::NAN;
            let features = Features {
                albedo: Some(&albedo),
                variance: Some(&var),
                ..Features::default()
            };
            for demodulate in [false, true] {
                let inp = Input {
                    color: &f.noisy,
                    features: &features,
                    demodulate,
                    use_variance: true,
                };
                let n = w * h - 5;
                let mut got = vec![0.0; n];
                variance_run(&inp, 5, 0.7, &mut got);
                for (t, g) in got.iter().enumerate() {
                    let v = inp.variance(5 + t) * 0.7;
                    let want = if v > 1e-12 { v } else { 0.0 };
                    assert_eq!(
                        g.to_bits(),
                        want.to_bits(),
                        "variance {vc} ch, albedo {ac} ch, demodulate {demodulate}, pixel {t}"
                    );
                }
            }
        }
    }
}

/// The same for the normalisation of accumulated rows (with and without variance).
#[test]
fn normalise_copies_match_the_baseline_bit_for_bit() {
    let stride = QW;
    // Weight sums of every sign and size, including 0 (nothing contributed).
    let acc: Vec<f32> = (0..5 * stride)
        .map(|i| ((i * 2_654_435_761) % 1000) as f32 / 97.0 - 1.0)
        .collect();
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for (a0, d0, len) in [(0, M, CW), (3, M, 37), (M, M, CW)] {
        let (mut d1, mut d2) = (vec![0.5; K * QW], vec![0.5; K * QW]);
        normalise::<false>(&acc, stride, a0, &mut d1, d0, len);
        normalise_impl::<false>(&acc, stride, a0, &mut d2, d0, len);
        assert_eq!(bits(&d1), bits(&d2));
        normalise::<true>(&acc, stride, a0, &mut d1, d0, len);
        normalise_impl::<true>(&acc, stride, a0, &mut d2, d0, len);
        assert_eq!(bits(&d1), bits(&d2));
    }
}
