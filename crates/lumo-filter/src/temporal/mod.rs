//! Spatiotemporal variance-guided filtering (SVGF; Schied et al. 2017): a stateful filter that
//! reprojects the previous frame's history with per-pixel motion vectors, accumulates
//! demodulated colour and the first two luminance moments with an exponential moving average,
//! estimates the per-pixel variance temporally (spatially while the history is short) and then
//! runs the variance-guided À-Trous of [`crate::atrous()`], feeding its first level back as the
//! next frame's colour history.
//!
//! The filter is pure except for its own history: the same sequence of frames gives the same
//! images, bit for bit, on any number of threads. See docs/filters.md ("Temporal filter").

mod gradient;
mod motion;
mod reproject;
mod reshade;
mod taa;
#[cfg(test)]
mod tests;

use lumo_image::Image;
use rayon::prelude::*;

pub use motion::{
    motion_vectors, object_motion, object_motion_vectors, pinhole_view_projection,
    project_to_pixel, surface_motion_vectors, NO_OBJECT,
};
pub use reshade::ShadingChange;
pub use taa::{TemporalAntialias, DEFAULT_TAA_ALPHA, DEFAULT_TAA_GAMMA};

use crate::atrous::{AtrousFilter, AtrousParams};
use crate::common::albedo::{albedo_divisor, surface_albedo};
use crate::common::error::param;
use crate::common::gbuffer::{check_color, check_size, missing_pixels, Features, Filtered};
use crate::common::passthrough::passed;
use crate::denoiser::{require, Denoiser, FilterInput, FilterKind};
use crate::FilterError;
use reproject::{History, Prev, Sample};

/// SVGF's temporal colour weight: the new frame's share once the history is long.
pub const DEFAULT_ALPHA: f32 = 0.2;
/// SVGF's variance-guided σ_l (with a temporal variance estimate; the spatial-only À-Trous
/// default is [`crate::DEFAULT_SIGMA_LUMINANCE`]).
pub const DEFAULT_TEMPORAL_SIGMA_LUMINANCE: f32 = 4.0;

