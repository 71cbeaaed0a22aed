//! `auto`: guided filters at several radii, blended per pixel by an estimate of each one's
//! error there — leave-one-out cross-validation, the σ-free cousin of SURE (Li, Wu & Chuang
//! 2012 select per pixel among filter scales by SURE).
//!
//! Why this shape: no single radius suits a frame. Where the noise is heavy and the
//! illumination smooth (an indirect-only room at 1 spp) a 32-pixel window is best; along
//! shadow edges, contact shadows and glossy highlights a 4-pixel one is. The guided filter is
//! linear in the colour for a fixed geometry guide, so its self-weight `W_pp = ∂F_p/∂y_p` is
//! exact ([`crate::guided::self_weight`]), and `(y_p − F_p) / (1 − W_pp)` is the error of predicting the
//! pixel from its neighbours alone. Its square estimates MSE + σ², and σ² — the noise, which
//! nothing here knows — is the same for every candidate at a pixel, so it drops out of the
//! comparison: no variance plane or noise model is needed, which matters for frames from other
//! renderers. The squared errors are averaged over a window (a single pixel's is pure noise)
//! and turned into soft weights.
//!
//! Everything runs on the albedo-demodulated colour (texture is not filtered) when an albedo
//! plane is given; lights are the caller's business, as for every filter
//! ([`crate::with_passthrough`], [`crate::detect_emitters`]).

mod atrous_candidate;
mod fireflies;

use lumo_image::Image;
use rayon::prelude::*;

use crate::common::albedo::surface_albedo;
use crate::common::boxsum::box_mean;
use crate::common::gbuffer::{check_color, missing_pixels, Features, Filtered};
use crate::common::nonnegative::clamp_negative;
use crate::common::zeroed::{zeroed, zeroed_image};
use crate::denoiser::{Denoiser, FilterInput, FilterKind};
use crate::guided::SharedInput;
use crate::{build_guide, demodulate, DepthNorm, FilterError, GuideKind, GuidedParams};
use lumo_simd::fastmath::exp_neg;

/// Parameters of [`auto`]; the defaults were chosen on the tuning set (scenes/tuning and the
/// built-in scenes), never on scenes/heldout (docs/filters.md).
#[derive(Clone, Debug, PartialEq)]
pub struct AutoParams {
    /// Window radii of the candidate guided filters.
    pub radii: Vec<usize>,
    /// Radii of further candidates whose guide has ε = [`Self::flat_eps`] on every dimension:
    /// flatter per-window models, with less variance and more bias than the main ones'.
    pub flat_radii: Vec<usize>,
    /// ε of the [`Self::flat_radii`] candidates' guide.
    pub flat_eps: f32,
    /// ε on the guide's normal dimensions.
    pub eps_normal: f32,
    /// ε on its depth dimension.
    pub eps_depth: f32,
    /// Candidates of this radius and larger run the fast guided filter on a grid twice as
    /// coarse (0 = none): a quarter of the cost, and at such radii the same image to the
    /// tuning set's FLIP.
    pub coarse_from: usize,
    /// Radius of the window the squared leave-one-out errors are averaged over.
    pub error_radius: usize,
    /// Softness of the blend: a candidate whose error exceeds the best one's by this fraction
    /// of it gets weight e⁻¹ relative to the best.
    pub softness: f32,
    /// Divide by the albedo before filtering (when an albedo plane is given).
    pub demodulate: bool,
    /// Also blend the edge-avoiding À-Trous (its colour weight keeps the edges the geometry
    /// guide does not explain, such as hard shadows), its self-weight measured by a probe.
    pub atrous: bool,
    /// Firefly threshold k (0 = off): a pixel whose demodulated luminance exceeds k × the
    /// mean of its neighbourhood (fireflies clamped out of that mean first) is scaled down to
    /// that bound before the candidates see it, and what was taken off is spread back over a
    /// window of [`Self::firefly_spread`] by the geometry-guided filter (`auto/fireflies.rs`).
    pub firefly_k: f32,
    /// Radius of the neighbourhood the firefly threshold is measured over.
    pub firefly_radius: usize,
    /// Radius of the guided filter that spreads the fireflies' excess.
    pub firefly_spread: usize,
    /// Calibration of the unfiltered input as one more candidate (0 = not a candidate): its
    /// error is taken as 2σ̂², σ̂² this factor × the window mean of each pixel's smallest
    /// squared second difference over eight directions / 6 (`input_error`). 6.6 makes σ̂²
    /// unbiased for white Gaussian noise (the smallest of the eight averages 0.15σ²) and an
    /// over-estimate for heavier-tailed noise (1.9× for 4-spp-like, 3× for 1-spp-like noise
    /// in simulation), so the input wins only where every filter's bias clearly exceeds the
    /// noise: thin shadows and wires that no guide explains.
    pub input_noise: f32,
}

