//! The self-weight `∂F_p/∂y_p` of the guided filter: how much of a pixel's own noisy value
//! its filtered value keeps. The guided filter is linear in the colour for a fixed guide, so
//! the weight is exact and needs no Monte-Carlo probe; it turns a residual into a
//! leave-one-out prediction error (`auto`'s error estimate).
//!
//! With windows ω_k of |ω_k| pixels, guide mean μ_k and A_k = (Σ_k + diag ε)⁻¹,
//! `F_p = mean over k ∋ p of (a_kᵀ g_p + b_k)` with `a_k = A_k cov_k(g, y)`,
//! `b_k = ȳ_k − a_kᵀ μ_k`, so
//!
//! `∂F_p/∂y_p = mean over k ∋ p of (1 + (g_p − μ_k)ᵀ A_k (g_p − μ_k)) / |ω_k|`,
//!
//! which expands into window means of the per-window terms `A_k/|ω_k|` (packed upper
//! triangle), `A_k μ_k/|ω_k|` and `(1 + μ_kᵀA_kμ_k)/|ω_k|`. Those means are exactly what the
//! filter's stream takes of its coefficients `a_k`, `b_k`, over the same windows, from the
//! same factorisation of `Σ_k + diag ε`: the terms ride along with the coefficients
//! ([`super::guided_self_weighted`]), at a cost independent of the radius, like the filter's.

use super::cholesky::{inverse_factor_lanes, L};

/// Number of self-weight terms per window for a `d`-dimensional guide: the packed d×d
/// matrix, a d-vector and a scalar.
pub(super) const fn terms(d: usize) -> usize {
    d * (d + 1) / 2 + d + 1
}

/// Index of the (row, col) entry (row ≤ col) of a packed symmetric d×d matrix.
fn packed(d: usize, row: usize, col: usize) -> usize {
    row * d - row * (row + 1) / 2 + col
}

/// Packed entries of the largest guide's symmetric matrix.
const MAX_PACKED: usize = crate::MAX_GUIDE_DIMS * (crate::MAX_GUIDE_DIMS + 1) / 2;

/// The per-window terms of [`L`] windows, from the Cholesky factor (`lo`, `inv_diag`) of
/// their `Σ + diag ε` and their guide means `mu`: `put(lane, [A packed, Aμ, 1 + μᵀAμ])`
/// for every lane, not yet divided by the window size.
#[inline(always)]
pub(super) fn window_terms<const D: usize>(
    lo: &[[[f32; L]; D]; D],
    inv_diag: &[[f32; L]; D],
    mu: &[[f32; L]; D],
    mut put: impl FnMut(usize, &[f32]),
) {
    let np = D * (D + 1) / 2;
    let m = inverse_factor_lanes::<D>(lo, inv_diag);
    // z = Mμ; A = MᵀM, so Aμ = Mᵀz and μᵀAμ = |z|².
    let mut z = [[0.0f32; L]; D];
    for i in 0..D {
        for k in 0..=i {
            for l in 0..L {
                z[i][l] += m[i][k][l] * mu[k][l];
            }
        }
    }
    let mut quad = [0.0f32; L];
    for zi in &z {
        for l in 0..L {
            quad[l] += zi[l] * zi[l];
        }
    }
    let mut a_mu = [[0.0f32; L]; D];
    for a in 0..D {
        for k in a..D {
            for l in 0..L {
                a_mu[a][l] += m[k][a][l] * z[k][l];
            }
        }
    }
    let mut a_packed = [[0.0f32; L]; MAX_PACKED];
    for a in 0..D {
        for b in a..D {
            let mut acc = [0.0f32; L];
            for k in b..D {
                for l in 0..L {
                    acc[l] += m[k][a][l] * m[k][b][l];
                }
            }
            a_packed[packed(D, a, b)] = acc;
        }
    }
    let mut t = [0.0f32; MAX_PACKED + crate::MAX_GUIDE_DIMS + 1];
    for l in 0..L {
        for (p, v) in a_packed.iter().enumerate().take(np) {
            t[p] = v[l];
        }
        for a in 0..D {
            t[np + a] = a_mu[a][l];
        }
        t[np + D] = 1.0 + quad[l];
        put(l, &t[..terms(D)]);
    }
}

