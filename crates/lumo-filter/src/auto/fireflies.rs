//! Fireflies for `auto`: a pixel far brighter than its neighbourhood is split into a clamped
//! part, which the candidates filter, and an excess, which is spread over a wide window
//! afterwards.
//!
//! Why: every candidate is linear in the colour, so a 1-spp sample carrying a thousand times
//! its neighbourhood's light leaves a blob of its window's size and shape (a square blotch for
//! the guided filters), and the leave-one-out errors around it are dominated by it. Dropping
//! the excess would lose energy (darken indirect-lit rooms whose light arrives as rare bright
//! paths); spreading it with the geometry-guided filter over a window of
//! [`super::AutoParams::firefly_spread`] keeps the local mean while turning the blotch into a
//! faint, smooth glow. Chosen on the tuning set and the built-in scenes (docs/filters.md).

use lumo_image::{luminance, Image};
use rayon::prelude::*;

use crate::common::boxsum::box_mean_finite;
use crate::common::zeroed::zeroed_image;
use crate::{guided, FilterError, Guide, GuidedParams};

/// The colour split into what the candidates filter and what is spread.
pub(super) struct Split {
    /// The colour with every firefly scaled down to the threshold (missing pixels unchanged).
    pub clamped: Image,
    /// What was taken off (0 elsewhere, NaN at missing pixels so the spreading skips them).
    pub excess: Image,
    /// Pixels that were clamped.
    pub count: usize,
}

/// Splits `y` (3 channels, non-finite = missing): a pixel is a firefly when its luminance
/// exceeds `k` × the mean luminance of the (2r+1)² window around it, that mean taken over the
/// window's finite pixels after a first pass has clamped them at `k` × the plain mean (so the
/// fireflies themselves do not raise the threshold). A firefly keeps its chromaticity and is
/// scaled to the threshold.
pub(super) fn split(y: &Image, k: f32, r: usize) -> Split {
    let (w, h) = (y.width, y.height);
    // Element-wise passes in parallel: serial, the split took 12–14 ms of a 512² frame on one
    // thread and on two alike (same output bits either way).
    let lum: Vec<f32> = y
        .data
        .par_chunks_exact(3)
        .map(|p| luminance([p[0], p[1], p[2]]))
        .collect();
    // Negative samples count as 0 in the means; a window with no finite pixel has mean 0.
    let window_mean = |values: &[f32]| -> Vec<f32> {
        // (`f32::max` would turn a missing NaN into 0: keep it missing.)
        let nonneg: Vec<f32> = values
            .par_iter()
            .map(|&v| if v.is_finite() { v.max(0.0) } else { v })
            .collect();
        box_mean_finite(&nonneg, w, h, r)
            .into_par_iter()
            .map(|m| if m.is_nan() { 0.0 } else { m })
            .collect()
    };
    let first = window_mean(&lum);
    let pre: Vec<f32> = lum
        .par_iter()
        .zip(first.par_iter())
        .map(|(&l, &m)| if l.is_finite() { l.min(k * m) } else { l })
        .collect();
    let threshold: Vec<f32> = window_mean(&pre).into_par_iter().map(|m| k * m).collect();
    let mut clamped = y.clone();
    let mut excess = zeroed_image(w, h, 3);
    let count = clamped
        .data
        .par_chunks_mut(3)
        .zip(excess.data.par_chunks_mut(3))
        .enumerate()
        .map(|(i, (c, e))| {
            let (l, t) = (lum[i], threshold[i]);
            if !l.is_finite() {
                e.fill(f32::NAN);
                return 0;
            }
            if !(l > t && l > 0.0) {
                return 0;
            }
            let s = t / l;
            for ch in 0..3 {
                let v = c[ch];
                c[ch] = v * s;
                e[ch] = v - c[ch];
            }
            1
        })
        .sum();
    Split {
        clamped,
        excess,
        count,
    }
}