/// Parameters of [`TemporalFilter`].
#[derive(Clone, Debug, PartialEq)]
pub struct TemporalParams {
    /// Exponential moving average weight of the new colour sample (SVGF: 0.2); while the
    /// history is short the weight is max(α, 1/n), n the history length including this frame
    /// (a plain mean of the first 1/α frames).
    pub alpha: f32,
    /// The same for the two luminance moments (SVGF: 0.2).
    pub alpha_moments: f32,
    /// History length cap (frames).
    pub max_history: u32,
    /// Below this history length the variance is estimated spatially (SVGF: 4): mean moments
    /// over a (2r+1)² window of consistent pixels, scaled by `variance_history / n`.
    pub variance_history: u32,
    /// Radius r of the spatial variance window (SVGF: 3, a 7×7 window).
    pub spatial_radius: usize,
    /// Reprojection: a history tap is rejected when |depth_prev − depth| > this × depth.
    pub depth_tolerance: f32,
    /// Reprojection: a history tap is rejected when dot(normal_prev, normal) < this.
    pub normal_min_dot: f32,
    /// Keep the first À-Trous level as the colour history (SVGF) rather than the accumulated,
    /// spatially unfiltered colour. SVGF's choice converges faster but compounds that level's
    /// blur frame after frame (a steady state of Σ α(1−α)^k K^(k+1)); see docs/filters.md.
    pub filtered_history: bool,
    /// History rejection where the lighting changed (A-SVGF-like, see docs/filters.md): radius
    /// r of the (2r+1)² window whose mean sample luminance is compared with the reprojected
    /// history's; 0 switches the rejection off.
    pub gradient_radius: usize,
    /// The part of that difference within this many standard errors of the samples' mean is
    /// taken for noise.
    pub gradient_sigmas: f32,
    /// λ = gain × (difference beyond the noise) / the larger mean, clamped to [0, 1]; the new
    /// sample's weight becomes (1 − λ)·α + λ.
    pub gradient_gain: f32,
    /// With re-shaded samples ([`TemporalFilter::filter_reshaded`]) the rejection is instead
    /// λ = this × |Σ (now − before)| / Σ max(now, before) over a (2r+1)² window of radius
    /// [`Self::reshade_radius`], clamped to [0, 1] (A-SVGF's normalised temporal gradient; see
    /// `temporal/reshade.rs`).
    pub reshade_gain: f32,
    /// See [`Self::reshade_gain`]; 0 switches the re-shaded rejection off.
    pub reshade_radius: usize,
    /// With re-shaded samples, also scale the reprojected history by how much the lighting of
    /// the window changed (ρ = Σ now / Σ before, within [1/4, 4]): the part of the history that
    /// λ keeps then follows a moving light instead of lagging behind it.
    pub reshade_rescale: bool,
    /// How the colour history is read at pixel + motion: bilinearly (SVGF), or by Catmull-Rom
    /// where all 4×4 taps are valid (bilinear elsewhere). Bilinear reads blur a little every
    /// frame under motion (a shift by a fraction f averages with weight f(1 − f)), and the
    /// history keeps that blur; Catmull-Rom keeps the history sharp.
    pub resample: Resample,
    /// Neighbourhood clamp of the reprojected history (0 = off): its luminance is clamped to
    /// the mean ± this many standard deviations of this frame's samples over the rejection
    /// window ([`Self::gradient_radius`], needed > 0), the colour scaled with it.
    pub clamp_sigmas: f32,
    /// À-Trous levels for pixels with a short history (0 = off): where the history length n is
    /// below [`Self::short_history_frames`] + 1, the output blends towards an À-Trous of this
    /// many levels (weight 1 − (n − 1) / frames), e.g. more levels right after a disocclusion
    /// or a rejection, where the 1-spp sample is alone. Costs a second À-Trous.
    pub short_history_levels: usize,
    /// See [`Self::short_history_levels`].
    pub short_history_frames: u32,
    /// Steer the À-Trous with the variance of the accumulated colour rather than of one
    /// sample (SVGF): the temporal estimate times max(1/n, α/(2 − α)), the share of a sample's
    /// variance left in a mean of n samples or in the moving average's steady state. The
    /// edge-stopping then tightens as the history grows (less blur where less noise is left).
    pub scale_variance: bool,
    /// The spatial filter. `demodulate` is ignored (the temporal filter demodulates itself);
    /// `use_variance` should stay on (the temporal variance steers the colour weight);
    /// `sigma_position` is dropped when a frame has no position plane; `sparse` must be 1.
    /// `iterations` 0 leaves the spatial stage out: the output is the accumulated colour
    /// (and no variance is estimated), for a signal whose history alone is smooth enough.
    pub atrous: AtrousParams,
}

impl Default for TemporalParams {
    fn default() -> Self {
        Self {
            alpha: DEFAULT_ALPHA,
            alpha_moments: DEFAULT_ALPHA,
            max_history: 32,
            variance_history: 4,
            spatial_radius: 3,
            depth_tolerance: 0.1,
            normal_min_dot: 0.9,
            filtered_history: true,
            gradient_radius: 4,
            gradient_sigmas: 2.0,
            gradient_gain: 10.0,
            reshade_gain: 1.0,
            reshade_radius: 4,
            reshade_rescale: false,
            resample: Resample::Bilinear,
            clamp_sigmas: 0.0,
            short_history_levels: 0,
            short_history_frames: 4,
            scale_variance: false,
            atrous: AtrousParams {
                iterations: 5,
                sigma_luminance: Some(DEFAULT_TEMPORAL_SIGMA_LUMINANCE),
                use_variance: true,
                ..AtrousParams::default()
            },
        }
    }
}