impl Default for AutoParams {
    fn default() -> Self {
        Self {
            radii: vec![2, 4, 8, 12, 16, 24, 32],
            flat_radii: vec![16, 32],
            flat_eps: 0.01,
            eps_normal: 1e-4,
            eps_depth: 1e-5,
            coarse_from: 12,
            error_radius: 12,
            softness: 0.01,
            demodulate: true,
            atrous: true,
            firefly_k: 16.0,
            firefly_radius: 8,
            firefly_spread: 64,
            // Off by default: on a held-out Mitsuba 1-spp sun frame the input won almost
            // everywhere (relMSE 0.309 against 4.6e-3 without it; docs/filters.md).
            input_noise: 0.0,
        }
    }
}

/// Denoises `color` (3 channels) with [`AutoParams::radii`] guided filters, the
/// [`AutoParams::flat_radii`] ones and the À-Trous, blended per pixel by their estimated
/// error. Needs a normal plane; uses depth (4-D guide) and albedo when given (background
/// pixels pass through, [`crate::surface_albedo`]). Missing (non-finite) colour pixels take
/// no part in the error estimate.
pub fn auto(
    color: &Image,
    features: &Features,
    params: &AutoParams,
) -> Result<Filtered, FilterError> {
    check_color("color", color)?;
    if crate::common::transpose::few_rows(color.width, color.height) {
        // Its guided candidates' rows would be as wide as the image (common/transpose.rs).
        if let Some(t) = crate::common::transpose::TransposedInput::of(color, features) {
            return auto(&t.color, &t.features(), params).map(crate::common::transpose::back);
        }
    }
    if params.radii.is_empty() || params.radii.contains(&0) || params.flat_radii.contains(&0) {
        return Err(crate::common::error::param(
            "auto radii",
            format!(
                "{:?} and flat {:?} (give one or more radii ≥ 1, and flat radii ≥ 1)",
                params.radii, params.flat_radii
            ),
        ));
    }
    if !(params.flat_eps > 0.0 && params.flat_eps.is_finite()) {
        return Err(crate::common::error::param(
            "auto flat ε",
            format!("{} (must be finite and > 0)", params.flat_eps),
        ));
    }
    if !(params.firefly_k >= 0.0 && params.firefly_k.is_finite()) {
        return Err(crate::common::error::param(
            "auto firefly k",
            format!("{} (use 0 = off, or a finite k > 0)", params.firefly_k),
        ));
    }
    if params.firefly_k > 0.0 && (params.firefly_radius == 0 || params.firefly_spread == 0) {
        return Err(crate::common::error::param(
            "auto firefly radii",
            format!(
                "{} and {} (both must be ≥ 1 when the firefly threshold is on)",
                params.firefly_radius, params.firefly_spread
            ),
        ));
    }
    if !(params.input_noise >= 0.0 && params.input_noise.is_finite()) {
        return Err(crate::common::error::param(
            "auto input noise",
            format!(
                "{} (use 0 = off, or a finite factor > 0)",
                params.input_noise
            ),
        ));
    }
    if !(params.softness > 0.0) {
        return Err(crate::common::error::param(
            "auto softness",
            format!("{} (must be > 0)", params.softness),
        ));
    }
    let kind = if features.depth.is_some() {
        GuideKind::NormalDepth
    } else {
        GuideKind::Normal
    };
    let guide = build_guide(
        kind,
        features,
        DepthNorm::Range,
        params.eps_normal,
        params.eps_depth,
    )
    .map_err(|e| match e {
        FilterError::MissingFeature { needs, .. } => FilterError::MissingFeature {
            filter: "the auto filter",
            needs,
        },
        e => e,
    })?;
    let (w, h) = (color.width, color.height);
    let n = w * h;
    let albedo = params
        .demodulate
        .then(|| surface_albedo(features))
        .flatten();
    let demod = albedo.map(|a| demodulate(color, &a)).transpose()?;
    let y = demod.as_ref().map_or(color, |d| &d.illumination);
    let fireflies = (params.firefly_k > 0.0)
        .then(|| fireflies::split(y, params.firefly_k, params.firefly_radius))
        .filter(|f| f.count > 0);
    let y = fireflies.as_ref().map_or(y, |f| &f.clamped);
    // A window larger than the image only costs time: cap the radii, drop repeats.
    let cap = |r: &usize| (*r).min(w.max(h));
    let mut runs: Vec<(usize, bool)> = (params.radii.iter().map(cap).map(|r| (r, false)))
        .chain(params.flat_radii.iter().map(cap).map(|r| (r, true)))
        .collect();
    runs.sort_unstable();
    runs.dedup();
    // The flat candidates' ε: flat_eps on every dimension of the same guide planes.
    let flat_eps = vec![params.flat_eps; guide.dims];
    let mut shared = SharedInput::new(y, &guide)?;
    let finite = FiniteShare::new(y, params.error_radius);
    let mut candidates = Vec::with_capacity(runs.len() + 1);
    let mut errors = Vec::with_capacity(runs.len() + 1);
    for &(r, is_flat) in &runs {
        let eps = if is_flat { &flat_eps } else { &guide.eps };
        let subsampled = params.coarse_from > 0 && r >= params.coarse_from;
        let gp = GuidedParams {
            radius: r,
            fast_subsample: if subsampled { 2 } else { 1 },
        };
        let (f, self_weight) = shared.self_weighted(eps, &gp)?;
        errors.push(loo_error(
            y,
            &f.image,
            &self_weight,
            params.error_radius,
            &finite,
        ));
        candidates.push(f.image);
    }
    if params.atrous {
        let (f, self_weight) = atrous_candidate::atrous_candidate(y, features)?;
        errors.push(loo_error(y, &f, &self_weight, params.error_radius, &finite));
        candidates.push(f);
    }
    if params.input_noise > 0.0 {
        errors.push(input_error(y, params.input_noise, params.error_radius));
        candidates.push(finite_or_zero(y));
    }
    let mut blended = blend(&candidates, &errors, params.softness, w, h);
    debug_assert_eq!(blended.data.len(), n * 3);
    if let Some(f) = &fireflies {
        let spread = fireflies::spread(&f.excess, &guide, params.firefly_spread)?;
        for (b, s) in blended.data.iter_mut().zip(&spread.data) {
            *b += s;
        }
    }
    let mut image = match &demod {
        Some(d) => d.remodulate(&blended, color),
        None => blended,
    };
    clamp_negative(&mut image);
    Ok(Filtered {
        image,
        missing: missing_pixels(color),
    })
}

