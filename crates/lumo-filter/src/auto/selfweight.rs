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
//! which expands into box means of `A_k/|ω_k|`, `A_k μ_k/|ω_k|` and `(1 + μ_kᵀA_kμ_k)/|ω_k|`:
//! a cost independent of the radius, like the filter's.

use rayon::prelude::*;

use crate::common::boxsum::box_mean_into;
use crate::guided::cholesky::{factor_lanes, inverse_factor_lanes, L};
use crate::Guide;

/// Number of pixels of the window of radius `r` around `i` on an axis of length `n`.
fn span(i: usize, r: usize, n: usize) -> f64 {
    ((i + r).min(n - 1) - i.saturating_sub(r) + 1) as f64
}

/// Index of the (row, col) entry (row ≤ col) of a packed symmetric d×d matrix.
fn packed(d: usize, row: usize, col: usize) -> usize {
    row * d - row * (row + 1) / 2 + col
}

/// The guided filter's self-weight for one guide at several radii, its working buffers kept
/// from one radius to the next (fresh ones per radius page-faulted ~60 MB each at 512²).
pub(super) struct SelfWeights<'g> {
    guide: &'g Guide,
    /// Guide moments: g and the packed upper triangle of g gᵀ, per pixel (any radius).
    moments: Vec<f32>,
    /// Box means of `moments` at radius `means_radius` (kept: candidates that differ only in
    /// ε share them).
    means: Vec<f32>,
    means_radius: Option<usize>,
    window: Vec<f32>,
    avg: Vec<f32>,
    tmp: Vec<f32>,
}

impl<'g> SelfWeights<'g> {
    /// Buffers for `guide`, its moments computed once.
    pub(super) fn new(guide: &'g Guide) -> Self {
        let d = guide.dims;
        let k1 = d + d * (d + 1) / 2;
        let mut moments = vec![0.0f32; guide.width * guide.height * k1];
        moments
            .par_chunks_mut(k1)
            .zip(guide.data.par_chunks(d))
            .for_each(|(m, g)| {
                m[..d].copy_from_slice(g);
                for a in 0..d {
                    for b in a..d {
                        m[d + packed(d, a, b)] = g[a] * g[b];
                    }
                }
            });
        Self {
            guide,
            moments,
            means: Vec::new(),
            means_radius: None,
            window: Vec::new(),
            avg: Vec::new(),
            tmp: Vec::new(),
        }
    }

    /// The self-weight at every pixel for window radius `r`, with the guide's own ε.
    #[cfg(test)]
    pub(super) fn at_radius(&mut self, r: usize) -> Vec<f32> {
        let eps = self.guide.eps.clone();
        self.at_radius_eps(r, &eps)
    }

    /// The self-weight at every pixel for window radius `r` and regularisation `eps` (one
    /// per guide dimension) instead of the guide's. Calls at the same radius share the
    /// window means.
    pub(super) fn at_radius_eps(&mut self, r: usize, eps: &[f32]) -> Vec<f32> {
        assert_eq!(eps.len(), self.guide.dims, "one ε per guide dimension");
        // One copy per guide dimension (at most `crate::MAX_GUIDE_DIMS`).
        match self.guide.dims {
            1 => self.weights::<1>(r, eps),
            2 => self.weights::<2>(r, eps),
            3 => self.weights::<3>(r, eps),
            4 => self.weights::<4>(r, eps),
            5 => self.weights::<5>(r, eps),
            6 => self.weights::<6>(r, eps),
            7 => self.weights::<7>(r, eps),
            _ => self.weights::<{ crate::MAX_GUIDE_DIMS }>(r, eps),
        }
    }