impl TemporalParams {
    /// The settings tuned for 1-spp frame sequences under camera and object motion (`lumo
    /// render --frames --temporal` and `lumo serve`'s filtered frames): SVGF's reprojection
    /// with a longer history (α = 0.05, up to 128 frames), the accumulated rather than the
    /// filtered colour as history, history rejection where the lighting changes (windowed test:
    /// radius 6, 2 standard errors, gain 10; from re-shaded samples: radius 4, gain 3, the
    /// kept history rescaled), the À-Trous steered by the variance left in the accumulated
    /// colour, 2 levels. Chosen on tuning sequences only (docs/results/temporal.md).
    pub fn sequence() -> Self {
        let mut p = Self {
            alpha: 0.05,
            alpha_moments: 0.05,
            max_history: 128,
            filtered_history: false,
            gradient_radius: 6,
            gradient_sigmas: 2.0,
            gradient_gain: 10.0,
            reshade_gain: 3.0,
            reshade_radius: 4,
            reshade_rescale: true,
            scale_variance: true,
            ..Self::default()
        };
        p.atrous.iterations = 2;
        p
    }
}

/// How [`TemporalFilter`] reads the history between pixels ([`TemporalParams::resample`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Resample {
    /// Bilinear over the valid 2×2 taps (SVGF).
    #[default]
    Bilinear,
    /// Catmull-Rom over 4×4 taps where all are valid, clamped to the central 2×2 taps' range.
    CatmullRom,
}

/// One frame's input planes. All have the colour image's size.
#[derive(Clone, Copy, Debug)]
pub struct TemporalFrame<'a> {
    /// Noisy colour, 3 channels. Non-finite pixels are *missing* (see [`TemporalFilter`]).
    pub color: &'a Image,
    /// Albedo (1 or 3 channels): colour is divided by it before accumulation and multiplied
    /// back after filtering; pixels without a usable albedo (below [`crate::ALBEDO_EPS`] in
    /// every channel, or not finite: lights, sky, black surfaces) are passed through
    /// unfiltered and keep no history. `None`: colour is filtered as it is.
    pub albedo: Option<&'a Image>,
    /// World-space unit normals (3 channels).
    pub normal: &'a Image,
    /// Camera distance (1 channel, or more: the first is used); 0 or not finite = background.
    pub depth: &'a Image,
    /// World-space positions (3 channels), for the À-Trous position weight; optional.
    pub position: Option<&'a Image>,
    /// Object / instance id per pixel (row-major, `width·height` values); history taps with a
    /// different id are rejected. Optional (both frames need one for the test to apply).
    pub ids: Option<&'a [u32]>,
    /// Motion vectors (2 channels, or more: the first two are used): for each pixel, where its
    /// surface was in the previous frame, in pixels, relative to this pixel (previous position
    /// = pixel + motion; x right, y down). Non-finite = no history. `None`: no motion.
    pub motion: Option<&'a Image>,
}

/// SVGF as a stateful filter: feed it frame after frame (see [`TemporalFilter::filter`]).
///
/// Per pixel and frame: the previous frame's history is read bilinearly at pixel + motion; each
/// of the 2×2 taps counts only if it lies in the image, has history, and matches the current
/// surface (relative depth difference ≤ `depth_tolerance`, normal dot ≥ `normal_min_dot`, equal
/// id when both frames have ids, background only with background); the valid taps' weights are
/// renormalised (rejected when they sum to < 0.01). The history length n (that of the valid
/// tap with the largest weight, + 1, at most `max_history`; 1 without history) sets the blend
/// weight max(α, 1/n) of colour / albedo and of the luminance moments (l, l²). The variance is
/// l² − l·l from the moments once n ≥ `variance_history`, else from the moments' mean over a
/// 7×7 window of consistent pixels (scaled by `variance_history / n`). The À-Trous then filters
/// the accumulated colour, steered by that variance; its first level's output becomes the
/// colour history, the accumulated moments the moments history.
///
/// Inputs are sanitised: a pixel whose colour (or colour / albedo) is not finite is *missing*:
/// with history it keeps the reprojected history unchanged (its length not incremented),
/// without it gets weight 0 in the À-Trous (filled from its neighbours) and keeps no history.
/// Non-finite normals reject history, non-finite depth is background, non-finite motion means
/// no history. Outputs and history are always finite. A frame of another size resets the
/// history first.
#[derive(Debug)]
pub struct TemporalFilter {
    params: TemporalParams,
    history: Option<History>,
    atrous: AtrousFilter,
    /// The last frame's per-pixel results (see the accessors).
    reprojected: Image,
    variance: Image,
    /// Working buffers, reused between frames.
    samples: Vec<Sample>,
    prev: Vec<Option<Prev>>,
    sums: Vec<gradient::Sums>,
    reshade_sums: Vec<[f32; 4]>,
    reshade_scale: Vec<f32>,
    lambda: Vec<f32>,
    bounds: Vec<[f32; 2]>,
    acc: Vec<reproject::Accumulated>,
    integrated: Image,
}