/// The candidates blended per pixel with weights `exp(−(e_k − e_min) / (softness · e_min))`,
/// row by row.
fn blend(candidates: &[Image], errors: &[Vec<f32>], softness: f32, w: usize, h: usize) -> Image {
    let mut blended = zeroed_image(w, h, 3);
    blended
        .data
        .par_chunks_mut(3 * w)
        .enumerate()
        .for_each_init(
            || (vec![0.0f32; w], vec![0.0f32; w], vec![0.0f32; w]),
            |(best, inv_scale, total), (y, out)| {
                blend_row(candidates, errors, softness, y, out, best, inv_scale, total)
            },
        );
    blended
}

multiversion! {
    /// Row `y` of [`blend`] into `out` (3 values per pixel, zero on entry), with three
    /// scratch rows. Loops over the row's pixels, so that the weights' exponentials
    /// ([`exp_neg`]: a relative error below 1e-5, below 2e-9 exactly 0) vectorise.
    #[allow(clippy::too_many_arguments)]
    fn blend_row(
        candidates: &[Image],
        errors: &[Vec<f32>],
        softness: f32,
        y: usize,
        out: &mut [f32],
        best: &mut [f32],
        inv_scale: &mut [f32],
        total: &mut [f32],
    ) as blend_row_impl {
        let w = best.len();
        let row = y * w..(y + 1) * w;
        best.fill(f32::INFINITY);
        for e in errors {
            for (b, &v) in best.iter_mut().zip(&e[row.clone()]) {
                *b = b.min(v);
            }
        }
        for (s, &b) in inv_scale.iter_mut().zip(best.iter()) {
            *s = 1.0 / (softness * b.max(1e-12));
        }
        total.fill(0.0);
        for (f, e) in candidates.iter().zip(errors) {
            let (fr, er) = (&f.data[3 * row.start..3 * row.end], &e[row.clone()]);
            for x in 0..w {
                let wk = exp_neg(-(er[x] - best[x]) * inv_scale[x]);
                total[x] += wk;
                for c in 0..3 {
                    out[3 * x + c] += wk * fr[3 * x + c];
                }
            }
        }
        for x in 0..w {
            let inv = 1.0 / total[x];
            for c in 0..3 {
                out[3 * x + c] *= inv;
            }
        }
    }
}

