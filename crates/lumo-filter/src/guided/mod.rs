//! Guided image filter (He et al. 2010) with a geometry guide (Bauszat et al. 2011; papers/README
//! §2), and the fast guided filter (He & Sun 2015) as an option.
//!
//! Files: this one (guide building, parameters, the public entry point, the sub-sampled
//! variant), stream.rs (the exact filter streamed row by row), cholesky.rs (its small window
//! solves), self_weight.rs (the exact `∂F_p/∂y_p` that `auto` needs, streamed with the filter),
//! shared.rs (the input prepared once for several runs) and lookup.rs (the paper's
//! geometry-aware lookup, used by the guided pipeline).

pub(crate) mod cholesky;
mod lookup;
pub(crate) mod self_weight;
mod shared;
mod stream;

use lumo_image::Image;
use rayon::prelude::*;

use crate::common::albedo::{surface_albedo, with_demodulation};
use crate::common::boxsum::box_mean_rows;
use crate::common::error::param;
use crate::common::gbuffer::{
    background_mask, check_color, check_features, check_size, flush, plane0, Features, Filtered,
};
use crate::common::nonnegative::clamp_negative;
use crate::common::zeroed::{zeroed, zeroed_image};
use crate::denoiser::{require, Denoiser, FilterInput, FilterKind};
use crate::FilterError;
use self_weight::{cross_weight_lanes, terms, LANES};
pub(crate) use shared::SharedInput;
use stream::{stream, Plane, Problem};

pub use lookup::{most_similar, most_similar_in_grid, neighbour_cells};

/// Largest supported guide dimension.
pub const MAX_GUIDE_DIMS: usize = 8;

/// Which guide to build from the G-buffer (the paper's 1 / 3 / 4 dimensions).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GuideKind {
    /// 1 dim: grey value of the normal image (mean of the normalised x, y, z).
    Grey,
    /// 3 dims: normal, n·0.5 + 0.5.
    Normal,
    /// 4 dims: normal and normalised depth.
    NormalDepth,
}

impl GuideKind {
    /// The guide's dimension.
    pub fn dims(self) -> usize {
        match self {
            GuideKind::Grey => 1,
            GuideKind::Normal => 3,
            GuideKind::NormalDepth => 4,
        }
    }
}

/// How depth is mapped to [0, 1] for the guide.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DepthNorm {
    /// (d − min) / (max − min) over the finite, non-background depths of this image.
    Range,
    /// d / scale, clamped to [0, 1]: a constant from the scene's extent that stays fixed while
    /// rendering (the paper's choice; avoids flicker when the visible range changes).
    Scale(f32),
}

/// A guide image: `dims` interleaved channels per pixel, values in about [0, 1], with one ε per
/// dimension (added to the diagonal of the window covariance).
#[derive(Clone, Debug, PartialEq)]
pub struct Guide {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Channels per pixel, 1..=8.
    pub dims: usize,
    /// `width*height*dims` values, pixel-major.
    pub data: Vec<f32>,
    /// Regularisation per dimension (> 0).
    pub eps: Vec<f32>,
}

impl Guide {
    /// A guide from any image with 1..=8 channels (already scaled to about [0, 1]) and one ε
    /// per channel. Non-finite guide values are replaced by 0.
    pub fn from_image(img: &Image, eps: Vec<f32>) -> Result<Guide, FilterError> {
        if img.channels == 0 || img.channels > MAX_GUIDE_DIMS {
            return Err(FilterError::Channels {
                name: "guide",
                got: img.channels,
                expected: "1..=8",
            });
        }
        if eps.len() != img.channels {
            return Err(param(
                "eps",
                format!("{} values for a {}-channel guide", eps.len(), img.channels),
            ));
        }
        check_eps(&eps)?;
        Ok(Guide {
            width: img.width,
            height: img.height,
            dims: img.channels,
            data: img
                .data
                .iter()
                .map(|v| if v.is_finite() { *v } else { 0.0 })
                .collect(),
            eps,
        })
    }
}

/// Every ε must be finite and > 0.
fn check_eps(eps: &[f32]) -> Result<(), FilterError> {
    match eps.iter().find(|e| !(**e > 0.0 && e.is_finite())) {
        Some(e) => Err(param("eps", format!("{e} (must be > 0)"))),
        None => Ok(()),
    }
}

