//! À-Trous kernels against a direct f64 implementation of the same weights, and against each
//! other (fused vs per-tap path, AVX2 + FMA vs baseline).

use lumo_image::{luminance, Image};

use super::kernel::{Isa, Path, K};
use super::layout::{Layout, M, QW};
use super::{inverse_sigma_row, AtrousFilter, AtrousParams, B3, VARIANCE_EPS};
use crate::bench::synthetic::synthetic_frame;
use crate::common::gbuffer::{Features, Prepared};

mod passes;

/// Direct evaluation, pixel by pixel and tap by tap in f64, of the documented weights:
/// h·exp(−e)·valid_q, zero across background/geometry and for e > 20, with e the sum of the
/// colour term (fixed σ halved per level, or SVGF's σ_l·sqrt(G3×3 ∗ var)) and the normal
/// (÷ stepwidth²) and position distances.
fn direct(prep: &Prepared, var: Option<&[f32]>, p: &AtrousParams) -> Image {
    let (w, h) = (prep.w, prep.h);
    let n = w * h;
    let ml = prep.mean_luminance as f64;
    let mut col: Vec<[f64; 3]> = (0..n)
        .map(|i| [0, 1, 2].map(|c| prep.color[c][i] as f64))
        .collect();
    let mask = p.sparse - 1;
    let mut valid: Vec<f64> = (0..n)
        .map(|i| {
            let on = (i % w) & mask == 0 && (i / w) & mask == 0;
            prep.valid[i] as f64 * on as u8 as f64
        })
        .collect();
    let inv_ml2 = 1.0 / (prep.mean_luminance * prep.mean_luminance);
    let mut v: Vec<f64> = (0..n)
        .map(|i| {
            let x = var.map_or(0.0, |v| v[i]) * inv_ml2;
            if x > 1e-12 {
                x as f64
            } else {
                0.0
            }
        })
        .collect();
    let var_mode = var.is_some() && p.sigma_luminance.is_some();
    let skip = p.sparse.trailing_zeros() as usize;
    let feat =
        |i: usize, f: &Option<[Vec<f32>; 3]>| f.as_ref().map(|f| [0, 1, 2].map(|c| f[c][i] as f64));
    for it in 0..p.iterations {
        let step = 1isize << it;
        let lum: Vec<f64> = col
            .iter()
            .map(|c| luminance([c[0] as f32, c[1] as f32, c[2] as f32]) as f64)
            .collect();
        let mut next_c = vec![[0.0f64; 3]; n];
        let mut next_v = vec![0.0f64; n];
        let mut next_valid = vec![0.0f64; n];
        // SVGF: σ from the 3×3 Gaussian of the variance around each pixel.
        let isig_at = |x: isize, y: isize| {
            let g = [0.25, 0.5, 0.25];
            let (mut s, mut k) = (0.0, 0.0);
            for dy in 0..3 {
                for dx in 0..3 {
                    let (xx, yy) = (x + dx as isize - 1, y + dy as isize - 1);
                    if xx >= 0 && yy >= 0 && xx < w as isize && yy < h as isize {
                        s += g[dx] * g[dy] * v[(yy * w as isize + xx) as usize];
                        k += g[dx] * g[dy];
                    }
                }
            }
            let sl = p.sigma_luminance.unwrap_or(1.0) as f64 * ml;
            1.0 / (sl * (s / k).sqrt() + VARIANCE_EPS as f64 * ml)
        };
        let isig: Vec<f64> = (0..n)
            .map(|i| isig_at((i % w) as isize, (i / w) as isize))
            .collect();
        for y in 0..h as isize {
            for x in 0..w as isize {
                let i = (y * w as isize + x) as usize;
                let (mut acc, mut ws, mut wv) = ([0.0f64; 3], 0.0f64, 0.0f64);
                for (ky, hy) in B3.iter().enumerate() {
                    for (kx, hx) in B3.iter().enumerate() {
                        let xx = x + (kx as isize - 2) * step;
                        let yy = y + (ky as isize - 2) * step;
                        if xx < 0 || yy < 0 || xx >= w as isize || yy >= h as isize {
                            continue;
                        }
                        let j = (yy * w as isize + xx) as usize;
                        if prep.background[i] != prep.background[j] {
                            continue;
                        }
                        let mut e = 0.0f64;
                        if it >= skip {
                            if var_mode {
                                e += (lum[i] - lum[j]).abs() * isig[i] * valid[i];
                            } else if let Some(s) = p.sigma_color {
                                let si = s as f64 * ml / (1u64 << it) as f64;
                                let d2: f64 = (0..3).map(|c| (col[i][c] - col[j][c]).powi(2)).sum();
                                e += d2 / (si * si) * valid[i];
                            }
                        }
                        if let (Some(s), Some(a), Some(b)) =
                            (p.sigma_normal, feat(i, &prep.normal), feat(j, &prep.normal))
                        {
                            let d2: f64 = (0..3).map(|c| (a[c] - b[c]).powi(2)).sum();
                            e += d2 / (s as f64 * s as f64 * (step * step) as f64);
                        }
                        if let (Some(s), Some(a), Some(b)) = (
                            p.sigma_position,
                            feat(i, &prep.position),
                            feat(j, &prep.position),
                        ) {
                            let d2: f64 = (0..3).map(|c| (a[c] - b[c]).powi(2)).sum();
                            e += d2 / (s as f64 * s as f64);
                        }
                        if e > 20.0 {
                            continue;
                        }
                        let wgt = (hx * hy) as f64 * (-e).exp() * valid[j];
                        for c in 0..3 {
                            acc[c] += wgt * col[j][c];
                        }
                        ws += wgt;
                        wv += wgt * wgt * v[j];
                    }
                }
                if ws > 0.0 {
                    next_c[i] = acc.map(|a| a / ws);
                    next_v[i] = wv / (ws * ws);
                    next_valid[i] = 1.0;
                }
            }
        }
        col = next_c;
        if var_mode {
            v = next_v;
        }
        valid = next_valid;
    }
    let data = col.iter().flat_map(|c| c.map(|v| v as f32)).collect();
    Image::from_vec(w, h, 3, data)
}

