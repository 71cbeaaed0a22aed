//! History rejection where the lighting changed (after A-SVGF, Schied et al. 2018, in its
//! cheap form): the reprojection tests see only geometry, so a moving light or shadow leaves
//! the history of a static surface in place. Per pixel, the mean luminance of this frame's
//! samples over a (2r+1)² window is compared with the mean luminance of the reprojected
//! history over the same pixels (those with both); the difference beyond `k` standard errors
//! of the samples' mean (their variance: the larger of the window's and the history's temporal
//! estimate), relative to the larger of the two means, is the rejection
//! λ ∈ [0, 1], which shortens the history (see [`super::reproject::blend`]).
//!
//! Comparing means over the same pixels makes the test blind to edges inside the window (both
//! means see them alike) and to noise (its share is subtracted), so a static scene keeps its
//! history.

use lumo_image::luminance;
use rayon::prelude::*;

use super::reproject::{Prev, Sample};
use super::TemporalParams;

/// Windowed sums: count, Σ l, Σ l² of the samples, Σ l of the history, Σ of the history's
/// temporal luminance variance (from its moments).
pub(super) type Sums = [f32; 5];

/// Smallest mean luminance the relative difference divides by.
const EPS: f32 = 1e-4;

/// Fills `lambda` (one value per pixel, row-major) for a `w`×`h` frame; `sums` is a working
/// buffer. All zero when the rejection is off (`gradient_radius` 0). With
/// [`TemporalParams::clamp_sigmas`] > 0, `bounds` gets each pixel's neighbourhood-clamp
/// interval of the history's luminance (the window samples' mean ± that many standard
/// deviations), else it is left empty.
#[allow(clippy::too_many_arguments)]
pub(super) fn rejection(
    p: &TemporalParams,
    samples: &[Sample],
    prev: &[Option<Prev>],
    w: usize,
    h: usize,
    sums: &mut Vec<Sums>,
    lambda: &mut Vec<f32>,
    bounds: &mut Vec<[f32; 2]>,
) {
    lambda.clear();
    lambda.resize(w * h, 0.0);
    bounds.clear();
    let r = p.gradient_radius;
    if r == 0 || w == 0 {
        return;
    }
    let item = |i: usize| -> Sums {
        match (samples[i].valid, prev[i]) {
            (true, Some(pr)) => {
                let l = samples[i].moments[0];
                let v = (pr.moments[1] - pr.moments[0] * pr.moments[0]).max(0.0);
                [1.0, l, l * l, luminance(pr.color), v]
            }
            _ => [0.0; 5],
        }
    };
    // Horizontal box sums.
    sums.clear();
    sums.resize(w * h, [0.0; 5]);
    sums.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, out) in row.iter_mut().enumerate() {
            let mut s = [0.0f32; 5];
            for xx in x.saturating_sub(r)..(x + r + 1).min(w) {
                let v = item(y * w + xx);
                for k in 0..5 {
                    s[k] += v[k];
                }
            }
            *out = s;
        }
    });
    // Vertical box sums and λ.
    let sums = &sums[..];
    let (k_sigma, gain) = (p.gradient_sigmas, p.gradient_gain);
    let window = |x: usize, y: usize| {
        let mut s = [0.0f32; 5];
        for yy in y.saturating_sub(r)..(y + r + 1).min(h) {
            let v = sums[yy * w + x];
            for k in 0..5 {
                s[k] += v[k];
            }
        }
        s
    };
    lambda.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, out) in row.iter_mut().enumerate() {
            *out = lambda_of(window(x, y), k_sigma, gain);
        }
    });
    if p.clamp_sigmas > 0.0 {
        bounds.resize(w * h, [f32::NEG_INFINITY, f32::INFINITY]);
        bounds.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, out) in row.iter_mut().enumerate() {
                *out = clamp_bounds(window(x, y), p.clamp_sigmas);
            }
        });
    }
}

/// The clamp interval of one window's sums: mean ± `gamma` standard deviations of the
/// samples' luminance; unbounded with fewer than two samples.
pub(super) fn clamp_bounds(s: Sums, gamma: f32) -> [f32; 2] {
    let n = s[0];
    if n < 2.0 {
        return [f32::NEG_INFINITY, f32::INFINITY];
    }
    let m = s[1] / n;
    let sd = (s[2] / n - m * m).max(0.0).sqrt();
    let b = [m - gamma * sd, m + gamma * sd];
    if b.iter().all(|v| v.is_finite()) {
        b
    } else {
        [f32::NEG_INFINITY, f32::INFINITY]
    }
}

/// λ of one window's sums.
fn lambda_of(s: Sums, k_sigma: f32, gain: f32) -> f32 {
    let n = s[0];
    if n < 2.0 {
        return 0.0;
    }
    let (mc, mh) = (s[1] / n, s[3] / n);
    // The samples' variance: the larger of the window's and the history's temporal estimate
    // (a window of 1-spp samples mostly misses the rare bright ones that the history saw).
    let var = (s[2] / n - mc * mc).max(s[4] / n).max(0.0);
    let excess = (mc - mh).abs() - k_sigma * (var / n).sqrt();
    unit_or_zero(gain * excess / mc.max(mh).max(EPS))
}

/// `l` clamped to [0, 1]; 0 when it is not finite (a degenerate window keeps its history).
pub(super) fn unit_or_zero(l: f32) -> f32 {
    if l.is_finite() {
        l.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::lambda_of;

    #[test]
    fn lambda_grows_with_the_change_beyond_the_noise() {
        // 49 samples of mean 1 and variance 0.49: standard error 0.1.
        let s = |mc: f32, mh: f32| [49.0, 49.0 * mc, 49.0 * (0.49 + mc * mc), 49.0 * mh, 0.0];
        assert_eq!(lambda_of(s(1.0, 1.15), 2.0, 1.0), 0.0, "within 2 SE");
        let half = lambda_of(s(1.0, 2.0), 2.0, 1.0);
        assert!((half - 0.4).abs() < 1e-4, "{half}");
        assert!(
            lambda_of(s(0.0, 5.0), 2.0, 1.0) > 0.95,
            "the light went out"
        );
        assert_eq!(
            lambda_of([1.0, 1.0, 1.0, 9.0, 0.0], 2.0, 1.0),
            0.0,
            "one pixel"
        );
        // The history saw a variance of 4 (SE 2/7): a difference of 0.5 is noise.
        let mut t = s(1.0, 1.5);
        assert!(lambda_of(t, 1.0, 1.0) > 0.0);
        t[4] = 49.0 * 4.0;
        assert_eq!(lambda_of(t, 2.0, 1.0), 0.0);
    }
}