/// Builds a 1-, 3- or 4-dimensional guide from `features.normal` (and `features.depth`), with
/// ε = `eps_normal` on normal dimensions and `eps_depth` on depth. Background pixels get depth 1
/// (the far end), so windows across a silhouette see a large guide variance.
pub fn build_guide(
    kind: GuideKind,
    features: &Features,
    depth_norm: DepthNorm,
    eps_normal: f32,
    eps_depth: f32,
) -> Result<Guide, FilterError> {
    let normal = features.normal.ok_or_else(|| FilterError::MissingFeature {
        filter: "the guided filter",
        needs: format!("a normal plane for a {}-dimensional guide", kind.dims()),
    })?;
    let (w, h) = (normal.width, normal.height);
    check_features(features, w, h)?;
    let npix = w * h;
    let dims = kind.dims();
    let mut data = vec![0.0f32; npix * dims];
    let mut eps = vec![eps_normal; dims];
    let nc = normal.channels;
    // Non-finite normal components count as 0; non-finite guide values (from huge ones) too.
    let finite = |v: f32| if v.is_finite() { v } else { 0.0 };
    data.par_chunks_mut(w * dims)
        .zip(normal.data.par_chunks(w * nc))
        .for_each(|(out, src)| {
            for (o, n) in out.chunks_exact_mut(dims).zip(src.chunks_exact(nc)) {
                let n = [finite(n[0]), finite(n[1]), finite(n[2])];
                if kind == GuideKind::Grey {
                    o[0] = finite(((n[0] + n[1] + n[2]) / 3.0) * 0.5 + 0.5);
                } else {
                    for c in 0..3 {
                        o[c] = finite(n[c] * 0.5 + 0.5);
                    }
                }
            }
        });
    if kind == GuideKind::NormalDepth {
        let depth = features.depth.ok_or_else(|| FilterError::MissingFeature {
            filter: "the guided filter",
            needs: "a depth plane for a 4-dimensional guide (normal + depth)".into(),
        })?;
        check_size("depth", depth, "normal", w, h)?;
        let d = plane0(depth);
        let bg = background_mask(features, npix);
        let (lo, hi) = match depth_norm {
            DepthNorm::Scale(s) => {
                if !(s > 0.0 && s.is_finite()) {
                    return Err(param("depth scale", format!("{s} (must be > 0)")));
                }
                (0.0, s)
            }
            DepthNorm::Range => {
                let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                for (v, b) in d.iter().zip(&bg) {
                    if *b == 0.0 {
                        lo = lo.min(*v);
                        hi = hi.max(*v);
                    }
                }
                if lo.is_finite() && hi > lo {
                    (lo, hi)
                } else {
                    (0.0, 1.0)
                }
            }
        };
        let inv = 1.0 / (hi - lo);
        for i in 0..npix {
            data[i * 4 + 3] = if bg[i] > 0.0 {
                1.0
            } else {
                let v = ((d[i] - lo) * inv).clamp(0.0, 1.0);
                if v.is_finite() {
                    v
                } else {
                    0.0
                }
            };
        }
        eps[3] = eps_depth;
    }
    check_eps(&eps)?;
    Ok(Guide {
        width: w,
        height: h,
        dims,
        data,
        eps,
    })
}

/// Parameters of [`guided`].
#[derive(Clone, Debug, PartialEq)]
pub struct GuidedParams {
    /// Window radius r (window (2r+1)²); the paper uses 24–32.
    pub radius: usize,
    /// Fast guided filter sub-sampling s: coefficients computed on a grid s times coarser
    /// (radius r/s) and bilinearly upsampled. 1 = the exact guided filter.
    pub fast_subsample: usize,
}

/// Default window radius, see docs/filters.md.
pub const DEFAULT_RADIUS: usize = 24;
/// Default ε for normal dimensions, see docs/filters.md.
pub const DEFAULT_EPS_NORMAL: f32 = 0.003;
/// Default ε for the depth dimension, see docs/filters.md.
pub const DEFAULT_EPS_DEPTH: f32 = 0.003;