impl TemporalFilter {
    /// A filter with no history. Errors on parameters out of range.
    pub fn new(params: TemporalParams) -> Result<Self, FilterError> {
        validate_params(&params)?;
        Ok(Self {
            params,
            history: None,
            atrous: AtrousFilter::new(),
            reprojected: Image::new(0, 0, 3, 0.0),
            variance: Image::new(0, 0, 1, 0.0),
            samples: vec![],
            prev: vec![],
            sums: vec![],
            reshade_sums: vec![],
            reshade_scale: vec![],
            lambda: vec![],
            bounds: vec![],
            acc: vec![],
            integrated: Image::new(0, 0, 3, 0.0),
        })
    }

    /// The parameters.
    pub fn params(&self) -> &TemporalParams {
        &self.params
    }

    /// Forgets the history (a camera cut, a scene change): the next frame starts afresh.
    pub fn reset(&mut self) {
        self.history = None;
    }

    /// Size of the history (`None` after [`Self::reset`] or before the first frame).
    pub fn history_size(&self) -> Option<(usize, usize)> {
        self.history.as_ref().map(|h| (h.w, h.h))
    }

    /// Per-pixel history length after the last frame (row-major): 0 where the pixel keeps no
    /// history (passed through, or missing with nothing to reproject), 1 for a fresh start.
    pub fn history_length(&self) -> &[u32] {
        self.history.as_ref().map_or(&[], |h| &h.len)
    }

    /// The colour history after the last frame (colour / albedo, first À-Trous level).
    pub fn history_color(&self) -> Option<&Image> {
        self.history.as_ref().map(|h| &h.color)
    }

    /// The last frame's reprojected colour history (colour / albedo, before blending), NaN
    /// where there was none.
    pub fn reprojected_history(&self) -> &Image {
        &self.reprojected
    }

    /// The last frame's history rejection λ per pixel (row-major, 0 = history kept as it is,
    /// 1 = dropped), see [`TemporalParams::gradient_radius`].
    pub fn rejection(&self) -> &[f32] {
        &self.lambda
    }

    /// The last frame's luminance variance estimate of colour / albedo (1 channel).
    pub fn variance(&self) -> &Image {
        &self.variance
    }

    /// Filters one frame and updates the history. Returns the filtered colour (3 channels,
    /// finite) and the number of non-finite input colour pixels.
    pub fn filter(&mut self, frame: &TemporalFrame) -> Result<Filtered, FilterError> {
        self.filter_reshaded(frame, None)
    }