/// Squared leave-one-out prediction error `Σ_c ((y − F) / (1 − W_pp))²`, averaged over the
/// window of radius `r` over the finite pixels (a window with none gets 1 for every
/// candidate, so the blend there is uniform). `finite` is [`FiniteShare`] of `y` for `r`.
fn loo_error(
    y: &Image,
    f: &Image,
    self_weight: &[f32],
    r: usize,
    finite: &FiniteShare,
) -> Vec<f32> {
    let (w, h) = (y.width, y.height);
    let mut sq = zeroed(w * h);
    // Whether some error is finite where the colour is not or the other way round (an
    // overflow): then the shared count does not apply.
    let differs = sq
        .par_chunks_mut(w.max(1))
        .enumerate()
        .map(|(row, s)| {
            let mut differs = false;
            for (x, s) in s.iter_mut().enumerate() {
                let i = row * w + x;
                // A pixel that is all its own estimate predicts nothing: floor the denominator.
                let k = 1.0 / (1.0 - self_weight[i]).max(0.05);
                let mut e = 0.0;
                for c in 0..3 {
                    let d = (y.data[i * 3 + c] - f.data[i * 3 + c]) * k;
                    e += d * d;
                }
                if e.is_finite() {
                    *s = e;
                }
                differs |= e.is_finite() != finite.valid[i];
            }
            differs
        })
        .reduce(|| false, |a, b| a || b);
    if differs {
        return loo_error_pairs(y, f, self_weight, r);
    }
    let mut m = box_mean(&sq, w, h, 1, r);
    for (e, &n) in m.iter_mut().zip(&finite.mean) {
        *e = if n > 0.0 { *e / n } else { 1.0 };
    }
    m
}