/// The spreading filter runs on a grid this many times coarser (the fast guided filter): its
/// window is wide (64 pixels by default), so the coarse grid changes nothing the tuning set
/// sees (FLIP ratios to OIDN the same or lower, relMSE the same to 1 %) and cuts the step
/// from ~150 to ~80 ms at 1080p. Frames with a side under [`SPREAD_COARSE_MIN`] pixels run
/// it exactly: the coarse grid weighs a partial block at the right or bottom edge like a
/// whole one, which on a frame a few blocks wide loses a visible share of the energy.
const SPREAD_SUBSAMPLE: usize = 4;
/// Shortest frame side at which the spread runs on the coarse grid.
const SPREAD_COARSE_MIN: usize = 64;

/// Spreads `excess` (0 at pixels that were not clamped, NaN at missing ones) with the guided
/// filter of radius `r` over the frame's geometry guide, so a firefly's energy stays on the
/// surface it fell on and near where it fell; the filter's local linear fit can dip below zero
/// beside a lone spike, which is clipped.
pub(super) fn spread(excess: &Image, guide: &Guide, r: usize) -> Result<Image, FilterError> {
    let params = GuidedParams {
        radius: r,
        fast_subsample: if excess.width.min(excess.height) >= SPREAD_COARSE_MIN {
            SPREAD_SUBSAMPLE
        } else {
            1
        },
    };
    let mut out = guided(excess, guide, &params)?.image;
    for v in &mut out.data {
        *v = v.max(0.0);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spike_is_clamped_to_the_threshold_and_its_excess_kept() {
        let (w, h) = (24, 20);
        let mut y = Image::new(w, h, 3, 0.5);
        // A firefly with a colour of its own, and a missing pixel.
        y.pixel_mut(10, 8).copy_from_slice(&[300.0, 200.0, 100.0]);
        y.pixel_mut(3, 3).fill(f32::NAN);
        let s = split(&y, 16.0, 4);
        assert_eq!(s.count, 1);
        let (c, e) = (s.clamped.rgb(10, 8), s.excess.rgb(10, 8));
        // The 9×9 window: 80 pixels at 0.5 and the spike, first clamped at 16 × the plain
        // mean; the bound is 16 × the mean after that clamp (about 36 × the wall).
        let spike = luminance([300.0, 200.0, 100.0]);
        let m1 = (80.0 * 0.5 + spike) / 81.0;
        let bound = 16.0 * (80.0 * 0.5 + spike.min(16.0 * m1)) / 81.0;
        let l = luminance(c);
        assert!((l - bound).abs() < 1e-3 * bound, "{l} vs {bound}");
        // Chromaticity kept, nothing lost.
        assert!((c[0] / c[2] - 3.0).abs() < 1e-4 && (c[1] / c[2] - 2.0).abs() < 1e-4);
        for k in 0..3 {
            assert!((c[k] + e[k] - y.rgb(10, 8)[k]).abs() < 1e-3);
        }
        // Everything else untouched; the missing pixel stays missing in both parts.
        assert_eq!(s.clamped.rgb(11, 8), [0.5; 3]);
        assert_eq!(s.excess.rgb(11, 8), [0.0; 3]);
        assert!(s.clamped.rgb(3, 3)[0].is_nan() && s.excess.rgb(3, 3)[0].is_nan());
    }

    #[test]
    fn a_flat_or_smoothly_lit_frame_has_no_fireflies() {
        let (w, h) = (32, 16);
        let mut y = Image::new(w, h, 3, 0.0);
        for yy in 0..h {
            for x in 0..w {
                // A gradient over two orders of magnitude, as a light's falloff.
                y.pixel_mut(x, yy).fill(0.01 * 1.15f32.powi(x as i32));
            }
        }
        assert_eq!(split(&y, 16.0, 8).count, 0);
        assert_eq!(split(&Image::new(w, h, 3, 0.0), 16.0, 8).count, 0);
    }
}