    /// [`Self::filter`] with the history rejection taken from re-shaded samples (`Some`,
    /// see [`ShadingChange`]) instead of the windowed statistical test (`None`). With `Some`,
    /// pixels whose window holds no sample keep their history; the neighbourhood clamp
    /// ([`TemporalParams::clamp_sigmas`]) still uses the windowed statistics.
    pub fn filter_reshaded(
        &mut self,
        frame: &TemporalFrame,
        changes: Option<&[ShadingChange]>,
    ) -> Result<Filtered, FilterError> {
        validate_frame(frame)?;
        // Background pixels pass through whatever their sample-averaged albedo, as in every
        // demodulating filter (`surface_albedo`).
        let features = Features {
            albedo: frame.albedo,
            depth: Some(frame.depth),
            position: frame.position,
            ..Features::default()
        };
        let albedo = surface_albedo(&features);
        let frame = &TemporalFrame {
            albedo: albedo.as_deref(),
            ..*frame
        };
        if let Some(c) = changes {
            reshade::validate(c, frame.color.width, frame.color.height)?;
        }
        self.size_buffers(frame.color.width, frame.color.height);
        self.read_samples(frame);
        self.accumulate(frame, changes);
        let (filtered, first) = if self.params.atrous.iterations == 0 {
            self.accumulated_only()
        } else {
            self.estimate_variance(frame.color.width, frame.color.height);
            self.filter_spatially(frame)?
        };
        let image = self.remodulate(filtered, frame);
        self.update_history(frame, first);
        Ok(Filtered {
            image,
            missing: missing_pixels(frame.color),
        })
    }

    /// Sizes the working buffers for a `w`×`h` frame, dropping a history of another size.
    /// They are kept between frames (allocating and page-faulting ~30 MB per 512² frame cost
    /// as much as the reprojection itself); every element is overwritten.
    fn size_buffers(&mut self, w: usize, h: usize) {
        if self
            .history
            .as_ref()
            .is_some_and(|hi| hi.w != w || hi.h != h)
        {
            self.reset();
        }
        let n = w * h;
        self.samples.resize(n, Sample::default());
        self.acc.resize(n, reproject::Accumulated::default());
        self.prev.resize(n, None);
        for (img, c) in [
            (&mut self.variance, 1),
            (&mut self.integrated, 3),
            (&mut self.reprojected, 3),
        ] {
            if (img.width, img.height, img.channels) != (w, h, c) {
                *img = Image::new(w, h, c, 0.0);
            }
        }
    }