/// Luminance of a 1- or 3-channel variance image; negative or non-finite values become 0.
fn variance_plane(v: &Image) -> Vec<f32> {
    v.data
        .chunks_exact(v.channels)
        .map(|p| {
            let x = if p.len() >= 3 {
                luminance([p[0], p[1], p[2]])
            } else {
                p[0]
            };
            if x.is_finite() && x > 0.0 {
                x
            } else {
                0.0
            }
        })
        .collect()
}

/// Largest |a − b| / (1 + |b|).
fn rel_diff(a: &Image, b: &Image) -> f32 {
    a.data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y).abs() / (1.0 + y.abs()))
        .fold(0.0, f32::max)
}

/// Every instruction set this machine can run.
fn isas() -> Vec<Isa> {
    let mut v = vec![Isa::Baseline];
    match Isa::detect() {
        Isa::Avx512 => v.extend([Isa::Avx2, Isa::Avx512]),
        Isa::Avx2 => v.push(Isa::Avx2),
        Isa::Baseline => {}
    }
    v
}

/// Each row turned right by `by` columns (the frame's geometry sits in its middle third; the
/// tests need it across the strip boundary at column 512).
fn roll(img: &Image, by: usize) -> Image {
    let (w, c) = (img.width, img.channels);
    let mut out = img.clone();
    for (o, i) in out
        .data
        .chunks_exact_mut(w * c)
        .zip(img.data.chunks_exact(w * c))
    {
        for x in 0..w {
            let to = (x + by) % w;
            o[to * c..to * c + c].copy_from_slice(&i[x * c..x * c + c]);
        }
    }
    out
}

/// 600 columns (two strips, with geometry across their boundary at column 512, so taps and
/// the pair path's sweeps cross strip margins) and 140 rows (the pair path's bands split at
/// rows 64 and 128), a few missing pixels.
fn case() -> (crate::SyntheticFrame, Image) {
    let mut f = synthetic_frame(600, 140, 2, 3);
    for img in [
        &mut f.noisy,
        &mut f.reference,
        &mut f.albedo,
        &mut f.normal,
        &mut f.position,
        &mut f.depth,
        &mut f.variance,
    ] {
        *img = roll(img, 200);
    }
    let mut c = f.noisy.clone();
    for (x, y) in [(511, 10), (512, 10), (513, 63), (599, 139), (300, 64)] {
        c.pixel_mut(x, y)[1] = f32::NAN;
    }
    (f, c)
}

