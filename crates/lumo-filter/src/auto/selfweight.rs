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
use crate::Guide;

/// Number of pixels of the window of radius `r` around `i` on an axis of length `n`.
fn span(i: usize, r: usize, n: usize) -> f64 {
    ((i + r).min(n - 1) - i.saturating_sub(r) + 1) as f64
}

/// Index of the (row, col) entry (row ≤ col) of a packed symmetric d×d matrix.
fn packed(d: usize, row: usize, col: usize) -> usize {
    row * d - row * (row + 1) / 2 + col
}

/// Inverts the symmetric positive definite `m` in place by Gauss–Jordan elimination without
/// pivoting (the ε on the diagonal keeps the pivots positive); a pivot that rounding drives to
/// ≤ 0 is floored so the result stays finite. On the stack: it runs once per pixel and radius,
/// and with `D` a constant the loops unroll (the first version, with the dimension known only
/// at run time, spent a third of `auto`'s time here).
#[inline(always)]
fn invert<const D: usize>(m: &mut [[f64; D]; D]) {
    let mut inv = [[0.0f64; D]; D];
    for (i, row) in inv.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for c in 0..D {
        let p = m[c][c].max(1e-12);
        for k in 0..D {
            m[c][k] /= p;
            inv[c][k] /= p;
        }
        for r in 0..D {
            if r != c {
                let f = m[r][c];
                for k in 0..D {
                    m[r][k] -= f * m[c][k];
                    inv[r][k] -= f * inv[c][k];
                }
            }
        }
    }
    *m = inv;
}

/// The guided filter's self-weight for one guide at several radii, its working buffers kept
/// from one radius to the next (fresh ones per radius page-faulted ~60 MB each at 512²).
pub(super) struct SelfWeights<'g> {
    guide: &'g Guide,
    /// Guide moments: g and the packed upper triangle of g gᵀ, per pixel (any radius).
    moments: Vec<f32>,
    means: Vec<f32>,
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
            window: Vec::new(),
            avg: Vec::new(),
            tmp: Vec::new(),
        }
    }

    /// The self-weight at every pixel for window radius `r`.
    pub(super) fn at_radius(&mut self, r: usize) -> Vec<f32> {
        // One copy per guide dimension (at most `crate::MAX_GUIDE_DIMS`).
        match self.guide.dims {
            1 => self.weights::<1>(r),
            2 => self.weights::<2>(r),
            3 => self.weights::<3>(r),
            4 => self.weights::<4>(r),
            5 => self.weights::<5>(r),
            6 => self.weights::<6>(r),
            7 => self.weights::<7>(r),
            _ => self.weights::<{ crate::MAX_GUIDE_DIMS }>(r),
        }
    }

    /// [`Self::at_radius`] for a guide of `D` dimensions.
    fn weights<const D: usize>(&mut self, r: usize) -> Vec<f32> {
        let guide = self.guide;
        let (w, h) = (guide.width, guide.height);
        debug_assert_eq!(guide.dims, D);
        let n = w * h;
        let np = D * (D + 1) / 2;
        let k1 = D + np;
        box_mean_into(&self.moments, w, h, k1, r, &mut self.tmp, &mut self.means);
        let means = &self.means;
        // Per window: A/|ω| (packed), Aμ/|ω|, (1 + μᵀAμ)/|ω|.
        let k2 = np + D + 1;
        // Every element is written below: resized, not cleared (see `box_mean_into`).
        self.window.resize(n * k2, 0.0);
        self.window
            .par_chunks_mut(k2 * w)
            .enumerate()
            .for_each(|(y, row)| {
                let mut mu = [0.0f64; D];
                for x in 0..w {
                    let i = y * w + x;
                    let s = &means[i * k1..(i + 1) * k1];
                    for a in 0..D {
                        mu[a] = s[a] as f64;
                    }
                    let mut m = [[0.0f64; D]; D];
                    for a in 0..D {
                        for b in a..D {
                            let cov = s[D + packed(D, a, b)] as f64 - mu[a] * mu[b];
                            m[a][b] = cov;
                            m[b][a] = cov;
                        }
                        m[a][a] += guide.eps[a] as f64;
                    }
                    invert(&mut m);
                    let size = span(x, r, w) * span(y, r, h);
                    let out = &mut row[x * k2..(x + 1) * k2];
                    let mut quad = 0.0;
                    for a in 0..D {
                        let am: f64 = (0..D).map(|b| m[a][b] * mu[b]).sum();
                        out[np + a] = (am / size) as f32;
                        quad += mu[a] * am;
                        for b in a..D {
                            out[packed(D, a, b)] = (m[a][b] / size) as f32;
                        }
                    }
                    out[np + D] = ((1.0 + quad) / size) as f32;
                }
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
        let guide = Guide::from_image(&g, vec![0.01, 0.02]).unwrap();
        for r in [1, 3, 6] {
            let weights = guided_self_weight(&guide, r);
            for &(x, y) in &[(0, 0), (5, 8), (10, 3), (11, 3), (22, 16), (12, 9)] {
                let mut impulse = Image::new(w, h, 3, 0.0);
                impulse.pixel_mut(x, y).fill(1.0);
                let params = GuidedParams {
                    radius: r,
                    fast_subsample: 1,
                };
                let f = guided(&impulse, &guide, &params).unwrap().image;
                let want = f.rgb(x, y)[0];
                let got = weights[y * w + x];
                assert!(
                    (got - want).abs() < 1e-4 * want.max(1.0),
                    "r {r} ({x}, {y}): {got} vs {want}"
                );
            }
        }
    }
}
