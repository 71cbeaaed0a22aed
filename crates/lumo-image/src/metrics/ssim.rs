//! Structural similarity (Wang et al. 2004) of the tone-mapped luminance.

use super::{MetricError, Pair};
use crate::Image;

/// Side of the Gaussian window in pixels (smaller images use a window as large as they are).
pub const SSIM_WINDOW: usize = 11;
/// Standard deviation of the window's Gaussian in pixels.
pub const SSIM_SIGMA: f64 = 1.5;
/// Stabiliser of the luminance term, as a fraction of the dynamic range (1).
pub const SSIM_K1: f64 = 0.01;
/// Stabiliser of the contrast-structure term.
pub const SSIM_K2: f64 = 0.03;

/// Mean SSIM of `L = tone_map(luminance(rgb), exposure)` over every placement of the
/// [`SSIM_WINDOW`]² Gaussian window (σ = [`SSIM_SIGMA`]) that lies wholly inside the image
/// ("valid" placements, as in Wang et al.'s reference code), dynamic range 1,
/// C1 = (K1)², C2 = (K2)². Windows centred on an excluded pixel are left out of the mean
/// (unless that would leave none). An image narrower or shorter than 11 pixels uses a square
/// window of its smaller side, the same σ renormalised.
pub fn ssim(reference: &Image, test: &Image, exposure: f32) -> Result<f64, MetricError> {
    Ok(ssim_pair(&Pair::new(reference, test)?, exposure))
}

/// The normalised 1-D window weights for a window of `k` taps.
fn window(k: usize) -> Vec<f64> {
    let centre = (k as f64 - 1.0) / 2.0;
    let g: Vec<f64> = (0..k)
        .map(|i| (-(i as f64 - centre).powi(2) / (2.0 * SSIM_SIGMA * SSIM_SIGMA)).exp())
        .collect();
    let s: f64 = g.iter().sum();
    g.into_iter().map(|v| v / s).collect()
}

/// Weighted sums of `plane` over every valid placement of the separable window `g`⊗`g`;
/// output is `(w−k+1)×(h−k+1)`.
fn filter_valid(plane: &[f64], w: usize, h: usize, g: &[f64]) -> Vec<f64> {
    let k = g.len();
    let (ow, oh) = (w + 1 - k, h + 1 - k);
    let mut rows = vec![0.0; ow * h];
    for y in 0..h {
        for x in 0..ow {
            rows[y * ow + x] = g.iter().zip(&plane[y * w + x..]).map(|(a, b)| a * b).sum();
        }
    }
    let mut out = vec![0.0; ow * oh];
    for y in 0..oh {
        for (j, wy) in g.iter().enumerate() {
            let src = &rows[(y + j) * ow..(y + j + 1) * ow];
            for (o, s) in out[y * ow..(y + 1) * ow].iter_mut().zip(src) {
                *o += wy * s;
            }
        }
    }
    out
}