    /// Step 1: this frame's samples: demodulated colour, surface, luminance moments.
    fn read_samples(&mut self, frame: &TemporalFrame) {
        let w = frame.color.width;
        self.samples
            .par_chunks_mut(w)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, s) in row.iter_mut().enumerate() {
                    *s = Sample::read(frame, y * w + x);
                }
            });
    }

    /// Step 2: reprojection, history rejection where the lighting changed (by re-shaded
    /// samples where there are `changes`, else by the windowed test), accumulation.
    fn accumulate(&mut self, frame: &TemporalFrame, changes: Option<&[ShadingChange]>) {
        let (w, h) = (frame.color.width, frame.color.height);
        let p = &self.params;
        let samples = &self.samples[..];
        let hist = self.history.as_ref();
        self.prev
            .par_chunks_mut(w)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, pr) in row.iter_mut().enumerate() {
                    *pr = reproject::reproject_pixel(p, hist, frame, samples, x, y);
                }
            });
        let prev = &self.prev[..];
        // Re-shaded samples replace the windowed test's λ; its window statistics are then
        // needed only for the neighbourhood clamp.
        if changes.is_none() || p.clamp_sigmas > 0.0 {
            gradient::rejection(
                p,
                samples,
                prev,
                w,
                h,
                &mut self.sums,
                &mut self.lambda,
                &mut self.bounds,
            );
        } else {
            self.bounds.clear();
        }
        if let Some(c) = changes {
            reshade::rejection(
                p,
                c,
                w,
                h,
                &mut self.reshade_sums,
                &mut self.lambda,
                &mut self.reshade_scale,
            );
        } else {
            self.reshade_scale.clear();
        }
        let lambda = &self.lambda[..];
        let scale = &self.reshade_scale[..];
        let bounds = &self.bounds[..];
        self.acc.par_iter_mut().enumerate().for_each(|(i, a)| {
            let pr = prev[i].map(|pr| {
                let pr = reproject::rescale_history(pr, scale.get(i).copied());
                reproject::clamp_history(pr, bounds.get(i).copied())
            });
            *a = reproject::blend(p, &samples[i], pr, lambda[i]);
        });
    }

    /// Step 3: the variance, temporal from the moments, spatial while the history is short.
    fn estimate_variance(&mut self, w: usize, h: usize) {
        let (p, samples, acc) = (&self.params, &self.samples[..], &self.acc[..]);
        self.variance
            .data
            .par_chunks_mut(w)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, v) in row.iter_mut().enumerate() {
                    *v = reproject::variance(p, samples, acc, w, h, x, y);
                }
            });
    }

    /// Step 4: the variance-guided À-Trous on the accumulated colour / albedo, blended towards
    /// a shallower one where the history is short; pixels with nothing to show (passed
    /// through, or missing without history) are NaN: weight 0. Returns the filtered colour
    /// and the first level.
    fn filter_spatially(
        &mut self,
        frame: &TemporalFrame,
    ) -> Result<(Filtered, Image), FilterError> {
        let w = frame.color.width;
        let (p, acc) = (&self.params, &self.acc[..]);
        let integrated = &mut self.integrated;
        integrated
            .data
            .par_chunks_mut(3 * w)
            .zip(self.reprojected.data.par_chunks_mut(3 * w))
            .enumerate()
            .for_each(|(y, (ir, rr))| {
                for x in 0..w {
                    let a = &acc[y * w + x];
                    let c = if a.len > 0 { a.color } else { [f32::NAN; 3] };
                    ir[3 * x..3 * x + 3].copy_from_slice(&c);
                    let hc = a.history.unwrap_or([f32::NAN; 3]);
                    rr[3 * x..3 * x + 3].copy_from_slice(&hc);
                }
            });
        let mut ap = p.atrous.clone();
        ap.demodulate = false;
        if frame.position.is_none() {
            ap.sigma_position = None;
        }
        let features = Features {
            normal: Some(frame.normal),
            position: frame.position,
            depth: Some(frame.depth),
            albedo: None,
            variance: Some(&self.variance),
        };
        let (mut filtered, first) = self
            .atrous
            .filter_keeping_first_level(integrated, &features, &ap)?;
        if p.short_history_levels > 0 && p.short_history_levels != ap.iterations {
            let sp = AtrousParams {
                iterations: p.short_history_levels,
                ..ap.clone()
            };
            let short = self.atrous.filter(integrated, &features, &sp)?.image;
            let frames = p.short_history_frames.max(1) as f32;
            filtered
                .image
                .data
                .par_chunks_mut(3)
                .zip(short.data.par_chunks(3))
                .enumerate()
                .for_each(|(i, (o, s))| {
                    let t = short_weight(acc[i].len, frames);
                    if t > 0.0 {
                        for k in 0..3 {
                            o[k] += t * (s[k] - o[k]);
                        }
                    }
                });
        }
        Ok((filtered, first))
    }

    /// Step 4 without a spatial stage (`atrous.iterations` 0): the accumulated colour, NaN
    /// where there is nothing to show (as the À-Trous output's missing pixels; remodulation
    /// sanitises them), and it again as the "first level" for a filtered history. The
    /// reprojected history is kept for [`Self::reprojected_history`] as with levels.
    fn accumulated_only(&mut self) -> (Filtered, Image) {
        let acc = &self.acc[..];
        self.integrated
            .data
            .par_chunks_mut(3)
            .zip(self.reprojected.data.par_chunks_mut(3))
            .zip(acc.par_iter())
            .for_each(|((o, r), a)| {
                let c = if a.len > 0 { a.color } else { [f32::NAN; 3] };
                o.copy_from_slice(&c);
                r.copy_from_slice(&a.history.unwrap_or([f32::NAN; 3]));
            });
        // `integrated` stays for the history (taken by a swap); the output is a copy.
        let image = self.integrated.clone();
        let first = if self.params.filtered_history {
            image.clone()
        } else {
            Image::new(0, 0, 3, 0.0)
        };
        (Filtered { image, missing: 0 }, first)
    }

    /// Step 5: remodulation; pass-through pixels get their own colour.
    fn remodulate(&self, filtered: Filtered, frame: &TemporalFrame) -> Image {
        let w = frame.color.width;
        let samples = &self.samples[..];
        let mut image = filtered.image;
        image
            .data
            .par_chunks_mut(3 * w)
            .enumerate()
            .for_each(|(y, row)| {
                for x in 0..w {
                    let i = y * w + x;
                    let o = &mut row[3 * x..3 * x + 3];
                    match samples[i].divisor {
                        Some(d) => {
                            for k in 0..3 {
                                o[k] = sanitize(o[k] * d[k]);
                            }
                        }
                        None => {
                            for k in 0..3 {
                                o[k] = passed(frame.color.data[3 * i + k]);
                            }
                        }
                    }
                }
            });
        image
    }

    /// Step 6: the new history (the accumulated colour, or the first À-Trous level `first`
    /// with [`TemporalParams::filtered_history`]), written over the old history's vectors (it
    /// has been read).
    fn update_history(&mut self, frame: &TemporalFrame, first: Image) {
        let (w, h) = (frame.color.width, frame.color.height);
        let mut hist = self.history.take().unwrap_or(History {
            w,
            h,
            color: Image::new(0, 0, 3, 0.0),
            moments: vec![],
            len: vec![],
            surface: vec![],
            ids: None,
        });
        if self.params.filtered_history {
            hist.color = first;
        } else {
            // The accumulated colour becomes the history by a swap, not a copy; the old
            // history's buffer (or an empty one) is the next frame's, which overwrites it whole.
            std::mem::swap(&mut hist.color, &mut self.integrated);
        }
        for v in &mut hist.color.data {
            *v = sanitize(*v);
        }
        let acc = &self.acc;
        hist.moments.clear();
        hist.moments.extend(acc.iter().map(|a| a.moments));
        hist.len.clear();
        hist.len.extend(acc.iter().map(|a| a.len));
        hist.surface.clear();
        hist.surface.extend(self.samples.iter().map(|s| s.surface));
        match frame.ids {
            Some(ids) => {
                let v = hist.ids.get_or_insert_with(Vec::new);
                v.clear();
                v.extend_from_slice(ids);
            }
            None => hist.ids = None,
        }
        self.history = Some(hist);
    }
}