impl Default for GuidedParams {
    /// Defaults chosen by the sweep in docs/filters.md.
    fn default() -> Self {
        Self {
            radius: DEFAULT_RADIUS,
            fast_subsample: 1,
        }
    }
}

/// The guided filter behind the [`Denoiser`] interface: builds the guide from the input's
/// normal (and depth) planes on every call, as [`build_guide`], then runs [`guided`]. Needs a
/// normal plane, and a depth plane for [`GuideKind::NormalDepth`]; the albedo when
/// demodulating.
#[derive(Clone, Debug, PartialEq)]
pub struct GuidedDenoiser {
    /// Which guide to build.
    pub guide: GuideKind,
    /// How depth is mapped to the guide's [0, 1].
    pub depth_norm: DepthNorm,
    /// ε on the guide's normal dimensions.
    pub eps_normal: f32,
    /// ε on its depth dimension.
    pub eps_depth: f32,
    /// The filter's parameters.
    pub params: GuidedParams,
    /// Filter colour / albedo and multiply back ([`with_demodulation`]; needs an albedo).
    pub demodulate: bool,
}

impl Default for GuidedDenoiser {
    /// The 4-dimensional guide (normal + depth, depth over its range) with the defaults of
    /// docs/filters.md.
    fn default() -> Self {
        Self {
            guide: GuideKind::NormalDepth,
            depth_norm: DepthNorm::Range,
            eps_normal: DEFAULT_EPS_NORMAL,
            eps_depth: DEFAULT_EPS_DEPTH,
            params: GuidedParams::default(),
            demodulate: false,
        }
    }
}

impl Denoiser for GuidedDenoiser {
    fn name(&self) -> &'static str {
        FilterKind::Guided.name()
    }

    /// [`build_guide`] from the input's features, then [`guided`], demodulated when asked;
    /// negative output values are set to 0 (the pure [`guided`] keeps them, as OpenCV's
    /// does).
    fn denoise(&mut self, input: &FilterInput) -> Result<Filtered, FilterError> {
        let guide = build_guide(
            self.guide,
            &input.features,
            self.depth_norm,
            self.eps_normal,
            self.eps_depth,
        )?;
        let mut out = if self.demodulate {
            let albedo = surface_albedo(&input.features);
            let albedo = require(albedo.as_deref(), "albedo demodulation", "an albedo plane")?;
            with_demodulation(input.color, albedo, |c| guided(c, &guide, &self.params))
        } else {
            guided(input.color, &guide, &self.params)
        }?;
        // The linear model overshoots below 0 beside bright edges: no light to that.
        clamp_negative(&mut out.image);
        Ok(out)
    }
}

/// Filters each channel of `color` (3 channels) against the same `guide`: per window a linear
/// model `q = aᵀI + b`, with `a = (Σ + diag ε)⁻¹ cov(I, p)`; coefficients averaged over all
/// windows covering a pixel. Missing colour pixels are first filled with the mean of the valid
/// pixels in their window. Cost is independent of the radius.
pub fn guided(
    color: &Image,
    guide: &Guide,
    params: &GuidedParams,
) -> Result<Filtered, FilterError> {
    use crate::common::transpose::{back, few_rows, transposed};
    let same_size = (guide.width, guide.height) == (color.width, color.height);
    if same_size && few_rows(color.width, color.height) && color.channels > 0 {
        // Rows as wide as the image would cost ~740 bytes per pixel (common/transpose.rs).
        let flat = Image {
            width: guide.width,
            height: guide.height,
            channels: guide.dims,
            data: guide.data.clone(),
        };
        let turned = Guide {
            width: guide.height,
            height: guide.width,
            dims: guide.dims,
            data: transposed(&flat).data,
            eps: guide.eps.clone(),
        };
        return guided(&transposed(color), &turned, params).map(back);
    }
    SharedInput::new(color, guide)?.filter(&guide.eps, params)
}