fn check(params: &AtrousParams, with_variance: bool) {
    let (f, c) = case();
    let feats = Features {
        normal: Some(&f.normal),
        position: Some(&f.position),
        depth: Some(&f.depth),
        ..Features::default()
    };
    let prep = Prepared::new(&c, &feats).unwrap();
    let var = with_variance.then(|| variance_plane(&f.variance));
    let want = direct(&prep, var.as_deref(), params);
    let feats = Features {
        variance: with_variance.then_some(&f.variance),
        ..feats
    };
    // One filter object for every run: results must not depend on earlier calls.
    let mut filter = AtrousFilter::new();
    let mut run = |isa, path| filter.run(&c, &feats, params, isa, path).unwrap().image;
    let base = run(Isa::Baseline, Path::Fused);
    for isa in isas() {
        let fused = run(isa, Path::Fused);
        let taps = run(isa, Path::Taps);
        // The AVX-512 build of the fused path rounds like the AVX2 build of the per-tap one.
        assert_eq!(fused, taps, "{isa:?}: fused and per-tap paths differ");
        let d = rel_diff(&fused, &want);
        assert!(d < 2e-4, "{isa:?} vs direct: {d}");
        let d = rel_diff(&fused, &base);
        assert!(d < 2e-5, "{isa:?} vs baseline: {d}");
        // The pair path sums in another order: equal up to rounding.
        let auto = run(isa, Path::Auto);
        let d = rel_diff(&auto, &want);
        assert!(d < 2e-4, "{isa:?} pairs vs direct: {d}");
        let d = rel_diff(&auto, &fused);
        assert!(d < 2e-5, "{isa:?} pairs vs fused: {d}");
        // The level pipeline (where it runs) computes every pixel as the pair path does
        // level by level, whatever the band split.
        let pairs = run(isa, Path::Pairs);
        assert_eq!(
            auto, pairs,
            "{isa:?}: pipeline and level-by-level pairs differ"
        );
        for rows in [7, 64, 100] {
            for groups in [1, 2] {
                let banded = run(isa, Path::Bands(rows, groups));
                assert_eq!(
                    banded, pairs,
                    "{isa:?}: pipeline with {rows}-row bands, {groups} groups differs"
                );
            }
        }
    }
    // A fresh filter gives the same image as the reused one.
    let again = AtrousFilter::new()
        .filter(&c, &feats, params)
        .unwrap()
        .image;
    assert_eq!(again, run(Isa::detect(), Path::Auto));
}

#[test]
fn fixed_colour_normal_position_match_direct_evaluation() {
    // 7 levels: steps 32 and 64 take the per-tap path and cross strips.
    check(
        &AtrousParams {
            iterations: 7,
            sigma_color: Some(4.0),
            sigma_luminance: None,
            ..AtrousParams::default()
        },
        false,
    );
}

#[test]
fn variance_guided_matches_direct_evaluation() {
    check(&AtrousParams::default(), true);
}

#[test]
fn sparse_variance_guided_matches_direct_evaluation() {
    check(
        &AtrousParams {
            sparse: 2,
            sigma_position: None,
            ..AtrousParams::default()
        },
        true,
    );
}

#[test]
fn unweighted_levels_match_direct_evaluation() {
    check(
        &AtrousParams {
            iterations: 6,
            sigma_color: None,
            sigma_luminance: None,
            sigma_normal: None,
            sigma_position: None,
            ..AtrousParams::default()
        },
        false,
    );
}

#[test]
fn strong_fixed_colour_weight_matches_direct_evaluation() {
    // A colour σ small enough that the colour term decides most weights, also at the strip
    // boundary, where the pair path sweeps the neighbouring strip's pixels.
    check(
        &AtrousParams {
            iterations: 5,
            sigma_color: Some(0.5),
            sigma_luminance: None,
            ..AtrousParams::default()
        },
        false,
    );
}

#[test]
fn pipeline_strip_groups_match_level_by_level_pairs() {
    // Four strips (1700 columns: 4 × 432, the last 404 wide), so a group of three or four
    // has strips whose margins on both sides are copied from neighbours, not recomputed.
    let f = synthetic_frame(1700, 48, 2, 5);
    let mut c = f.noisy.clone();
    for (x, y) in [(431, 3), (432, 3), (863, 20), (1699, 47)] {
        c.pixel_mut(x, y)[0] = f32::INFINITY;
    }
    let feats = Features {
        normal: Some(&f.normal),
        position: Some(&f.position),
        albedo: Some(&f.albedo),
        ..Features::default()
    };
    let params = AtrousParams {
        iterations: 5,
        sigma_color: Some(2.0),
        sigma_luminance: None,
        demodulate: true,
        ..AtrousParams::default()
    };
    let mut filter = AtrousFilter::new();
    for isa in isas() {
        let mut run = |path| filter.run(&c, &feats, &params, isa, path).unwrap().image;
        let pairs = run(Path::Pairs);
        for groups in 1..=4 {
            for rows in [13, 48] {
                assert_eq!(
                    run(Path::Bands(rows, groups)),
                    pairs,
                    "{isa:?}: {groups} groups of {rows}-row bands differ from level by level"
                );
            }
        }
    }
}

