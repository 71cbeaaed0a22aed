//! History rejection from re-shaded samples (A-SVGF's temporal gradients, Schied et al.
//! 2018). The renderer traces a few surface points of the previous frame again in this frame
//! with the previous frame's random numbers; where nothing changed the path is the same and the
//! two luminances agree exactly, where a light, a shadow or a material changed they differ by
//! the change itself, not by noise. That is what the windowed test of [`super::gradient`]
//! cannot do: it has to tell a small lighting change from 1-spp noise by statistics.
//!
//! Per pixel, over the (2r+1)² window of [`TemporalParams::reshade_radius`]: λ =
//! `reshade_gain` · |Σ (now − before)| / Σ max(now, before), clamped to [0, 1]; 0 where the
//! window holds no re-shaded sample. Summing the signed differences before taking the magnitude
//! averages out the noise of a change (a path that hit the moved light before and misses it
//! now), as A-SVGF's filtering of the gradient does. With `reshade_rescale` the history that λ
//! keeps is also scaled by ρ = Σ now / Σ before, the factor the window's lighting changed by:
//! under a moving light the kept history then follows the light instead of lagging behind it.

use rayon::prelude::*;

use super::gradient::unit_or_zero;
use super::TemporalParams;
use crate::common::error::param;
use crate::FilterError;

/// One re-shaded sample: a surface point of the previous frame traced again in this frame with
/// the random numbers it was traced with then (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingChange {
    /// Row-major index of the pixel of *this* frame that the point lies in now.
    pub pixel: usize,
    /// Luminance of the sample traced in this frame's scene.
    pub now: f32,
    /// Luminance of the same sample in the previous frame.
    pub before: f32,
}

/// Windowed sums: Σ (now − before), Σ max(now, before), count, Σ before.
type Sums = [f32; 4];

/// Smallest Σ max(now, before) the relative change divides by.
const EPS: f32 = 1e-6;

/// Checks that every change lies in a `w`×`h` frame (non-finite luminances are allowed: those
/// samples are skipped, as missing pixels are).
pub(super) fn validate(changes: &[ShadingChange], w: usize, h: usize) -> Result<(), FilterError> {
    match changes.iter().find(|c| c.pixel >= w * h) {
        Some(c) => Err(param(
            "shading change",
            format!(
                "pixel index {} outside the {w}x{h} frame (use y * width + x)",
                c.pixel
            ),
        )),
        None => Ok(()),
    }
}

/// Fills `lambda` (one value per pixel, row-major) from `changes` for a `w`×`h` frame, and,
/// with [`TemporalParams::reshade_rescale`], `scale` (the factor the window's lighting changed
/// by; else left empty); `plane` is a working buffer.
pub(super) fn rejection(
    p: &TemporalParams,
    changes: &[ShadingChange],
    w: usize,
    h: usize,
    plane: &mut Vec<Sums>,
    lambda: &mut Vec<f32>,
    scale: &mut Vec<f32>,
) {
    lambda.clear();
    lambda.resize(w * h, 0.0);
    scale.clear();
    let r = p.reshade_radius;
    if r == 0 || w == 0 {
        return;
    }
    // Scatter the samples onto the pixel grid (several may land in one pixel).
    plane.clear();
    plane.resize(2 * w * h, [0.0; 4]);
    let (cells, rows) = plane.split_at_mut(w * h);
    for c in changes {
        if c.now.is_finite() && c.before.is_finite() {
            let s = &mut cells[c.pixel];
            s[0] += c.now - c.before;
            s[1] += c.now.max(c.before).max(0.0);
            s[2] += 1.0;
            s[3] += c.before.max(0.0);
        }
    }
    // Horizontal box sums, then vertical sums and λ.
    let cells = &cells[..];
    rows.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, out) in row.iter_mut().enumerate() {
            *out = add_range((x.saturating_sub(r)..(x + r + 1).min(w)).map(|xx| cells[y * w + xx]));
        }
    });
    let rows = &rows[..];
    let gain = p.reshade_gain;
    let window = |x: usize, y: usize| {
        add_range((y.saturating_sub(r)..(y + r + 1).min(h)).map(|yy| rows[yy * w + x]))
    };
    if p.reshade_rescale {
        scale.resize(w * h, 1.0);
        lambda
            .par_chunks_mut(w)
            .zip(scale.par_chunks_mut(w))
            .enumerate()
            .for_each(|(y, (row, srow))| {
                for x in 0..w {
                    (row[x], srow[x]) = rescaled(window(x, y), gain);
                }
            });
    } else {
        lambda.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, out) in row.iter_mut().enumerate() {
                *out = lambda_of(window(x, y), gain);
            }
        });
    }
}

/// Range of the history's rescaling factor.
const SCALE_RANGE: f32 = 4.0;

/// λ and the history's scale of one window's sums: λ as without rescaling, and the factor ρ =
/// Σ now / Σ before (within [1/4, 4]) the window's lighting changed by, which the part of the
/// history that λ keeps is scaled by.
fn rescaled(s: Sums, gain: f32) -> (f32, f32) {
    let lambda = lambda_of(s, gain);
    let (before, now) = (s[3], s[3] + s[0]);
    if s[2] < 1.0 || before <= EPS || now <= EPS {
        // Dark before (a light came on) or now (it went out): no ratio to trust.
        return (lambda, 1.0);
    }
    (lambda, (now / before).clamp(1.0 / SCALE_RANGE, SCALE_RANGE))
}