/// [`loo_error`] with the count summed beside each error: for a candidate whose errors are
/// not finite exactly where the colour is.
fn loo_error_pairs(y: &Image, f: &Image, self_weight: &[f32], r: usize) -> Vec<f32> {
    let (w, h) = (y.width, y.height);
    let mut sq = zeroed(w * h * 2);
    sq.par_chunks_mut(2).enumerate().for_each(|(i, s)| {
        let k = 1.0 / (1.0 - self_weight[i]).max(0.05);
        let mut e = 0.0;
        for c in 0..3 {
            let d = (y.data[i * 3 + c] - f.data[i * 3 + c]) * k;
            e += d * d;
        }
        if e.is_finite() {
            s[0] = e;
            s[1] = 1.0;
        }
    });
    let m = box_mean(&sq, w, h, 2, r);
    m.chunks_exact(2)
        .map(|p| if p[1] > 0.0 { p[0] / p[1] } else { 1.0 })
        .collect()
}

/// Which pixels of the (demodulated) colour are finite, and the window means of that count:
/// the second half of every candidate's [`loo_error`] window mean, the same for all of them
/// (their errors are finite exactly where the colour is), so it is summed once rather than
/// once per candidate. Box means are channel by channel, so the bits are those of a
/// two-channel mean of (error, count).
struct FiniteShare {
    valid: Vec<bool>,
    mean: Vec<f32>,
}

impl FiniteShare {
    fn new(y: &Image, r: usize) -> Self {
        let valid: Vec<bool> = y
            .data
            .par_chunks_exact(3)
            .map(|p| p.iter().all(|v| v.is_finite()))
            .collect();
        let ones: Vec<f32> = valid.iter().map(|&v| if v { 1.0 } else { 0.0 }).collect();
        let mean = box_mean(&ones, y.width, y.height, 1, r);
        Self { valid, mean }
    }
}

/// The error estimate of the unfiltered input as a candidate, in the units of [`loo_error`]
/// (squared error summed over the channels, window-averaged): its MSE is the noise σ², and
/// every leave-one-out error carries σ² on top of its MSE, so it is 2σ̂².
///
/// σ̂² per pixel: the smallest, over eight directions ([`DIRECTIONS`]), of the squared second
/// difference `Σ_c (y₋ − 2y + y₊)²`, / 6 (its variance for white noise; one-sided at the
/// frame's edge and beside background or missing pixels), × `k`. The smallest,
/// because a thin line or an edge along one of the directions leaves that direction's
/// difference at the noise's level while it inflates a window variance;
/// that is the case where keeping the input matters (why: a sun-lit lattice's one-pixel
/// shadows on flat ground, which every guided candidate blurs away, made `auto` worse than
/// its input on `thin-branches`). Pixels without a finite neighbour pair take no part; a
/// window without any gets +∞ (the input is never chosen there), and so do missing pixels.
fn input_error(y: &Image, k: f32, r: usize) -> Vec<f32> {
    let (w, h) = (y.width, y.height);
    let mut sq = zeroed(w * h * 2);
    sq.par_chunks_mut(2 * w.max(1))
        .enumerate()
        .for_each(|(py, row)| {
            for px in 0..w {
                let at = |x: usize, yy: usize| &y.data[(yy * w + x) * 3..][..3];
                let c = at(px, py);
                if !c.iter().all(|v| v.is_finite()) {
                    continue;
                }
                let mut best = f32::INFINITY;
                for (dx, dy) in DIRECTIONS {
                    // A neighbour outside the frame, or missing or background (NaN), leaves
                    // the one-sided difference: (y₊ − y)² / 2, also σ² for white noise.
                    let side = |sx: isize, sy: isize| -> Option<&[f32]> {
                        let (x, yy) = (px as isize + sx, py as isize + sy);
                        let inside = x >= 0 && yy >= 0 && (x as usize) < w && (yy as usize) < h;
                        let v = inside.then(|| at(x as usize, yy as usize))?;
                        v.iter().all(|v| v.is_finite()).then_some(v)
                    };
                    let e = match (side(-dx, -dy), side(dx, dy)) {
                        (Some(a), Some(b)) => {
                            (0..3)
                                .map(|ch| (a[ch] - 2.0 * c[ch] + b[ch]).powi(2))
                                .sum::<f32>()
                                / 6.0
                        }
                        (Some(a), None) | (None, Some(a)) => {
                            (0..3).map(|ch| (a[ch] - c[ch]).powi(2)).sum::<f32>() / 2.0
                        }
                        (None, None) => continue,
                    };
                    if e.is_finite() {
                        best = best.min(e);
                    }
                }
                if best.is_finite() {
                    row[2 * px] = best;
                    row[2 * px + 1] = 1.0;
                }
            }
        });
    let m = box_mean(&sq, w, h, 2, r);
    m.chunks_exact(2)
        .enumerate()
        .map(|(i, p)| {
            let own = y.data[i * 3..i * 3 + 3].iter().all(|v| v.is_finite());
            if own && p[1] > 0.0 {
                2.0 * k * p[0] / p[1]
            } else {
                f32::INFINITY
            }
        })
        .collect()
}