/// The guided filter with `params` and its self-weight `∂F_p/∂y_p` at every pixel
/// ([`self_weight`]), in one pass: the terms of the weight are averaged over the same windows
/// as the filter's coefficients, from the same factorisations (`auto`'s candidates). Exact
/// for the exact filter; for the fast filter (sub-sampling s > 1) an approximation: the
/// pixel's input reaches the coarse grid's filter through its block's mean, and the weight
/// is that block's effect on the pixel's interpolated model, counting every window around
/// the interpolation's nodes, also those that miss the block ([`apply_upsampled_weighted`]).
/// (Several runs on the same colour and guide planes: [`SharedInput::self_weighted`].)
#[cfg(test)]
pub(crate) fn guided_self_weighted(
    color: &Image,
    guide: &Guide,
    params: &GuidedParams,
) -> Result<(Filtered, Vec<f32>), FilterError> {
    SharedInput::new(color, guide)?.self_weighted(&guide.eps, params)
}

/// The exact filter's output (the coefficients applied to the guide) and, when `SW`, each
/// pixel's self-weight, for the colour `p` as the filter reads it ([`guided_input`], missing
/// pixels filled); the self-weights are empty unless `SW`.
fn exact<const SW: bool>(pb: &Problem, d: usize) -> (Image, Vec<f32>) {
    let (w, h, g) = (pb.w, pb.h, pb.guide);
    if !SW {
        let mut out = zeroed_image(w, h, 3);
        let plane = (&mut out.data[..], 3 * w);
        stream_dims::<false>(d, pb, plane, (&mut [], 0), &|y, ab, row, _| {
            apply_row(&g[y * w * d..(y + 1) * w * d], d, 3 * d + 3, ab, row)
        });
        return (out, Vec::new());
    }
    let mut image = zeroed_image(w, h, 3);
    let mut weights = zeroed(w * h);
    let planes = ((&mut image.data[..], 3 * w), (&mut weights[..], w));
    stream_dims::<true>(d, pb, planes.0, planes.1, &|y, ab, rgb, wt| {
        weighted_row(&g[y * w * d..(y + 1) * w * d], d, ab, rgb, wt);
    });
    (image, weights)
}

multiversion! {
    /// One row of [`exact`]'s self-weighted output from the row's averaged coefficients and
    /// terms: the filtered colour and each pixel's self-weight. Dispatches on the guide's
    /// dimension so that [`weighted_row_d`]'s loops have constant lengths.
    fn weighted_row(gr: &[f32], d: usize, ab: &[f32], rgb: &mut [f32], weights: &mut [f32])
        as weighted_row_impl
    {
        match d {
            1 => weighted_row_d::<1>(gr, ab, rgb, weights),
            2 => weighted_row_d::<2>(gr, ab, rgb, weights),
            3 => weighted_row_d::<3>(gr, ab, rgb, weights),
            4 => weighted_row_d::<4>(gr, ab, rgb, weights),
            5 => weighted_row_d::<5>(gr, ab, rgb, weights),
            6 => weighted_row_d::<6>(gr, ab, rgb, weights),
            7 => weighted_row_d::<7>(gr, ab, rgb, weights),
            _ => weighted_row_d::<8>(gr, ab, rgb, weights),
        }
    }
}

/// [`weighted_row`] for a `D`-dimensional guide: [`apply_row`]'s sums and
/// the self-weight's (in groups of [`LANES`] pixels, [`cross_weight_lanes`]) in the same
/// order, so the same bits.
#[inline(always)]
fn weighted_row_d<const D: usize>(gr: &[f32], ab: &[f32], rgb: &mut [f32], weights: &mut [f32]) {
    let k0 = 3 * D + 3;
    let k2 = k0 + terms(D);
    let w = weights.len();
    let mut g = [[0.0f64; LANES]; D];
    let mut t = [[0.0f64; LANES]; terms(MAX_GUIDE_DIMS)];
    let mut wt = [0.0f32; LANES];
    for x0 in (0..w).step_by(LANES) {
        let n = (w - x0).min(LANES);
        for l in 0..n {
            let x = x0 + l;
            let gx: &[f32; D] = gr[x * D..][..D].try_into().expect("D values");
            let c = &ab[x * k2..(x + 1) * k2];
            apply_model(c, gx, &mut rgb[3 * x..3 * x + 3]);
            for i in 0..D {
                g[i][l] = gx[i] as f64;
            }
            for (j, v) in c[k0..].iter().enumerate() {
                t[j][l] = *v as f64;
            }
        }
        cross_weight_lanes::<D>(&g, &g, &t[..terms(D)], &mut wt);
        weights[x0..x0 + n].copy_from_slice(&wt[..n]);
    }
}