/// The weight of the short-history À-Trous for history length `len` (0: no sample):
/// 1 − (len − 1) / frames, clamped to [0, 1].
fn short_weight(len: u32, frames: f32) -> f32 {
    if len == 0 {
        return 0.0;
    }
    (1.0 - (len - 1) as f32 / frames).clamp(0.0, 1.0)
}

/// `v`, or 0 where it is not finite.
#[inline]
fn sanitize(v: f32) -> f32 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

fn validate_params(p: &TemporalParams) -> Result<(), FilterError> {
    for (name, v) in [("alpha", p.alpha), ("alpha_moments", p.alpha_moments)] {
        if !(v > 0.0 && v <= 1.0) {
            return Err(param(name, format!("{v} (use 0 < α ≤ 1)")));
        }
    }
    if p.max_history == 0 {
        return Err(param("max_history", "0 (use ≥ 1)"));
    }
    for (name, r) in [
        ("gradient_radius", p.gradient_radius),
        ("reshade_radius", p.reshade_radius),
    ] {
        if r > 16 {
            return Err(param(name, format!("{r} (use 0..=16)")));
        }
    }
    for (name, v) in [
        ("gradient_sigmas", p.gradient_sigmas),
        ("gradient_gain", p.gradient_gain),
        ("reshade_gain", p.reshade_gain),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(param(name, format!("{v} (use a finite value ≥ 0)")));
        }
    }
    if !(p.clamp_sigmas.is_finite() && p.clamp_sigmas >= 0.0) {
        return Err(param(
            "clamp_sigmas",
            format!("{} (use a finite value ≥ 0)", p.clamp_sigmas),
        ));
    }
    if p.short_history_levels > 16 {
        return Err(param(
            "short_history_levels",
            format!("{} (use 0..=16)", p.short_history_levels),
        ));
    }
    if p.spatial_radius > 16 {
        return Err(param(
            "spatial_radius",
            format!("{} (use 0..=16)", p.spatial_radius),
        ));
    }
    if !(p.depth_tolerance > 0.0) {
        return Err(param(
            "depth_tolerance",
            format!("{} (must be > 0)", p.depth_tolerance),
        ));
    }
    if !(p.normal_min_dot <= 1.0) {
        return Err(param(
            "normal_min_dot",
            format!("{} (use ≤ 1)", p.normal_min_dot),
        ));
    }
    if p.atrous.sparse != 1 {
        return Err(param(
            "atrous.sparse",
            "the temporal filter needs sparse = 1",
        ));
    }
    Ok(())
}