/// The steps of [`input_error`]'s second differences: horizontal, vertical, the diagonals
/// and the four knight's moves, so that a line at any slope near 0, ±½, ±1, ±2 or ∞ runs
/// along one of them.
const DIRECTIONS: [(isize, isize); 8] = [
    (1, 0),
    (0, 1),
    (1, 1),
    (1, -1),
    (1, 2),
    (2, 1),
    (1, -2),
    (2, -1),
];

/// `y` with its non-finite values set to 0: a candidate that never wins there must still not
/// turn the blend's `0 × value` into NaN.
fn finite_or_zero(y: &Image) -> Image {
    let mut out = y.clone();
    for v in &mut out.data {
        if !v.is_finite() {
            *v = 0.0;
        }
    }
    out
}

/// [`auto`] behind the [`Denoiser`] interface. Needs a normal plane; reads depth and albedo
/// when given.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AutoDenoiser {
    /// Its parameters.
    pub params: AutoParams,
}

impl Denoiser for AutoDenoiser {
    fn name(&self) -> &'static str {
        FilterKind::Auto.name()
    }

    fn denoise(&mut self, input: &FilterInput) -> Result<Filtered, FilterError> {
        auto(input.color, &input.features, &self.params)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The error window with the count shared between candidates gives the bits of the
    /// two-channel mean of (error, count) it replaced: with missing colour pixels, with a
    /// window that holds none, and with a candidate whose error overflows where the colour
    /// is finite (the fallback).
    #[test]
    fn shared_count_gives_the_bits_of_the_pairwise_mean() {
        let (w, h, r) = (41, 23, 3);
        let mut y = Image::new(w, h, 3, 0.0);
        for (i, v) in y.data.iter_mut().enumerate() {
            *v = 0.5 + 0.4 * ((i as f32 * 0.618) * 12.9898).sin();
        }
        // A missing block wider than the window, so some windows hold no finite pixel.
        for yy in 5..14 {
            for x in 20..29 {
                y.pixel_mut(x, yy)[1] = f32::NAN;
            }
        }
        let mut f = y.clone();
        for (i, v) in f.data.iter_mut().enumerate() {
            *v = if v.is_finite() {
                *v * 0.9 + 0.01 * (i % 7) as f32
            } else {
                0.3
            };
        }
        let weights: Vec<f32> = (0..w * h).map(|i| (i % 11) as f32 * 0.09).collect();
        let finite = FiniteShare::new(&y, r);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let shared = loo_error(&y, &f, &weights, r, &finite);
        assert_eq!(bits(&shared), bits(&loo_error_pairs(&y, &f, &weights, r)));
        assert_eq!(shared[10 * w + 24], 1.0, "a window without finite pixels");
        // An error that overflows f32 where the colour is finite.
        f.data[3 * (2 * w + 2)] = 3e38;
        let overflow = loo_error(&y, &f, &weights, r, &finite);
        assert_eq!(bits(&overflow), bits(&loo_error_pairs(&y, &f, &weights, r)));
        assert_ne!(bits(&overflow), bits(&shared));
    }
}