/// The fast filter's coarse grid for the block means `gl` (guide) and `pl` (input) of an
/// `s`-times coarser grid: the stream's averaged coefficients there at the coarse radius
/// (followed by the self-weight terms when `SW`), written into `ab` (resized; the stream
/// writes every value, so a buffer from an earlier run serves without being cleared).
fn coarse_grid<'a, const SW: bool>(
    (gl, pl): (&'a [f32], &[f32]),
    (lw, lh): (usize, usize),
    (eps, radius, s): (&[f32], usize, usize),
    ab: &'a mut Vec<f32>,
) -> Coarse<'a> {
    let d = eps.len();
    let k2 = 3 * d + 3 + if SW { terms(d) } else { 0 };
    let pb = Problem {
        guide: gl,
        p: pl,
        eps,
        w: lw,
        h: lh,
        r: coarse_radius(radius, s),
    };
    ab.resize(lw * lh * k2, 0.0);
    stream_dims::<SW>(
        d,
        &pb,
        (&mut ab[..], lw * k2),
        (&mut [], 0),
        &|_, m, row, _| row.copy_from_slice(m),
    );
    Coarse {
        guide: gl,
        ab,
        w: lw,
        h: lh,
        s,
    }
}

/// The fast filter's window radius on the grid `s` times coarser.
fn coarse_radius(radius: usize, s: usize) -> usize {
    ((radius as f32 / s as f32).round() as usize).max(1)
}

/// The checks [`guided`] makes of the colour and the guide planes.
fn check_planes(color: &Image, guide: &Guide) -> Result<(), FilterError> {
    check_color("color", color)?;
    let (w, h) = (color.width, color.height);
    if guide.width != w || guide.height != h {
        return Err(FilterError::SizeMismatch {
            name: "guide",
            width: guide.width,
            height: guide.height,
            reference: "color",
            ref_width: w,
            ref_height: h,
        });
    }
    if guide.dims == 0 || guide.dims > MAX_GUIDE_DIMS || guide.data.len() != w * h * guide.dims {
        return Err(FilterError::Channels {
            name: "guide",
            got: guide.dims,
            expected: "1..=8 with width*height*dims values",
        });
    }
    Ok(())
}

/// The checks [`guided`] makes of a run's ε (one per guide dimension) and parameters.
fn check_run(dims: usize, eps: &[f32], params: &GuidedParams) -> Result<(), FilterError> {
    if eps.len() != dims || eps.iter().any(|e| !(*e > 0.0)) {
        return Err(param("eps", "one value > 0 per guide dimension"));
    }
    if params.radius == 0 {
        return Err(param("radius", "0 (must be ≥ 1)"));
    }
    let s = params.fast_subsample;
    if s == 0 || s > 64 {
        return Err(param("fast_subsample", format!("{s} (use 1..=64)")));
    }
    Ok(())
}

/// The colour as the filter reads it, in one pass over the rows (in parallel): pixel-major
/// RGB with pixels that have a non-finite channel set to 0 (and 0 in the returned validity
/// mask), denormals flushed to 0 (they would slow every product they enter), and the number
/// of missing pixels.
fn guided_input(color: &Image) -> (Vec<f32>, Vec<f32>, usize) {
    let w = color.width;
    let mut p = zeroed(color.data.len());
    let mut valid = zeroed(w * color.height);
    let missing = p
        .par_chunks_mut(3 * w)
        .zip(valid.par_chunks_mut(w))
        .zip(color.data.par_chunks(3 * w))
        .map(|((out, ok), src)| {
            let mut missing = 0;
            for ((o, k), c) in out
                .chunks_exact_mut(3)
                .zip(ok.iter_mut())
                .zip(src.chunks_exact(3))
            {
                if c.iter().all(|v| v.is_finite()) {
                    for (o, v) in o.iter_mut().zip(c) {
                        *o = flush(*v);
                    }
                    *k = 1.0;
                } else {
                    missing += 1;
                }
            }
            missing
        })
        .sum();
    (p, valid, missing)
}

