//! The edge-avoiding À-Trous as one more candidate of `auto`, with its self-weight estimated
//! by a Monte-Carlo probe.
//!
//! Why: the guided candidates are steered by geometry only, so an edge the geometry does not
//! explain — a hard sun shadow across a flat floor — is blurred over the smallest candidate's
//! window; the À-Trous' colour weight keeps it. Its self-weight `∂F_p/∂y_p` has no closed form
//! (the edge-stopping weights depend on the colour), so it is measured the way Monte-Carlo
//! SURE measures a black-box filter's divergence (Ramani, Blu & Unser 2008): filter once more
//! with every pixel scaled by `1 + ε·δ_p`, δ_p = ±1 from a hash of the pixel, and read
//! `δ_p (F'_p − F_p) / (ε y_p)`. The other pixels' perturbations add zero-mean terms, which the
//! error window averages out like the residuals' own noise.

use lumo_image::Image;
use rayon::prelude::*;

use crate::common::boxsum::box_mean;
use crate::common::gbuffer::Features;
use crate::{
    spatial_variance, AtrousFilter, AtrousParams, FilterError, DEFAULT_SIGMA_LUMINANCE,
    DEFAULT_SIGMA_NORMAL, DEFAULT_SIGMA_POSITION,
};

/// Relative size of the probe's perturbation: small enough that the colour weights barely
/// move, large enough that `F' − F` stands well above f32 rounding.
const PROBE: f32 = 0.05;

/// Radius of the box the probe's per-pixel estimates are averaged over (the self-weight varies
/// slowly away from edges; the probe's noise does not).
const SMOOTHING_RADIUS: usize = 2;

/// À-Trous parameters of the candidate: `lumo denoise --filter atrous`'s defaults, on colour
/// already demodulated by the caller, with the normal and position weights where those planes
/// exist.
fn params(features: &Features) -> AtrousParams {
    AtrousParams {
        iterations: 5,
        sigma_color: None,
        sigma_luminance: Some(DEFAULT_SIGMA_LUMINANCE),
        sigma_normal: features.normal.map(|_| DEFAULT_SIGMA_NORMAL),
        sigma_position: features.position.map(|_| DEFAULT_SIGMA_POSITION),
        sparse: 1,
        demodulate: false,
        use_variance: true,
    }
}

/// ±1 per pixel from a hash of its index (fixed, so `auto` stays deterministic).
fn sign(i: usize) -> f32 {
    let mut x = (i as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    if (x ^ (x >> 31)) & 1 == 0 {
        1.0
    } else {
        -1.0
    }
}

/// The À-Trous result on the (demodulated) colour `y` and its estimated self-weight per pixel.
/// `features`' albedo is ignored (the caller demodulated).
pub(super) fn atrous_candidate(
    y: &Image,
    features: &Features,
) -> Result<(Image, Vec<f32>), FilterError> {
    let variance = spatial_variance(y);
    let features = Features {
        albedo: None,
        variance: Some(&variance),
        ..*features
    };
    let p = params(&features);
    let mut filter = AtrousFilter::new();
    probe_self_weight(y, |c| Ok(filter.filter(c, &features, &p)?.image))
}

/// `filter(y)` and the Monte-Carlo estimate of its self-weight `∂F_p/∂y_p` per pixel (the
/// channels' responses summed, averaged over a small box, clamped to [0, 1]; a black pixel,
/// which no relative perturbation moves, counts 0).
pub(super) fn probe_self_weight(
    y: &Image,
    mut filter: impl FnMut(&Image) -> Result<Image, FilterError>,
) -> Result<(Image, Vec<f32>), FilterError> {
    let f = filter(y)?;
    let mut probe = y.clone();
    probe
        .data
        .par_chunks_mut(3)
        .enumerate()
        .for_each(|(i, px)| {
            let s = 1.0 + PROBE * sign(i);
            for v in px {
                *v *= s;
            }
        });
    let g = filter(&probe)?;
    let raw: Vec<f32> = (0..y.width * y.height)
        .into_par_iter()
        .map(|i| {
            let (mut num, mut den) = (0.0f32, 0.0f32);
            for c in 0..3 {
                num += g.data[i * 3 + c] - f.data[i * 3 + c];
                den += y.data[i * 3 + c];
            }
            let w = sign(i) * num / (PROBE * den);
            if w.is_finite() {
                w
            } else {
                0.0
            }
        })
        .collect();
    // Averaged before clamping: a single probe is noisy around the true weight, and clamping
    // its negative draws at 0 would bias the weight upwards.
    let weights = box_mean(&raw, y.width, y.height, 1, SMOOTHING_RADIUS)
        .into_iter()
        .map(|w| w.clamp(0.0, 1.0))
        .collect();
    Ok((f, weights))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{guided, Guide, GuidedParams};

    /// On a linear filter (the guided filter with a fixed guide) the probe must agree with the
    /// exact self-weight: in the mean over the image closely (the other pixels' zero-mean
    /// terms average out), pixel by pixel up to those terms and the smoothing box.
    #[test]
    fn probe_matches_the_guided_filters_exact_self_weight() {
        let (w, h) = (64, 48);
        let g = crate::guided::self_weight::two_region_guide(w, h, 30);
        let mut y = Image::new(w, h, 3, 0.0);
        for yy in 0..h {
            for x in 0..w {
                let i = (yy * w + x) as f32;
                let c = y.pixel_mut(x, yy);
                for (k, v) in c.iter_mut().enumerate() {
                    *v = 0.5 + 0.4 * ((i * 0.618 + k as f32) * 12.9898).sin().abs();
                }
            }
        }
        let guide = Guide::from_image(&g, vec![0.01, 0.02]).unwrap();
        for r in [2, 5] {
            let params = GuidedParams {
                radius: r,
                fast_subsample: 1,
            };
            let (_, probed) =
                probe_self_weight(&y, |c| Ok(guided(c, &guide, &params)?.image)).unwrap();
            let (_, exact) = crate::guided::guided_self_weighted(&y, &guide, &params).unwrap();
            let n = (w * h) as f64;
            let mean = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>() / n;
            let (mp, me) = (mean(&probed), mean(&exact));
            assert!(
                (mp - me).abs() < 0.15 * me,
                "r {r}: probed mean {mp} vs exact {me}"
            );
            // Pixel by pixel the probe is noisy (and blurred across the guide's edge by the
            // smoothing box); what `auto` uses is the leave-one-out factor 1 / (1 − W), which
            // must be off by a few per cent at most.
            let k = |w: f32| 1.0 / (1.0 - w as f64);
            let rms = (probed
                .iter()
                .zip(&exact)
                .map(|(&a, &b)| (k(a) / k(b) - 1.0).powi(2))
                .sum::<f64>()
                / n)
                .sqrt();
            eprintln!(
                "r {r}: mean probed {mp:.4} exact {me:.4}, rms of the factor's error {rms:.4}"
            );
            assert!(rms < 0.06, "r {r}: rms relative error of 1/(1 − W) {rms}");
        }
    }
}