fn add_range(it: impl Iterator<Item = Sums>) -> Sums {
    it.fold([0.0; 4], |a, v| {
        [a[0] + v[0], a[1] + v[1], a[2] + v[2], a[3] + v[3]]
    })
}

/// λ of one window's sums.
fn lambda_of(s: Sums, gain: f32) -> f32 {
    if s[2] < 1.0 {
        return 0.0;
    }
    unit_or_zero(gain * s[0].abs() / s[1].max(EPS))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// λ of `changes` on a `w`×`h` frame without rescaling.
    fn lambdas(p: &TemporalParams, changes: &[ShadingChange], w: usize, h: usize) -> Vec<f32> {
        let (mut plane, mut lambda) = (vec![], vec![]);
        rejection(p, changes, w, h, &mut plane, &mut lambda, &mut vec![]);
        lambda
    }

    fn params(r: usize, gain: f32) -> TemporalParams {
        TemporalParams {
            reshade_radius: r,
            reshade_gain: gain,
            reshade_rescale: false,
            ..TemporalParams::sequence()
        }
    }

    #[test]
    fn unchanged_samples_keep_the_history_and_a_change_drops_it() {
        let (w, h) = (16, 8);
        let mut changes: Vec<ShadingChange> = (0..w * h)
            .step_by(3)
            .map(|i| ShadingChange {
                pixel: i,
                now: 0.5 + (i % 7) as f32,
                before: 0.5 + (i % 7) as f32,
            })
            .collect();
        let mut lambda = lambdas(&params(2, 1.0), &changes, w, h);
        assert!(lambda.iter().all(|&l| l == 0.0), "same paths, same values");
        // The light went out on the right half: λ is 1 there, 0 far from it.
        for c in &mut changes {
            if c.pixel % w >= w / 2 {
                c.now = 0.0;
            }
        }
        lambda = lambdas(&params(2, 1.0), &changes, w, h);
        assert_eq!(lambda[3 * w + w - 1], 1.0);
        assert_eq!(lambda[3 * w], 0.0);
        // Half the window's light went: λ = ½ at gain 1, clamped at gain 4.
        let half = [
            ShadingChange {
                pixel: 0,
                now: 1.0,
                before: 1.0,
            },
            ShadingChange {
                pixel: 1,
                now: 0.0,
                before: 1.0,
            },
        ];
        lambda = lambdas(&params(1, 1.0), &half, w, h);
        assert!((lambda[0] - 0.5).abs() < 1e-6, "{}", lambda[0]);
        lambda = lambdas(&params(1, 4.0), &half, w, h);
        assert_eq!(lambda[0], 1.0);
        assert_eq!(lambda[5 * w + 10], 0.0, "no sample in the window: kept");
    }

    #[test]
    fn opposite_noise_cancels_and_bad_input_is_named() {
        let (w, h) = (8, 8);
        // A path that now misses a light it hit, beside one that now hits a light it missed:
        // the window's light did not change.
        let noise = [
            ShadingChange {
                pixel: 9,
                now: 4.0,
                before: 0.0,
            },
            ShadingChange {
                pixel: 10,
                now: 0.0,
                before: 4.0,
            },
            ShadingChange {
                pixel: 11,
                now: f32::NAN,
                before: 1.0,
            },
        ];
        let lambda = lambdas(&params(2, 1.0), &noise, w, h);
        assert_eq!(lambda[9], 0.0);
        assert!(validate(&noise, w, h).is_ok());
        let outside = [ShadingChange {
            pixel: 64,
            now: 1.0,
            before: 1.0,
        }];
        let e = validate(&outside, w, h).unwrap_err().to_string();
        assert!(e.contains("64") && e.contains("8x8"), "{e}");
    }

    #[test]
    fn the_kept_history_follows_a_uniform_change() {
        let (w, h) = (9, 9);
        // Every sample 20 % brighter: ρ = 1.2 everywhere it has samples, λ = gain · 0.2 / 1.2.
        let brighter: Vec<ShadingChange> = (0..w * h)
            .step_by(2)
            .map(|i| ShadingChange {
                pixel: i,
                now: 1.2 * (1 + i % 3) as f32,
                before: (1 + i % 3) as f32,
            })
            .collect();
        let p = TemporalParams {
            reshade_rescale: true,
            ..params(2, 1.0)
        };
        let (mut plane, mut lambda, mut scale) = (vec![], vec![], vec![]);
        rejection(&p, &brighter, w, h, &mut plane, &mut lambda, &mut scale);
        for i in 0..w * h {
            assert!((scale[i] - 1.2).abs() < 1e-5, "{i}: {}", scale[i]);
            assert!((lambda[i] - 0.2 / 1.2).abs() < 1e-5, "{i}: {}", lambda[i]);
        }
        // A light that went out: nothing to scale, all rejected.
        let out = [ShadingChange {
            pixel: 40,
            now: 0.0,
            before: 3.0,
        }];
        rejection(&p, &out, w, h, &mut plane, &mut lambda, &mut scale);
        assert_eq!((lambda[40], scale[40]), (1.0, 1.0));
        // Without rescaling no scale is made.
        rejection(
            &params(2, 1.0),
            &out,
            w,
            h,
            &mut plane,
            &mut lambda,
            &mut scale,
        );
        assert!(scale.is_empty());
    }
}