/// Replaces missing pixels by the mean of the valid pixels in their window (0 if none): the
/// bits of [`crate::common::boxsum::box_mean`] of (colour × validity, validity), computed only on the rows that hold
/// a missing pixel ([`box_mean_rows`]).
fn fill_missing(p: &mut [f32], valid: &[f32], w: usize, h: usize, r: usize) {
    let wanted: Vec<bool> = valid.chunks_exact(w).map(|v| v.contains(&0.0)).collect();
    let src: &[f32] = p;
    let rows = box_mean_rows(
        |y, buf| {
            for x in 0..w {
                let i = y * w + x;
                for c in 0..3 {
                    buf[x * 4 + c] = src[i * 3 + c] * valid[i];
                }
                buf[x * 4 + 3] = valid[i];
            }
        },
        (w, h, 4, r),
        &wanted,
    );
    for (y, m) in rows {
        for x in 0..w {
            let i = y * w + x;
            if valid[i] == 0.0 {
                let k = m[x * 4 + 3];
                for c in 0..3 {
                    p[i * 3 + c] = if k > 0.0 { m[x * 4 + c] / k } else { 0.0 };
                }
            }
        }
    }
}

/// Block means over s×s blocks (partial blocks at the right and bottom edges).
fn downsample(data: &[f32], w: usize, h: usize, k: usize, s: usize) -> Vec<f32> {
    let (lw, lh) = (w.div_ceil(s), h.div_ceil(s));
    let mut out = vec![0.0f32; lw * lh * k];
    out.par_chunks_mut(lw * k)
        .enumerate()
        .for_each(|(ly, row)| {
            let y1 = ((ly + 1) * s).min(h);
            for lx in 0..lw {
                let x1 = ((lx + 1) * s).min(w);
                let o = &mut row[lx * k..(lx + 1) * k];
                for y in ly * s..y1 {
                    for x in lx * s..x1 {
                        for c in 0..k {
                            o[c] += data[(y * w + x) * k + c];
                        }
                    }
                }
                let inv = 1.0 / ((y1 - ly * s) * (x1 - lx * s)) as f32;
                o.iter_mut().for_each(|v| *v *= inv);
            }
        });
    out
}

/// Low-res sample index pair and weight for full-res coordinate `i`: low-res pixel j has its
/// centre at full-res coordinate (j + 0.5)·s − 0.5 (so s = 1 is the identity).
#[inline(always)]
fn lerp_at(i: usize, s: usize, n: usize) -> (usize, usize, f32) {
    let f = ((i as f32 + 0.5) / s as f32 - 0.5).clamp(0.0, (n - 1) as f32);
    let i0 = f as usize;
    (i0, (i0 + 1).min(n - 1), f - i0 as f32)
}

/// The fast filter's output: per pixel, the bilinearly upsampled coefficients of the
/// coarse grid's coefficients applied to the full-resolution guide, q_c = Σ_i a_ci I_i + b_c.
fn apply_upsampled(guide: &[f32], w: usize, h: usize, d: usize, coarse: &Coarse) -> Image {
    let Coarse {
        ab,
        w: lw,
        h: lh,
        s,
        ..
    } = *coarse;
    let k2 = 3 * d + 3;
    let mut out = zeroed_image(w, h, 3);
    out.data
        .par_chunks_mut(3 * w)
        .enumerate()
        .for_each(|(y, row)| {
            let (y0, y1, ty) = lerp_at(y, s, lh);
            let (r0, r1) = (
                &ab[y0 * lw * k2..][..lw * k2],
                &ab[y1 * lw * k2..][..lw * k2],
            );
            let mut c = vec![0.0f32; k2];
            for (x, o) in row.chunks_exact_mut(3).enumerate() {
                let (x0, x1, tx) = lerp_at(x, s, lw);
                let (a, b) = (&r0[x0 * k2..][..k2], &r0[x1 * k2..][..k2]);
                let (e, f) = (&r1[x0 * k2..][..k2], &r1[x1 * k2..][..k2]);
                for i in 0..k2 {
                    let top = a[i] + (b[i] - a[i]) * tx;
                    let bot = e[i] + (f[i] - e[i]) * tx;
                    c[i] = top + (bot - top) * ty;
                }
                let gi = &guide[(y * w + x) * d..][..d];
                apply_model(&c, gi, o);
            }
        });
    out
}