/// The derivative of the filtered value of a pixel with guide `g` with respect to the input
/// of a pixel with guide `gb` in the same windows, from the window means `s` of their terms
/// (already divided by the windows' sizes): `s_c − (g + gb)ᵀ s_v + gᵀ S_M gb`, clamped to
/// [0, 1]. With `gb = g` it is the pixel's self-weight `s_c − 2 gᵀ s_v + gᵀ S_M g`; for the
/// fast filter `gb` is the coarse pixel's guide. One pixel at a time: the reference the
/// filters' [`cross_weight_lanes`] is tested against.
#[cfg(test)]
fn cross_weight_at(g: &[f32], gb: &[f32], s: &[f32]) -> f32 {
    let d = g.len();
    let np = d * (d + 1) / 2;
    let mut v = s[np + d] as f64;
    for a in 0..d {
        v -= (g[a] as f64 + gb[a] as f64) * s[np + a] as f64;
        for b in a..d {
            let m = s[packed(d, a, b)] as f64;
            v += if a == b {
                g[a] as f64 * gb[a] as f64 * m
            } else {
                (g[a] as f64 * gb[b] as f64 + g[b] as f64 * gb[a] as f64) * m
            };
        }
    }
    v.clamp(0.0, 1.0) as f32
}

/// Pixels [`cross_weight_lanes`] takes at once.
pub(super) const LANES: usize = 8;

/// The derivative of the filtered value of a pixel with guide `g` with respect to the input
/// of a pixel with guide `gb` in the same windows, from the window means `s` of their terms
/// (already divided by the windows' sizes): `s_c − (g + gb)ᵀ s_v + gᵀ S_M gb`, clamped to
/// [0, 1] (with `gb = g` the pixel's self-weight; for the fast filter `gb` is the coarse
/// pixel's guide), for [`LANES`] pixels, lane-last (`g[a][l]`, `gb[a][l]`, terms `s[j][l]`,
/// all as f64): per lane the operations and order of the one-pixel formula, so its bits.
/// Why: one pixel's weight is a chain of dependent f64 additions, which kept the upsampling
/// loop waiting on their latency; eight independent chains side by side vectorise.
#[inline(always)]
pub(super) fn cross_weight_lanes<const D: usize>(
    g: &[[f64; LANES]; D],
    gb: &[[f64; LANES]; D],
    s: &[[f64; LANES]],
    out: &mut [f32; LANES],
) {
    let np = D * (D + 1) / 2;
    let mut v = s[np + D];
    for a in 0..D {
        let sa = &s[np + a];
        for l in 0..LANES {
            v[l] -= (g[a][l] + gb[a][l]) * sa[l];
        }
        for b in a..D {
            let m = &s[packed(D, a, b)];
            if a == b {
                for l in 0..LANES {
                    v[l] += g[a][l] * gb[a][l] * m[l];
                }
            } else {
                for l in 0..LANES {
                    v[l] += (g[a][l] * gb[b][l] + g[b][l] * gb[a][l]) * m[l];
                }
            }
        }
    }
    for (o, v) in out.iter_mut().zip(v) {
        *o = v.clamp(0.0, 1.0) as f32;
    }
}