/// The per-pixel inverse σ the row-wise `inverse_sigma_row` replaced, as it was.
fn inverse_sigma_reference(
    src: &[f32],
    lay: Layout,
    c: usize,
    y: usize,
    j: usize,
    sigma: f32,
    eps: f32,
) -> f32 {
    const G: [f32; 3] = [0.25, 0.5, 0.25];
    let x = (lay.strip(c).0 + j) as isize - M as isize;
    let (mut s, mut k) = (0.0f32, 0.0f32);
    for (dy, gy) in G.iter().enumerate() {
        let yy = y as isize + dy as isize - 1;
        if yy < 0 || yy >= lay.h as isize {
            continue;
        }
        let row = &src[lay.block(c, yy as usize, K) + 4 * QW..][..QW];
        for (dx, gx) in G.iter().enumerate() {
            let xx = x + dx as isize - 1;
            if xx < 0 || xx >= lay.w as isize {
                continue;
            }
            s += gx * gy * row[j + dx - 1];
            k += gx * gy;
        }
    }
    1.0 / (sigma * (s / k).max(0.0).sqrt() + eps)
}

#[test]
fn row_wise_inverse_sigma_equals_the_per_pixel_one() {
    // Three strips; variance in the image, margins copied from the neighbours, 0 beyond.
    for (w, h) in [(1100, 5), (37, 1), (512, 3)] {
        let lay = Layout::new(w, h);
        let mut src = vec![0.0f32; lay.size(K)];
        let mut seed = 12345u64;
        for c in 0..lay.nch {
            let len = lay.strip(c).1;
            for y in 0..h {
                let b = lay.block(c, y, K) + 4 * QW;
                for v in &mut src[b + M..b + M + len] {
                    *v = crate::bench::synthetic::splitmix(&mut seed) * 3.0;
                }
            }
        }
        lay.fill_margins(&mut src, K, K);
        for c in 0..lay.nch {
            let len = lay.strip(c).1;
            for y in 0..h {
                let mut got = vec![0.0f32; len];
                inverse_sigma_row(&src, lay, c, y, 16.0, 1e-6, &mut got);
                for (t, g) in got.iter().enumerate() {
                    let want = inverse_sigma_reference(&src, lay, c, y, M + t, 16.0, 1e-6);
                    assert_eq!(
                        g.to_bits(),
                        want.to_bits(),
                        "{w}×{h}: strip {c}, row {y}, column {t}"
                    );
                }
            }
        }
    }
}

/// A narrow, tall image is filtered transposed (transpose.rs: its layout would otherwise hold
/// 672 floats per pixel and plane); the result must be the direct filter's, for fixed and
/// variance-guided weights, with demodulation and sparse input, and for the first level the
/// temporal filter keeps.
#[test]
fn transposed_narrow_images_filter_as_the_direct_layout_does() {
    let f = synthetic_frame(20, 230, 2, 11);
    assert!(super::transpose::pays(20, 230) && !super::transpose::pays(230, 20));
    let features = Features {
        normal: Some(&f.normal),
        position: Some(&f.position),
        depth: Some(&f.depth),
        albedo: Some(&f.albedo),
        variance: Some(&f.variance),
    };
    let svgf = AtrousParams {
        use_variance: true,
        demodulate: true,
        ..AtrousParams::default()
    };
    let sparse = AtrousParams {
        sparse: 2,
        ..AtrousParams::default()
    };
    for p in [AtrousParams::default(), svgf, sparse] {
        let turned = AtrousFilter::new().filter(&f.noisy, &features, &p).unwrap();
        let direct = AtrousFilter::new()
            .run(&f.noisy, &features, &p, Isa::detect(), Path::Auto)
            .unwrap();
        assert_eq!(turned.missing, direct.missing);
        let scale = direct.image.data.iter().fold(0f32, |m, v| m.max(v.abs()));
        for (i, (a, b)) in turned.image.data.iter().zip(&direct.image.data).enumerate() {
            assert!(
                (a - b).abs() <= 1e-4 * scale,
                "value {i}: {a} transposed, {b} direct"
            );
        }
        let (kept, first) = AtrousFilter::new()
            .filter_keeping_first_level(&f.noisy, &features, &p)
            .unwrap();
        assert_eq!((first.width, first.height), (20, 230));
        for (a, b) in kept.image.data.iter().zip(&direct.image.data) {
            assert!((a - b).abs() <= 1e-4 * scale);
        }
    }
}