/// The fast filter's coarse grid ([`coarse_grid`]): its guide (block means), its averaged
/// coefficients (and self-weight terms), its size and the sub-sampling factor.
struct Coarse<'a> {
    guide: &'a [f32],
    ab: &'a [f32],
    w: usize,
    h: usize,
    s: usize,
}

/// [`apply_upsampled`] for coefficients followed by the self-weight terms (from the stream
/// with `SW`), which are interpolated with them: returns the image and each pixel's
/// self-weight. The pixel's value enters its block's mean with weight 1 / the block's pixel
/// count (s², fewer in a partial block at the right or bottom edge), and the block's input
/// moves the interpolated model by [`cross_weight_lanes`] of the pixel's guide and the block's
/// (the windows around the interpolation's nodes taken as those around the block).
fn apply_upsampled_weighted(
    guide: &[f32],
    w: usize,
    h: usize,
    d: usize,
    coarse: &Coarse,
) -> (Image, Vec<f32>) {
    let Coarse {
        guide: gl,
        ab,
        w: lw,
        h: lh,
        s,
    } = *coarse;
    let k0 = 3 * d + 3;
    let k2 = k0 + terms(d);
    let mut out = zeroed_image(w, h, 3);
    let mut weights = zeroed(w * h);
    out.data
        .par_chunks_mut(3 * w)
        .zip(weights.par_chunks_mut(w))
        .enumerate()
        .for_each_init(
            || vec![0.0f32; lw * k2],
            |between, (y, (row, wrow))| {
                // The two coarse rows around this one, interpolated in y once for the row.
                let (y0, y1, ty) = lerp_at(y, s, lh);
                let (r0, r1) = (
                    &ab[y0 * lw * k2..][..lw * k2],
                    &ab[y1 * lw * k2..][..lw * k2],
                );
                for ((b, &a0), &a1) in between.iter_mut().zip(r0).zip(r1) {
                    *b = a0 + (a1 - a0) * ty;
                }
                let rows = UpsampleRow {
                    guide: &guide[y * w * d..(y + 1) * w * d],
                    coarse_guide: &gl[(y / s) * lw * d..(y / s + 1) * lw * d],
                    between,
                    d,
                    s,
                    // Pixels of this row's blocks: s, or fewer in the last block row.
                    block_rows: s.min(h - (y / s) * s),
                };
                upsample_row_weighted(&rows, row, wrow)
            },
        );
    (out, weights)
}

/// One output row of [`apply_upsampled_weighted`]: its guide, its coarse row's guide, the
/// coarse coefficients and terms interpolated to its y, and the constants.
struct UpsampleRow<'a> {
    guide: &'a [f32],
    coarse_guide: &'a [f32],
    between: &'a [f32],
    d: usize,
    s: usize,
    block_rows: usize,
}

multiversion! {
    /// [`apply_upsampled_weighted`]'s row: the coefficients and terms interpolated in x, the
    /// filtered value and the self-weight of every pixel. Dispatches on the guide's dimension
    /// so that [`upsample_row_weighted_d`]'s loops have constant lengths (they unroll and
    /// vectorise; the same operations in the same order, so the same bits).
    fn upsample_row_weighted(r: &UpsampleRow, out: &mut [f32], weights: &mut [f32])
        as upsample_row_weighted_impl
    {
        match r.d {
            1 => upsample_row_weighted_d::<1>(r, out, weights),
            2 => upsample_row_weighted_d::<2>(r, out, weights),
            3 => upsample_row_weighted_d::<3>(r, out, weights),
            4 => upsample_row_weighted_d::<4>(r, out, weights),
            5 => upsample_row_weighted_d::<5>(r, out, weights),
            6 => upsample_row_weighted_d::<6>(r, out, weights),
            7 => upsample_row_weighted_d::<7>(r, out, weights),
            _ => upsample_row_weighted_d::<8>(r, out, weights),
        }
    }
}