/// A 2-channel test guide: a step at column `split` in the first channel, a smooth wave in the
/// second.
#[cfg(test)]
pub(crate) fn two_region_guide(w: usize, h: usize, split: usize) -> lumo_image::Image {
    let mut g = lumo_image::Image::new(w, h, 2, 0.0);
    for y in 0..h {
        for x in 0..w {
            let p = g.pixel_mut(x, y);
            p[0] = if x < split { 0.2 } else { 0.8 };
            p[1] = (x as f32 * 0.37 + y as f32 * 0.11).sin() * 0.3 + 0.5;
        }
    }
    g
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lanes give [`cross_weight_at`]'s bits, for every guide dimension up to 4, with
    /// weights inside, below and above [0, 1].
    #[test]
    fn lanes_give_the_bits_of_one_pixel() {
        fn check<const D: usize>() {
            let val = |i: usize| ((i * 7919 + 13) % 1009) as f32 / 500.0 - 1.0;
            let nt = terms(D);
            let (mut g, mut gb) = ([[0.0f64; LANES]; D], [[0.0f64; LANES]; D]);
            let mut s = vec![[0.0f64; LANES]; nt];
            let mut want = [0.0f32; LANES];
            for l in 0..LANES {
                let gl: Vec<f32> = (0..D).map(|a| val(l * 31 + a)).collect();
                let gbl: Vec<f32> = (0..D).map(|a| val(l * 17 + a + 400)).collect();
                let sl: Vec<f32> = (0..nt).map(|j| val(l * 53 + j + 900) * 0.7).collect();
                for a in 0..D {
                    (g[a][l], gb[a][l]) = (gl[a] as f64, gbl[a] as f64);
                }
                for j in 0..nt {
                    s[j][l] = sl[j] as f64;
                }
                want[l] = cross_weight_at(&gl, &gbl, &sl);
            }
            let mut got = [0.0f32; LANES];
            cross_weight_lanes::<D>(&g, &gb, &s, &mut got);
            assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "D {D}");
            assert!(
                want.iter().any(|&w| w > 0.0 && w < 1.0),
                "D {D}: an inner weight"
            );
        }
        check::<1>();
        check::<2>();
        check::<3>();
        check::<4>();
    }
    use crate::guided::guided_self_weighted;
    use crate::{guided, Guide, GuidedParams};
    use lumo_image::Image;

    /// A colour plane of smooth, positive values (what the weights must not depend on).
    fn some_color(w: usize, h: usize) -> Image {
        let mut c = Image::new(w, h, 3, 0.0);
        for (i, v) in c.data.iter_mut().enumerate() {
            *v = 0.5 + 0.4 * (i as f32 * 0.37).sin();
        }
        c
    }

    /// The self-weight against a brute-force derivative: filter an image that is 1 at one
    /// pixel and 0 elsewhere; the filtered value there is ∂F_p/∂y_p (the filter is linear).
    /// And the filtered image that comes with the weights is the plain filter's, bit for bit.
    #[test]
    fn matches_the_filter_response_to_a_unit_impulse() {
        let (w, h) = (23, 17);
        let g = two_region_guide(w, h, 11);
        // And four dimensions, as `auto`'s normal + depth guide has (rows of 16 lanes and a
        // partly filled last lane group).
        let mut g4 = Image::new(w, h, 4, 0.0);
        for y in 0..h {
            for x in 0..w {
                let (a, b) = (g.pixel(x, y)[0], g.pixel(x, y)[1]);
                let c = (x as f32 * 0.21 - y as f32 * 0.4).cos() * 0.2;
                g4.pixel_mut(x, y).copy_from_slice(&[a, b, c, 0.5 * a + c]);
            }
        }
        let guides = [
            Guide::from_image(&g, vec![0.01, 0.02]).unwrap(),
            Guide::from_image(&g4, vec![0.01, 0.02, 0.005, 0.01]).unwrap(),
        ];
        let color = some_color(w, h);
        for (guide, r) in guides.iter().flat_map(|g| [1, 3, 6].map(|r| (g, r))) {
            let params = GuidedParams {
                radius: r,
                fast_subsample: 1,
            };
            let (filtered, weights) = guided_self_weighted(&color, guide, &params).unwrap();
            let plain = guided(&color, guide, &params).unwrap();
            assert!(
                (filtered.image.data.iter().zip(&plain.image.data))
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "r {r}: the filtered image differs from the plain filter's"
            );
            for &(x, y) in &[(0, 0), (5, 8), (10, 3), (11, 3), (22, 16), (12, 9)] {
                let mut impulse = Image::new(w, h, 3, 0.0);
                impulse.pixel_mut(x, y).fill(1.0);
                let f = guided(&impulse, guide, &params).unwrap().image;
                let want = f.rgb(x, y)[0];
                let got = weights[y * w + x];
                assert!(
                    (got - want).abs() < 1e-4 * want.max(1.0),
                    "r {r} ({x}, {y}): {got} vs {want}"
                );
            }
        }
    }

    /// On the coarse grid (fast filter, s = 2) the weight is an approximation: it counts every
    /// window around the interpolation's nodes, also those that miss the pixel's block, so it
    /// runs 3–13 % high away from the guide's step (up to a third next to it, with this
    /// guide's ε; with `auto`'s far smaller ε a window straddling a step has a much larger
    /// inverse, and there the weight can run ~10× high, the leave-one-out factor ~8 %: on the
    /// cautious side, it penalises the coarse candidate at edges). Away from the step it must
    /// match the fast filter's response to a unit impulse within 20 %, and the leave-one-out
    /// factor 1 / (1 − W) within 1 % everywhere. The frame has odd sides, so the right column
    /// and bottom row sit in partial blocks (of 2 and 1 pixels), whose share of their block's
    /// mean is larger.
    #[test]
    fn the_coarse_weight_approximates_the_fast_filters_impulse_response() {
        let (w, h, split) = (41, 31, 21);
        let guide = Guide::from_image(&two_region_guide(w, h, split), vec![0.01, 0.02]).unwrap();
        let color = some_color(w, h);
        for r in [4, 8] {
            let params = GuidedParams {
                radius: r,
                fast_subsample: 2,
            };
            let (filtered, weights) = guided_self_weighted(&color, &guide, &params).unwrap();
            let plain = guided(&color, &guide, &params).unwrap();
            assert!(
                (filtered.image.data.iter().zip(&plain.image.data))
                    .all(|(a, b)| (a - b).abs() <= 1e-6 * b.abs().max(1.0)),
                "r {r}: the filtered image differs from the fast filter's"
            );
            for &(x, y) in &[
                (3, 4),
                (10, 15),
                (19, 9),
                (20, 20),
                (21, 5),
                (30, 12),
                (39, 29),
                (40, 12),
                (17, 30),
                (40, 30),
            ] {
                let mut impulse = Image::new(w, h, 3, 0.0);
                impulse.pixel_mut(x, y).fill(1.0);
                let want = guided(&impulse, &guide, &params).unwrap().image.rgb(x, y)[0];
                let got = weights[y * w + x];
                let factor = |v: f32| 1.0 / (1.0 - v);
                let near_step = x.abs_diff(split) <= 2;
                if !near_step {
                    assert!(
                        (got - want).abs() < 0.2 * want,
                        "r {r} ({x}, {y}): {got} vs {want}"
                    );
                }
                assert!(
                    (factor(got) / factor(want) - 1.0).abs() < 0.01,
                    "r {r} ({x}, {y}): factor {} vs {}",
                    factor(got),
                    factor(want)
                );
            }
        }
    }

    /// A flatter model (larger ε) keeps less of each pixel's own value.
    #[test]
    fn a_flatter_model_keeps_less_of_each_pixel() {
        let (w, h) = (29, 13);
        let g = two_region_guide(w, h, 9);
        let sharp = Guide::from_image(&g, vec![0.001, 0.001]).unwrap();
        let flat = Guide::from_image(&g, vec![0.05, 0.05]).unwrap();
        let color = some_color(w, h);
        for r in [2, 5] {
            let params = GuidedParams {
                radius: r,
                fast_subsample: 1,
            };
            let (_, a) = guided_self_weighted(&color, &sharp, &params).unwrap();
            let (_, b) = guided_self_weighted(&color, &flat, &params).unwrap();
            let (sa, sb): (f32, f32) = (a.iter().sum(), b.iter().sum());
            assert!(sb < sa, "r {r}: flat {sb} vs sharp {sa}");
        }
    }
}