    /// [`Self::at_radius_eps`] for a guide of `D` dimensions.
    fn weights<const D: usize>(&mut self, r: usize, eps: &[f32]) -> Vec<f32> {
        let guide = self.guide;
        let (w, h) = (guide.width, guide.height);
        debug_assert_eq!(guide.dims, D);
        let n = w * h;
        let np = D * (D + 1) / 2;
        let k1 = D + np;
        if self.means_radius != Some(r) {
            box_mean_into(&self.moments, w, h, k1, r, &mut self.tmp, &mut self.means);
            self.means_radius = Some(r);
        }
        let means = &self.means;
        // Per window: A/|ω| (packed), Aμ/|ω|, (1 + μᵀAμ)/|ω|.
        let k2 = np + D + 1;
        // Every element is written below: resized, not cleared (see `box_mean_into`).
        self.window.resize(n * k2, 0.0);
        let avx2 = lumo_simd::Isa::detect() >= lumo_simd::Isa::Avx2;
        self.window
            .par_chunks_mut(k2 * w)
            .enumerate()
            .for_each(|(y, row)| {
                let means_row = &means[y * w * k1..(y + 1) * w * k1];
                window_row::<D>(means_row, eps, span(y, r, h), r, row, avx2)
            });
        box_mean_into(&self.window, w, h, k2, r, &mut self.tmp, &mut self.avg);
        let avg = &self.avg;
        (0..n)
            .into_par_iter()
            .map(|i| {
                let g = &guide.data[i * D..(i + 1) * D];
                let s = &avg[i * k2..(i + 1) * k2];
                let mut v = s[np + D] as f64;
                for a in 0..D {
                    v -= 2.0 * g[a] as f64 * s[np + a] as f64;
                    for b in a..D {
                        let t = g[a] as f64 * g[b] as f64 * s[packed(D, a, b)] as f64;
                        v += if a == b { t } else { 2.0 * t };
                    }
                }
                v.clamp(0.0, 1.0) as f32
            })
            .collect()
    }
}