/// [`upsample_row_weighted`] for a `D`-dimensional guide (`r.d == D`): pixels in groups of
/// [`LANES`], whose self-weights are formed side by side ([`cross_weight_lanes`]).
#[inline(always)]
fn upsample_row_weighted_d<const D: usize>(r: &UpsampleRow, out: &mut [f32], weights: &mut [f32]) {
    let (k0, k2) = (3 * D + 3, 3 * D + 3 + terms(D));
    let lw = r.between.len() / k2;
    let w = out.len() / 3;
    let mut c = [0.0f32; MAX_GUIDE_DIMS * 3 + 3 + terms(MAX_GUIDE_DIMS)];
    let c = &mut c[..k2];
    let (mut g, mut gb) = ([[0.0f64; LANES]; D], [[0.0f64; LANES]; D]);
    let mut t = [[0.0f64; LANES]; terms(MAX_GUIDE_DIMS)];
    let (mut block, mut wt) = ([1.0f32; LANES], [0.0f32; LANES]);
    for x0 in (0..w).step_by(LANES) {
        let n = (w - x0).min(LANES);
        for l in 0..n {
            let x = x0 + l;
            let (xa, xb, tx) = lerp_at(x, r.s, lw);
            let (a, b) = (&r.between[xa * k2..][..k2], &r.between[xb * k2..][..k2]);
            for i in 0..k2 {
                c[i] = a[i] + (b[i] - a[i]) * tx;
            }
            let gi: &[f32; D] = r.guide[x * D..][..D].try_into().expect("D values");
            apply_model(c, gi, &mut out[3 * x..3 * x + 3]);
            let gc = &r.coarse_guide[(x / r.s) * D..][..D];
            for i in 0..D {
                (g[i][l], gb[i][l]) = (gi[i] as f64, gc[i] as f64);
            }
            for (j, v) in c[k0..].iter().enumerate() {
                t[j][l] = *v as f64;
            }
            // The pixel's share of its block's mean (a partial block at the right or bottom
            // edge holds fewer pixels, `downsample`'s divisor).
            block[l] = (r.block_rows * r.s.min(w - (x / r.s) * r.s)) as f32;
        }
        cross_weight_lanes::<D>(&g, &gb, &t[..terms(D)], &mut wt);
        for l in 0..n {
            weights[x0 + l] = wt[l] / block[l];
        }
    }
}

/// Consumer of one row of averaged coefficients: (row, coefficients, output row, side row).
type EmitRow<'a> = dyn Fn(usize, &[f32], &mut [f32], &mut [f32]) + Sync + 'a;

/// [`stream`] monomorphised per guide dimension, so the d×d solve is unrolled.
fn stream_dims<const SW: bool>(
    d: usize,
    pb: &Problem,
    out: Plane,
    side: Plane,
    emit: &EmitRow<'_>,
) {
    match d {
        1 => stream::<1, SW, _>(pb, out, side, emit),
        2 => stream::<2, SW, _>(pb, out, side, emit),
        3 => stream::<3, SW, _>(pb, out, side, emit),
        4 => stream::<4, SW, _>(pb, out, side, emit),
        5 => stream::<5, SW, _>(pb, out, side, emit),
        6 => stream::<6, SW, _>(pb, out, side, emit),
        7 => stream::<7, SW, _>(pb, out, side, emit),
        _ => stream::<8, SW, _>(pb, out, side, emit),
    }
}

multiversion! {
    /// One output row: q_c = Σ_i ā_ci I_i + b̄_c from the row's averaged coefficients (`k2`
    /// values per pixel, the 3d + 3 coefficients first).
    fn apply_row(guide: &[f32], d: usize, k2: usize, ab: &[f32], row: &mut [f32]) as apply_row_impl {
        for (x, o) in row.chunks_exact_mut(3).enumerate() {
            let gi = &guide[x * d..(x + 1) * d];
            let c = &ab[x * k2..(x + 1) * k2];
            apply_model(c, gi, o);
        }
    }
}

/// One pixel's output of the local linear model: for each channel, its offset plus the
/// coefficients times the guide `g` (`c` holds 3·d coefficients, then the 3 offsets; d =
/// `g.len()`). Every caller's sum in the same order, so the bits do not depend on which.
#[inline(always)]
fn apply_model(c: &[f32], g: &[f32], o: &mut [f32]) {
    let d = g.len();
    for ch in 0..3 {
        let mut q = c[3 * d + ch];
        for i in 0..d {
            q += c[ch * d + i] * g[i];
        }
        o[ch] = q;
    }
}