pub(crate) fn ssim_pair(pair: &Pair, exposure: f32) -> f64 {
    let (w, h) = (pair.reference.width, pair.reference.height);
    let [a, b] = pair.tone_mapped_luminance(exposure);
    let k = SSIM_WINDOW.min(w).min(h);
    let g = window(k);
    let product =
        |p: &[f64], q: &[f64]| -> Vec<f64> { p.iter().zip(q).map(|(x, y)| x * y).collect() };
    let mu_a = filter_valid(&a, w, h, &g);
    let mu_b = filter_valid(&b, w, h, &g);
    let aa = filter_valid(&product(&a, &a), w, h, &g);
    let bb = filter_valid(&product(&b, &b), w, h, &g);
    let ab = filter_valid(&product(&a, &b), w, h, &g);
    let (c1, c2) = (SSIM_K1 * SSIM_K1, SSIM_K2 * SSIM_K2);
    let ow = w + 1 - k;
    let half = (k - 1) / 2;

    let (mut sum, mut n, mut sum_all) = (0.0f64, 0usize, 0.0f64);
    for (i, ((((ma, mb), saa), sbb), sab)) in mu_a
        .iter()
        .zip(&mu_b)
        .zip(&aa)
        .zip(&bb)
        .zip(&ab)
        .enumerate()
    {
        let var_a = saa - ma * ma;
        let var_b = sbb - mb * mb;
        let cov = sab - ma * mb;
        let s = ((2.0 * ma * mb + c1) * (2.0 * cov + c2))
            / ((ma * ma + mb * mb + c1) * (var_a + var_b + c2));
        sum_all += s;
        let (x, y) = (i % ow + half, i / ow + half);
        if pair.valid[y * w + x] {
            sum += s;
            n += 1;
        }
    }
    if n > 0 {
        sum / n as f64
    } else {
        sum_all / mu_a.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::luminance;
    use crate::metrics::tone_map;

    fn noise_image(w: usize, h: usize, seed: u32, scale: f32) -> Image {
        let mut s = seed;
        let data = (0..w * h * 3)
            .map(|i| {
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                // A gradient plus noise, so windows have both mean and variance structure.
                (i % (w * 3)) as f32 / (w * 3) as f32 * 0.8
                    + (s >> 8) as f32 / (1u32 << 24) as f32 * scale
            })
            .collect();
        Image::from_vec(w, h, 3, data)
    }

    /// SSIM from the definition: every window placement, every tap, no separability.
    fn brute_force(r: &Image, t: &Image, exposure: f32) -> f64 {
        let lum =
            |img: &Image, x: usize, y: usize| tone_map(luminance(img.rgb(x, y)), exposure) as f64;
        let k = 11;
        let mut wts = vec![0.0; k * k];
        for j in 0..k {
            for i in 0..k {
                let (dx, dy) = (i as f64 - 5.0, j as f64 - 5.0);
                wts[j * k + i] = (-(dx * dx + dy * dy) / (2.0 * 1.5 * 1.5)).exp();
            }
        }
        let total: f64 = wts.iter().sum();
        let (c1, c2) = (0.01f64.powi(2), 0.03f64.powi(2));
        let mut sum = 0.0;
        let mut n = 0;
        for y0 in 0..=r.height - k {
            for x0 in 0..=r.width - k {
                let (mut ma, mut mb) = (0.0, 0.0);
                for j in 0..k {
                    for i in 0..k {
                        let wgt = wts[j * k + i] / total;
                        ma += wgt * lum(r, x0 + i, y0 + j);
                        mb += wgt * lum(t, x0 + i, y0 + j);
                    }
                }
                let (mut va, mut vb, mut cov) = (0.0, 0.0, 0.0);
                for j in 0..k {
                    for i in 0..k {
                        let wgt = wts[j * k + i] / total;
                        let da = lum(r, x0 + i, y0 + j) - ma;
                        let db = lum(t, x0 + i, y0 + j) - mb;
                        va += wgt * da * da;
                        vb += wgt * db * db;
                        cov += wgt * da * db;
                    }
                }
                sum += (2.0 * ma * mb + c1) * (2.0 * cov + c2)
                    / ((ma * ma + mb * mb + c1) * (va + vb + c2));
                n += 1;
            }
        }
        sum / n as f64
    }

    #[test]
    fn matches_brute_force_definition() {
        let r = noise_image(17, 14, 3, 0.3);
        let t = noise_image(17, 14, 99, 0.6);
        for exposure in [0.0, 1.0] {
            let got = ssim(&r, &t, exposure).unwrap();
            let expected = brute_force(&r, &t, exposure);
            assert!((got - expected).abs() < 1e-10, "{got} vs {expected}");
            assert!(got < 0.95 && got > 0.0, "{got}");
        }
    }

    #[test]
    fn hand_computed_constant_images() {
        // Constant windows: variances and covariance vanish, only the luminance term remains:
        // (2ab + C1) / (a² + b² + C1) with a, b the tone-mapped grey levels.
        let r = Image::new(12, 12, 3, 0.214_041_14); // sRGB 0.5
        let t = Image::new(12, 12, 3, 1.0);
        let (a, b) = (
            tone_map(0.214_041_14, 0.0) as f64,
            tone_map(1.0, 0.0) as f64,
        );
        let c1 = 1e-4;
        let expected = (2.0 * a * b + c1) / (a * a + b * b + c1);
        assert!((ssim(&r, &t, 0.0).unwrap() - expected).abs() < 1e-9);
        assert!((expected - 0.8).abs() < 1e-3);
    }

    #[test]
    fn small_images_and_inverted_structure() {
        // Smaller than the window: still defined, and 1 for identical images.
        let r = noise_image(5, 8, 1, 0.5);
        assert!((ssim(&r, &r, 0.0).unwrap() - 1.0).abs() < 1e-12);
        // A photographic negative has the same means' spread but opposite structure.
        let pos = Image::from_vec(
            12,
            12,
            1,
            (0..144)
                .map(|i| {
                    if (i / 12 + i % 12) % 2 == 0 {
                        0.8
                    } else {
                        0.05
                    }
                })
                .collect(),
        );
        let neg = Image::from_vec(12, 12, 1, pos.data.iter().map(|v| 0.85 - v).collect());
        assert!(ssim(&pos, &neg, 0.0).unwrap() < 0.0);
    }
}