/// The per-window terms of one row ([`SelfWeights::at_radius`]): from the row's box means
/// `means` of the guide moments (g, packed g gᵀ), for each pixel A/|ω| (packed), Aμ/|ω| and
/// (1 + μᵀAμ)/|ω| into `out`, with A = (Σ + diag ε)⁻¹ and |ω| = `rows` × the row span at
/// radius `r`. In the AVX2 copy when `avx2` (no fused multiply-adds: the same bits as the
/// baseline copy). Not `multiversion!`: its AVX-512 copy, the same bits, made `auto` ~3 %
/// slower at 512² (three alternations, 176–183 → 183–206 ms).
fn window_row<const D: usize>(
    means: &[f32],
    eps: &[f32],
    rows: f64,
    r: usize,
    out: &mut [f32],
    avx2: bool,
) {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: `avx2` comes from run-time detection.
        unsafe { window_row_avx2::<D>(means, eps, rows, r, out) };
        return;
    }
    let _ = avx2;
    window_row_lanes::<D>(means, eps, rows, r, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn window_row_avx2<const D: usize>(
    means: &[f32],
    eps: &[f32],
    rows: f64,
    r: usize,
    out: &mut [f32],
) {
    window_row_lanes::<D>(means, eps, rows, r, out)
}

/// [`window_row`], [`L`] pixels at a time: why — the per-pixel D×D inverse in f64 by
/// Gauss–Jordan was a sixth of `auto`'s time at 512²; a Cholesky factor in f32 lanes, as the
/// guided filter solves its own windows, vectorises.
#[inline(always)]
fn window_row_lanes<const D: usize>(
    means: &[f32],
    eps: &[f32],
    rows: f64,
    r: usize,
    out: &mut [f32],
) {
    let np = D * (D + 1) / 2;
    let k1 = D + np;
    let k2 = np + D + 1;
    let w = means.len() / k1;
    for x0 in (0..w).step_by(L) {
        let lanes = (w - x0).min(L);
        let mut mu = [[0.0f32; L]; D];
        // Lanes past `lanes` keep the identity: finite, never written out.
        let mut sys = [[[0.0f32; L]; D]; D];
        for a in 0..D {
            sys[a][a] = [1.0; L];
        }
        for l in 0..lanes {
            let s = &means[(x0 + l) * k1..(x0 + l + 1) * k1];
            for a in 0..D {
                mu[a][l] = s[a];
            }
            for a in 0..D {
                for b in 0..=a {
                    sys[a][b][l] = s[D + packed(D, b, a)] - s[a] * s[b];
                }
                sys[a][a][l] += eps[a];
            }
        }
        let (lo, inv_diag) = factor_lanes::<D>(&sys);
        let m = inverse_factor_lanes::<D>(&lo, &inv_diag);
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
        for i in 0..D {
            for l in 0..L {
                quad[l] += z[i][l] * z[i][l];
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
        for l in 0..lanes {
            let x = x0 + l;
            let inv_size = (1.0 / (span(x, r, w) * rows)) as f32;
            let o = &mut out[x * k2..(x + 1) * k2];
            for (p, v) in a_packed.iter().enumerate().take(np) {
                o[p] = v[l] * inv_size;
            }
            for a in 0..D {
                o[np + a] = a_mu[a][l] * inv_size;
            }
            o[np + D] = (1.0 + quad[l]) * inv_size;
        }
    }
}

/// Packed entries of the largest guide's symmetric matrix.
const MAX_PACKED: usize = crate::MAX_GUIDE_DIMS * (crate::MAX_GUIDE_DIMS + 1) / 2;

/// The guided filter's self-weight at every pixel for `guide` and window radius `r` (one
/// radius; `auto` keeps a [`SelfWeights`] for its several).
#[cfg(test)]
fn guided_self_weight(guide: &Guide, r: usize) -> Vec<f32> {
    SelfWeights::new(guide).at_radius(r)
}

/// A 2-channel test guide: a step at column `split` in the first channel, a smooth wave in the
/// second.
#[cfg(test)]
pub(super) fn two_region_guide(w: usize, h: usize, split: usize) -> lumo_image::Image {
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
    use crate::{guided, GuidedParams};
    use lumo_image::Image;

    /// The self-weight against a brute-force derivative: filter an image that is 1 at one
    /// pixel and 0 elsewhere; the filtered value there is ∂F_p/∂y_p (the filter is linear).
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
        for (guide, r) in guides.iter().flat_map(|g| [1, 3, 6].map(|r| (g, r))) {
            let weights = guided_self_weight(guide, r);
            for &(x, y) in &[(0, 0), (5, 8), (10, 3), (11, 3), (22, 16), (12, 9)] {
                let mut impulse = Image::new(w, h, 3, 0.0);
                impulse.pixel_mut(x, y).fill(1.0);
                let params = GuidedParams {
                    radius: r,
                    fast_subsample: 1,
                };
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
    /// Calls that differ only in ε share the window means: each must still be the
    /// self-weight of its own ε, whatever was computed before (the flat candidates of `auto`
    /// follow the main candidate of their radius).
    #[test]
    fn another_eps_at_the_same_radius_is_its_own_guides_weight() {
        let (w, h) = (29, 13);
        let g = two_region_guide(w, h, 9);
        let sharp = Guide::from_image(&g, vec![0.001, 0.001]).unwrap();
        let flat = Guide::from_image(&g, vec![0.05, 0.05]).unwrap();
        let mut shared = SelfWeights::new(&sharp);
        for r in [2, 5] {
            let a = shared.at_radius_eps(r, &sharp.eps);
            let b = shared.at_radius_eps(r, &flat.eps);
            assert_eq!(a, guided_self_weight(&sharp, r), "r {r}, sharp");
            assert_eq!(b, guided_self_weight(&flat, r), "r {r}, flat");
            // A flatter model keeps less of each pixel's own value.
            let (sa, sb): (f32, f32) = (a.iter().sum(), b.iter().sum());
            assert!(sb < sa, "r {r}: flat {sb} vs sharp {sa}");
        }
    }
}