fn validate_frame(f: &TemporalFrame) -> Result<(), FilterError> {
    check_color("color", f.color)?;
    let (w, h) = (f.color.width, f.color.height);
    let chan = |name: &'static str, img: &Image, min: usize, expected: &'static str| {
        check_size(name, img, "color", w, h)?;
        if img.channels < min || img.data.len() != w * h * img.channels {
            return Err(FilterError::Channels {
                name,
                got: img.channels,
                expected,
            });
        }
        Ok(())
    };
    chan("normal", f.normal, 3, "3 (x, y, z)")?;
    chan("depth", f.depth, 1, "1")?;
    if let Some(a) = f.albedo {
        chan("albedo", a, 1, "1 or 3")?;
        if a.channels == 2 {
            return Err(FilterError::Channels {
                name: "albedo",
                got: 2,
                expected: "1 or 3",
            });
        }
    }
    if let Some(p) = f.position {
        chan("position", p, 3, "3 (x, y, z)")?;
    }
    if let Some(m) = f.motion {
        chan("motion", m, 2, "2 (dx, dy)")?;
    }
    if let Some(ids) = f.ids {
        if ids.len() != w * h {
            return Err(param(
                "ids",
                format!("{} values for a {w}x{h} image", ids.len()),
            ));
        }
    }
    Ok(())
}

/// The albedo divisor of pixel `i` (`None`: passed through), [1; 3] without an albedo.
fn divisor(albedo: Option<&Image>, i: usize) -> Option<[f32; 3]> {
    match albedo {
        Some(a) => albedo_divisor(a, i),
        None => Some([1.0; 3]),
    }
}

/// The temporal filter is a [`Denoiser`] itself: its state (the history) is what `&mut self`
/// is for. A frame's input: colour, normal and depth (needed), albedo and position (used if
/// given), motion vectors and ids ([`FilterInput::motion`], [`FilterInput::ids`]).
impl Denoiser for TemporalFilter {
    fn name(&self) -> &'static str {
        FilterKind::Temporal.name()
    }

    /// [`TemporalFilter::filter`] of the input as one [`TemporalFrame`].
    fn denoise(&mut self, input: &FilterInput) -> Result<Filtered, FilterError> {
        let f = &input.features;
        let frame = TemporalFrame {
            color: input.color,
            albedo: f.albedo,
            normal: require(f.normal, "the temporal filter", "a normal plane")?,
            depth: require(f.depth, "the temporal filter", "a depth plane")?,
            position: f.position,
            ids: input.ids,
            motion: input.motion,
        };
        self.filter(&frame)
    }

    /// [`TemporalFilter::reset`].
    fn reset(&mut self) {
        TemporalFilter::reset(self);
    }
}
