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

use crate::common::boxsum::box_mean;
use crate::Guide;

/// Number of pixels of the window of radius `r` around `i` on an axis of length `n`.
fn span(i: usize, r: usize, n: usize) -> f64 {
    ((i + r).min(n - 1) - i.saturating_sub(r) + 1) as f64
}

/// Index of the (row, col) entry (row ≤ col) of a packed symmetric d×d matrix.
fn packed(d: usize, row: usize, col: usize) -> usize {
    row * d - row * (row + 1) / 2 + col
}

/// Largest guide dimension (as [`crate::MAX_GUIDE_DIMS`]), for stack buffers.
const MAX_D: usize = crate::MAX_GUIDE_DIMS;

/// Inverts the symmetric positive definite `m` (d×d, row-major) in place by Gauss–Jordan
/// elimination without pivoting (the ε on the diagonal keeps the pivots positive); a pivot
/// that rounding drives to ≤ 0 is floored so the result stays finite. On the stack: it runs
/// once per pixel.
fn invert(m: &mut [f64], d: usize) {
    let mut inv = [0.0f64; MAX_D * MAX_D];
    for i in 0..d {
        inv[i * d + i] = 1.0;
    }
    for c in 0..d {
        let p = m[c * d + c].max(1e-12);
        for k in 0..d {
            m[c * d + k] /= p;
            inv[c * d + k] /= p;
        }
        for r in 0..d {
            if r != c {
                let f = m[r * d + c];
                for k in 0..d {
                    m[r * d + k] -= f * m[c * d + k];
                    inv[r * d + k] -= f * inv[c * d + k];
                }
            }
        }
    }
    m.copy_from_slice(&inv[..d * d]);
}

/// The guided filter's self-weight at every pixel for `guide` and window radius `r`.
pub(super) fn guided_self_weight(guide: &Guide, r: usize) -> Vec<f32> {
    let (w, h, d) = (guide.width, guide.height, guide.dims);
    let n = w * h;
    let np = d * (d + 1) / 2;
    // Guide moments: g (d values) and the packed upper triangle of g gᵀ.
    let k1 = d + np;
    let mut moments = vec![0.0f32; n * k1];
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
    let means = box_mean(&moments, w, h, k1, r);
    // Per window: A/|ω| (packed), Aμ/|ω|, (1 + μᵀAμ)/|ω|.
    let k2 = np + d + 1;
    let mut window = vec![0.0f32; n * k2];
    window
        .par_chunks_mut(k2 * w)
        .enumerate()
        .for_each(|(y, row)| {
            let mut mbuf = [0.0f64; MAX_D * MAX_D];
            let m = &mut mbuf[..d * d];
            let mut mu = [0.0f64; MAX_D];
            for x in 0..w {
                let i = y * w + x;
                let s = &means[i * k1..(i + 1) * k1];
                for a in 0..d {
                    mu[a] = s[a] as f64;
                }
                for a in 0..d {
                    for b in a..d {
                        let cov = s[d + packed(d, a, b)] as f64 - mu[a] * mu[b];
                        m[a * d + b] = cov;
                        m[b * d + a] = cov;
                    }
                    m[a * d + a] += guide.eps[a] as f64;
                }
                invert(m, d);
                let size = span(x, r, w) * span(y, r, h);
                let out = &mut row[x * k2..(x + 1) * k2];
                let mut quad = 0.0;
                for a in 0..d {
                    let am: f64 = (0..d).map(|b| m[a * d + b] * mu[b]).sum();
                    out[np + a] = (am / size) as f32;
                    quad += mu[a] * am;
                    for b in a..d {
                        out[packed(d, a, b)] = (m[a * d + b] / size) as f32;
                    }
                }
                out[np + d] = ((1.0 + quad) / size) as f32;
            }
        });
    let avg = box_mean(&window, w, h, k2, r);
    (0..n)
        .into_par_iter()
        .map(|i| {
            let g = &guide.data[i * d..(i + 1) * d];
            let s = &avg[i * k2..(i + 1) * k2];
            let mut v = s[np + d] as f64;
            for a in 0..d {
                v -= 2.0 * g[a] as f64 * s[np + a] as f64;
                for b in a..d {
                    let t = g[a] as f64 * g[b] as f64 * s[packed(d, a, b)] as f64;
                    v += if a == b { t } else { 2.0 * t };
                }
            }
            v.clamp(0.0, 1.0) as f32
        })
        .collect()
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
        let mut g = Image::new(w, h, 2, 0.0);
        for y in 0..h {
            for x in 0..w {
                let p = g.pixel_mut(x, y);
                p[0] = if x < 11 { 0.2 } else { 0.8 };
                p[1] = (x as f32 * 0.37 + y as f32 * 0.11).sin() * 0.3 + 0.5;
            }
        }
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
