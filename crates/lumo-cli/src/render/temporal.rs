//! `lumo render --frames … --temporal`: each traced frame goes through lumo-filter's temporal
//! filter (SVGF) instead of a per-frame pipeline, its history reprojected with the motion of
//! the camera and of the scene's instances.
//!
//! Motion vectors: a pixel's first-hit point (the frame's position plane, traced through the
//! pixel centre) is carried back to where it was on the previous frame — through the inverse of
//! its instance's transform now and that transform then, when instances move — and projected
//! with the previous camera. The instance under each pixel centre is found by one ray per
//! pixel, only when the scene animates (a camera orbit needs none); the same ids also reject
//! history that belonged to another object. On a mesh that deforms (a skin, morph targets) the
//! point is instead found again by its triangle and barycentric coordinates in the previous
//! frame's vertex positions (`lumo_render::deformation_back`).

use std::time::Duration;

use glam::Mat4;
use lumo_filter::{
    object_motion, object_motion_vectors, pinhole_view_projection, surface_motion_vectors,
    with_emitted, FilterError, Resample, TemporalAntialias, TemporalFilter, TemporalFrame,
    TemporalParams,
};
use lumo_image::Image;
use lumo_render::accel::Hit;
use lumo_render::camera::PinholeCamera;
use lumo_render::{
    camera_hits_into, deformation_back, direct_split_at, DirectSplit, Frame, MeshPoses,
    PathSettings, PixelHit, RenderScene,
};
use lumo_scene::Camera;
use rayon::prelude::*;

use super::reshade::{reshade, Pose, ShadedFrame};
use super::stage_clock::Mark;

/// What the previous frame looked like, for its motion vectors.
struct View {
    view_proj: Mat4,
    /// The frame's sub-pixel jitter (pixels).
    jitter: [f32; 2],
    /// Instance transforms (object → world).
    transforms: Vec<Mat4>,
    /// The instance under each pixel centre, when instances move.
    ids: Option<Vec<u32>>,
    /// The deforming meshes' vertex positions and the instance transforms, when meshes deform.
    poses: Option<MeshPoses>,
    /// The triangle and barycentrics under each pixel centre, when meshes deform (re-shading
    /// carries the previous frame's points on them forward by these).
    hits: Option<Vec<PixelHit>>,
    /// The traced frame, for re-shading (when on).
    shaded: Option<ShadedFrame>,
}

/// Time spent on one frame's temporal filtering, on the stage clock (wall time, or CPU time
/// with `LUMO_STAGE_CLOCK=cpu`: `super::stage_clock`).
#[derive(Clone, Copy, Debug, Default)]
pub struct TemporalTimes {
    /// The whole of [`TemporalSequence::filter`] (wall clock: less than the sum of the stages
    /// below when stages run side by side (see there), and it includes the small steps no stage
    /// counts (the emitter mask, the indirect-only colour, TAA)).
    pub total: Duration,
    /// Motion vectors (and the instance ids, taken from the split's camera hits when the
    /// split is on).
    pub motion: Duration,
    /// Re-shading one point per 3×3 block of the previous frame (history rejection).
    pub reshade: Duration,
    /// The direct-light split: its rays (the camera ray per pixel, which the instance ids
    /// share, one shadow ray per Dirac light and one light sample per pixel) and the temporal
    /// filter of its shadow ratio.
    pub split: Duration,
    /// The part of `split` spent on the shadow ratio's temporal filter and on adding the
    /// split light back (the rest is the split's rays and shading).
    pub split_filter: Duration,
    /// The filter itself (reprojection, accumulation, variance, À-Trous).
    pub filter: Duration,
}

/// The temporal filter of one sequence with its memory of the previous frame.
pub struct TemporalSequence {
    filter: TemporalFilter,
    /// Temporal anti-aliasing of the filtered image (with the lights), when on.
    taa: Option<TemporalAntialias>,
    prev: Option<View>,
    /// Jitter the camera by a sub-pixel offset every frame (see [`jitter`]).
    jitter: bool,
    /// Instances move (an animated scene): trace ids and follow each instance's motion.
    object_motion: bool,
    /// Meshes (indices into the scene's) that skins or morph targets deform: their points are
    /// followed by triangle and barycentrics ([`TemporalSequence::deforming`]).
    deforming: Vec<usize>,
    /// The path settings frames are traced with, when the history rejection re-shades
    /// samples of the previous frame (`super::reshade`); `None`: the windowed test.
    reshade: Option<PathSettings>,
    /// Re-shading carries points on deforming meshes by triangle and barycentrics (else by
    /// their instance's transform, as before; `rd=0` in the tuning hook, for comparison).
    reshade_deforming: bool,
    /// The temporal filter of the direct-light split's shadow ratio, when the split is on
    /// (see [`TemporalSequence::filter`]).
    ratio: Option<TemporalFilter>,
    /// Per-frame images kept between frames, so that a frame allocates (and page-faults) less.
    buffers: Buffers,
}

/// The sequence's per-frame working images (each frame overwrites them whole).
#[derive(Default)]
struct Buffers {
    /// The direct-light split.
    split: DirectSplit,
    /// The colour with the split direct light taken out ([`split_noisy`]).
    noisy: Option<Image>,
    /// The shadow ratio as the filter's colour ([`ratio_image`]).
    ratio: Option<Image>,
    /// Pixels that see an emitter directly.
    emitter: Vec<bool>,
    /// The first hit of every pixel centre's camera ray (when the split or the ids need it).
    hits: Vec<Option<Hit>>,
}

impl TemporalSequence {
    /// A sequence with SVGF's parameters; `object_motion` when the scene's instances move.
    /// With `reshade` (the path settings of frames traced at one sample per pixel) the history
    /// rejection re-traces a few of the previous frame's samples (A-SVGF), unless the tuning
    /// hook turns that off (`rs=0`); without, it uses the windowed statistical test.
    ///
    /// `split_direct` turns the direct-light split on (see [`TemporalSequence::filter`]),
    /// unless the tuning hook turns it off (`ds=0`); it computes RGB light, so frames traced
    /// with spectral transport go without it.
    pub fn new(
        object_motion: bool,
        reshade: Option<PathSettings>,
        split_direct: bool,
    ) -> Result<Self, FilterError> {
        let split_direct = split_direct && tuned("ds") != Some(0.0);
        let (params, taa) = sequence_params(split_direct);
        Ok(Self {
            filter: TemporalFilter::new(params)?,
            taa: match taa {
                Some((alpha, gamma)) => Some(TemporalAntialias::new(alpha, gamma)?),
                None => None,
            },
            prev: None,
            jitter: tuned("jit").is_some_and(|v| v != 0.0),
            object_motion,
            deforming: Vec::new(),
            reshade: reshade.filter(|_| tuned("rs") != Some(0.0)),
            reshade_deforming: tuned("rd") != Some(0.0),
            ratio: if split_direct {
                Some(TemporalFilter::new(ratio_params())?)
            } else {
                None
            },
            buffers: Buffers::default(),
        })
    }

    /// Follows the points of `meshes` (indices into the scene's meshes: those skins or morph
    /// targets deform) through their deformation, not only their instance's transform. Only
    /// with `object_motion` (an animated scene).
    pub fn deforming(mut self, meshes: Vec<usize>) -> Self {
        self.deforming = if self.object_motion {
            meshes
        } else {
            Vec::new()
        };
        self
    }

    /// The camera to trace frame number `i` of the sequence (counting from 0) with, and its
    /// jitter: `camera` turned by [`jitter`]`(i)` when jittering is on (as a real-time renderer
    /// jitters its projection for temporal anti-aliasing), else `camera` and no jitter.
    pub fn camera(&self, camera: &Camera, w: usize, h: usize, i: usize) -> (Camera, [f32; 2]) {
        if !self.jitter {
            return (camera.clone(), [0.0; 2]);
        }
        let j = jitter(i);
        (jittered_camera(camera, w, h, j), j)
    }

    /// Filters `frame`, traced from `rs` as it is posed now with a camera jittered by `jitter`
    /// pixels (see [`Self::camera`]) and random-number seed `seed`, one sample per pixel;
    /// returns the filtered image, which the TAA stage puts back on the unjittered pixel grid.
    ///
    /// With the direct-light split (the default; `lumo_render::direct_split`), pixels whose
    /// first hit has only broad lobes keep only their indirect light in the history: a moving
    /// light changes the direct light far more than the indirect, and the history rejection
    /// would throw the indirect light's history away with it. Their direct light is added back
    /// after filtering from this frame alone — Dirac lights exactly, the other lights as their
    /// unshadowed light times a shadow ratio that a second temporal filter accumulates, which
    /// changes only where shadows move.
    pub fn filter(
        &mut self,
        rs: &RenderScene,
        frame: &Frame,
        jitter: [f32; 2],
        seed: u32,
    ) -> Result<(Image, TemporalTimes), FilterError> {
        let (w, h) = (frame.width(), frame.height());
        let start = Mark::now();
        let c = &rs.scene.camera;
        let (hw, hh) = c.half_extent(w, h);
        let deforms = !self.deforming.is_empty();
        let camera = PinholeCamera::new(c, w, h);
        // One camera ray per pixel centre, in packets, shared by every pass that needs the
        // first hit: the split, the instance ids and the deforming meshes' triangles (each
        // traced its own before; the ids one ray at a time).
        let split_on = self.ratio.is_some();
        let hits = &mut self.buffers.hits;
        let hits_time = if split_on || self.object_motion {
            let t = Mark::now();
            camera_hits_into(hits, rs, &camera, w, h);
            t.elapsed()
        } else {
            hits.clear();
            Duration::ZERO
        };
        let hits = &self.buffers.hits[..];
        // Deforming meshes need each pixel's triangle and barycentrics; otherwise the
        // instance is enough.
        let pixel_hits: Option<Vec<PixelHit>> =
            deforms.then(|| hits.iter().map(PixelHit::from).collect());
        let ids = self.object_motion.then(|| {
            hits.iter()
                .map(|h| h.map_or(PixelHit::NONE.instance, |h| h.instance))
                .collect()
        });
        let mut view = View {
            view_proj: pinhole_view_projection(c.origin, c.target, c.up, [hw, hh]),
            jitter,
            transforms: rs.scene.instances.iter().map(|i| i.transform).collect(),
            ids,
            poses: deforms.then(|| MeshPoses::capture(&rs.scene, &self.deforming)),
            hits: None,
            shaded: None,
        };
        let ids = view.ids.as_deref();
        let motion = self.prev.as_ref().map(|prev| {
            let back = object_motion(&prev.transforms, &view.transforms);
            let ids = ids.unwrap_or_default();
            match (&pixel_hits, &prev.poses) {
                (Some(hits), Some(then)) => surface_motion_vectors(
                    &prev.view_proj,
                    &view.view_proj,
                    &frame.position,
                    ids,
                    &back,
                    &deformation_back(&rs.scene, hits, then),
                ),
                _ => object_motion_vectors(
                    &prev.view_proj,
                    &view.view_proj,
                    &frame.position,
                    ids,
                    &back,
                ),
            }
        });
        // With the split on, the camera hits count as its stage (they replace its camera rays;
        // the ids' own rays, which they replace too, counted as the motion vectors').
        let hits_time = if split_on { hits_time } else { Duration::ZERO };
        // Saturating: the CPU clock sums live threads, so a thread that ended would step it back.
        let motion_time = start.elapsed().saturating_sub(hits_time);
        // The split and the re-shading are independent, and so are the two temporal filters
        // after them: each pair runs side by side (rayon::join), so that one stage's last rows
        // and its barriers can overlap the other's work (on the 2-vCPU machine of
        // docs/results/temporal.md this measured no gain: each stage already kept both cores
        // busy); `serial=1` in the tuning hook runs them in turn, for a breakdown by stage.
        let serial = tuned("serial").is_some_and(|v| v != 0.0);
        let timed = |f: &mut dyn FnMut()| {
            let t = Mark::now();
            f();
            t.elapsed()
        };
        let buffers = &mut self.buffers;
        let split_buffer = &mut buffers.split;
        let hits = &buffers.hits[..];
        let mut changes = None;
        let follow_deforming = self.reshade_deforming;
        let mut split_stage = || {
            if split_on {
                direct_split_at(split_buffer, rs, &camera, hits, w, h, seed);
                keep_rims_whole(split_buffer, frame);
            }
        };
        let mut reshade_stage = || {
            changes = match (&self.reshade, &self.prev) {
                (Some(path), Some(prev)) => prev.shaded.as_ref().map(|before| {
                    let camera = PinholeCamera::new(c, w, h);
                    let then = Pose {
                        view_proj: prev.view_proj,
                        transforms: &prev.transforms,
                        ids: prev.ids.as_deref(),
                        surface: prev
                            .hits
                            .as_deref()
                            .zip(prev.poses.as_ref())
                            .filter(|_| follow_deforming),
                    };
                    let now = Pose {
                        view_proj: view.view_proj,
                        transforms: &view.transforms,
                        ids,
                        surface: None,
                    };
                    reshade(rs, &camera, path, before, &then, &now)
                }),
                _ => None,
            }
        };
        let (mut split_time, reshade_time) = if serial {
            (timed(&mut split_stage), timed(&mut reshade_stage))
        } else {
            rayon::join(|| timed(&mut split_stage), || timed(&mut reshade_stage))
        };
        split_time += hits_time;
        let split = split_on.then_some(&buffers.split);
        // Emitters seen directly pass through unfiltered, as in every pipeline.
        let emitter = &mut buffers.emitter;
        emitter.clear();
        emitter.par_extend(
            frame
                .emission
                .data
                .par_chunks_exact(3)
                .zip(frame.albedo.data.par_chunks_exact(3))
                .map(|(e, a)| e.iter().any(|&v| v != 0.0) && a.iter().any(|&v| v != 0.0)),
        );
        let emitter = &emitter[..];
        // Where the direct light is split, the history holds the indirect light only.
        let color = match split {
            Some(d) => split_noisy(frame, d, &mut buffers.noisy),
            None => &frame.color,
        };
        let ratio_color = match split {
            Some(d) => Some(ratio_image(d, &mut buffers.ratio)),
            None => None,
        };
        let (filter, ratio) = (&mut self.filter, &mut self.ratio);
        let motion_ref = motion.as_ref();
        let mut filtered = None;
        let mut main_filter = || {
            // With several samples per frame a light's rim pixels hold a share of it: kept
            // out too.
            filtered = Some(with_emitted(color, emitter, &frame.emitted, |c| {
                filter.filter_reshaded(
                    &TemporalFrame {
                        color: c,
                        albedo: Some(&frame.albedo),
                        normal: &frame.normal,
                        depth: &frame.depth,
                        position: Some(&frame.position),
                        ids,
                        motion: motion_ref,
                    },
                    changes.as_deref(),
                )
            }));
        };
        let mut shadow = None;
        let mut ratio_filter = || {
            if let (Some(color), Some(ratio)) = (ratio_color, ratio.as_mut()) {
                shadow = Some(ratio.filter(&TemporalFrame {
                    color,
                    albedo: None,
                    normal: &frame.normal,
                    depth: &frame.depth,
                    position: Some(&frame.position),
                    ids,
                    motion: motion_ref,
                }));
            }
        };
        let (filter_time, mut split_filter) = if serial {
            (timed(&mut main_filter), timed(&mut ratio_filter))
        } else {
            rayon::join(|| timed(&mut main_filter), || timed(&mut ratio_filter))
        };
        let t = Mark::now();
        let mut filtered = filtered.expect("the main filter ran")?;
        if let (Some(d), Some(shadow)) = (split, shadow) {
            add_split_direct(&mut filtered.image, d, &shadow?.image);
        }
        split_filter += t.elapsed();
        split_time += split_filter;
        // The TAA history lives on the unjittered grid. A jittered pixel x shows the unjittered
        // image at x + j, so the surface at unjittered x was at jittered x − j + motion in the
        // previous frame, which is unjittered x + motion + j_prev − j.
        let image = match &mut self.taa {
            Some(taa) => {
                let unjittered = match (&motion, &self.prev) {
                    (Some(m), Some(prev)) => {
                        let mut m = m.clone();
                        let d = [prev.jitter[0] - jitter[0], prev.jitter[1] - jitter[1]];
                        for v in m.data.chunks_exact_mut(2) {
                            v[0] += d[0];
                            v[1] += d[1];
                        }
                        Some(m)
                    }
                    _ => None,
                };
                taa.apply(&filtered.image, unjittered.as_ref())?
            }
            None => filtered.image,
        };
        let times = TemporalTimes {
            total: start.elapsed(),
            motion: motion_time,
            reshade: reshade_time,
            split: split_time,
            split_filter,
            filter: filter_time,
        };
        if self.reshade.is_some() {
            let old = self.prev.as_mut().and_then(|p| p.shaded.take());
            view.shaded = Some(ShadedFrame::reusing(
                old,
                frame,
                seed,
                split.map(|d| &d.split[..]),
            ));
        }
        view.hits = pixel_hits;
        self.prev = Some(view);
        Ok((image, times))
    }
}

/// The sequence's parameters, tuned on a 24-frame 20° Cornell orbit at 128² (references at
/// 512 spp) and a 24-frame, 96×64 run of `scenes/animated.gltf` (seed 7), never on the reported
/// sequences (docs/results/temporal.md). Round 1: α = 0.1 and a 2-level À-Trous (SVGF: 0.2
/// and 5), the accumulated rather than the filtered colour as history (SVGF's feedback of the first
/// À-Trous level compounds its blur: 0.70 → 0.59 of per-frame À-Trous on the Cornell orbit),
/// and history rejection where the lighting changes (2 standard errors, gain 10: the animated
/// scene went from 2.3× to 0.97× per-frame À-Trous). A second round (also on a 64-frame, 16°
/// cornell-spheres orbit at 96², references 256 spp) added the variance of the accumulated
/// colour rather than of one sample to steer the À-Trous (0.71 → 0.66 on that orbit), a longer
/// history (α = 0.05, up to 128 frames) and a rejection radius of 6 (Cornell 0.61 → 0.59,
/// spheres 0.65, animated 0.97 → 0.96). A third round re-shades one sample per 3×3 block of the
/// previous frame with its own random numbers (A-SVGF's temporal gradients, `super::reshade`)
/// and rejects history by that change (gain 3, radius 4) while scaling what is kept by it
/// (animated 0.96 → 0.78, Cornell 0.59 → 0.57, spheres 0.65 → 0.66). A fifth round splits
/// the first hit's direct light off the history ([`TemporalSequence::filter`]; animated 0.78 →
/// 0.48, Cornell 0.57 → 0.54, spheres 0.66 → 0.62, a 40-frame atrium orbit 0.53 → 0.51) and
/// then filters with 3 À-Trous levels (0.49, 0.51, 0.63, 0.45). Camera jitter, TAA,
/// Catmull-Rom history reads, the neighbourhood clamp and the short-history levels are off:
/// measured, they did not lower FLIP (docs/results/temporal.md).
fn sequence_params(split_direct: bool) -> (TemporalParams, Option<(f32, f32)>) {
    let mut p = TemporalParams::sequence();
    if split_direct {
        // With the direct light split off, the history holds smoother (indirect) light that
        // a wider filter serves: 3 levels instead of 2 (round 5, tuning sequences only).
        p.atrous.iterations = SPLIT_LEVELS;
    }
    let mut taa = None;
    tune(&mut p, &mut taa);
    (p, taa)
}

/// À-Trous levels of the sequence's filters when the direct light is split.
const SPLIT_LEVELS: usize = 3;

/// À-Trous levels of the shadow ratio's filter (see [`ratio_params`]).
const RATIO_LEVELS: usize = 1;

/// The blend weight of the shadow ratio's history (see [`ratio_params`]).
const RATIO_ALPHA: f32 = 0.2;

/// Whether the direct-light split can stand in for the direct light frames traced with `path`
/// carry: they have direct light (depth 2 or more) and are RGB (the split computes RGB light).
pub fn splits_direct_light(path: &PathSettings) -> bool {
    path.max_depth >= 2 && !path.spectral
}

/// Leaves unsplit the pixels some of whose samples saw a light (with several samples per
/// pixel, a light's rim): their colour is passed through with the light's share
/// (`with_emitted`), which the split's indirect-only colour would not hold.
fn keep_rims_whole(d: &mut DirectSplit, frame: &Frame) {
    d.split
        .par_iter_mut()
        .zip(d.ratio.data.par_chunks_exact_mut(2))
        .zip(frame.emitted.data.par_chunks_exact(3))
        .for_each(|((split, ratio), e)| {
            if *split && e.iter().any(|&v| v != 0.0) {
                *split = false;
                ratio.fill(0.0);
            }
        });
}

/// The frame's colour with the direct light taken out where it is split: indirect light
/// there, the full colour elsewhere; written into `buffer` (reused when it has the size).
fn split_noisy<'a>(frame: &Frame, d: &DirectSplit, buffer: &'a mut Option<Image>) -> &'a Image {
    let c = &frame.color;
    if buffer
        .as_ref()
        .is_some_and(|b| (b.width, b.height, b.channels) == (c.width, c.height, c.channels))
    {
        if let Some(b) = buffer.as_mut() {
            b.data.copy_from_slice(&c.data);
        }
    } else {
        *buffer = Some(c.clone());
    }
    let out = buffer.get_or_insert_with(|| c.clone());
    out.data
        .par_chunks_exact_mut(3)
        .zip(frame.indirect.data.par_chunks_exact(3))
        .zip(d.split.par_iter())
        .for_each(|((o, indirect), &split)| {
            if split {
                o.copy_from_slice(indirect);
            }
        });
    out
}

/// The ratio estimator's two halves as an image for the temporal filter: shadowed in red and
/// green, unshadowed in blue, so that the filter's luminance-driven weights (0.93 of it red
/// and green) follow the shadows while both halves get the same weights.
/// Written into `buffer` (reused when it has the size).
fn ratio_image<'a>(d: &DirectSplit, buffer: &'a mut Option<Image>) -> &'a Image {
    let (w, h) = (d.ratio.width, d.ratio.height);
    if buffer
        .as_ref()
        .is_some_and(|b| (b.width, b.height, b.channels) != (w, h, 3))
    {
        *buffer = None;
    }
    let out = buffer.get_or_insert_with(|| Image::new(w, h, 3, 0.0));
    out.data
        .par_chunks_exact_mut(3)
        .zip(d.ratio.data.par_chunks_exact(2))
        .for_each(|(o, r)| o.copy_from_slice(&[r[0], r[0], r[1]]));
    out
}

/// Adds the split direct light to the filtered image: the exact part, and the unshadowed
/// part times the filtered shadowed-over-unshadowed ratio (in [0, 1]).
fn add_split_direct(image: &mut Image, d: &DirectSplit, shadow: &Image) {
    image
        .data
        .par_chunks_exact_mut(3)
        .zip(d.split.par_iter())
        .zip(shadow.data.par_chunks_exact(3))
        .zip(d.ratio.data.par_chunks_exact(2))
        .zip(d.exact.data.par_chunks_exact(3))
        .zip(d.unshadowed.data.par_chunks_exact(3))
        .for_each(|(((((o, &split), r), own), exact), unshadowed)| {
            if !split {
                return;
            }
            // Where the filter has nothing (no neighbour's sample reached a light), the
            // pixel's own sample; without one, no direct light from these lights.
            let ratio = if r[2] > 1e-6 {
                (r[0] / r[2]).clamp(0.0, 1.0)
            } else if own[1] > 0.0 {
                own[0] / own[1]
            } else {
                0.0
            };
            for k in 0..3 {
                o[k] += exact[k] + unshadowed[k] * ratio;
            }
        });
}

/// The shadow ratio's filter: the sequence's parameters with α = 0.2 (SVGF's: shadows move with
/// their objects and lights, and a ratio of 0 or 1 needs few frames) and one À-Trous level, or
/// the tuning hook's `ra` and `rl`. Tuned on the same sequences as the rest: α 0.05 / 0.2 / 0.4
/// and 1–4 levels all within 0.001 FLIP, α 0.2 the best on both Cornell and the animated
/// scene, one level as good as three and the cheapest (docs/results/temporal.md).
fn ratio_params() -> TemporalParams {
    let (mut p, _) = sequence_params(true);
    p.alpha = RATIO_ALPHA;
    p.alpha_moments = RATIO_ALPHA;
    if let Some(a) = tuned("ra") {
        p.alpha = a;
        p.alpha_moments = a;
    }
    p.atrous.iterations = tuned("rl").map_or(RATIO_LEVELS, |l| l as usize);
    p
}

/// The sub-pixel jitter of frame `i`: the Halton (2, 3) point i + 1, less 0.5, in pixels
/// (x right, y down), repeating every 16 frames.
pub fn jitter(i: usize) -> [f32; 2] {
    let k = (i % 16) as u32 + 1;
    [halton(k, 2) - 0.5, halton(k, 3) - 0.5]
}

fn halton(mut i: u32, base: u32) -> f32 {
    let (mut f, mut r) = (1.0f32, 0.0f32);
    while i > 0 {
        f /= base as f32;
        r += f * (i % base) as f32;
        i /= base;
    }
    r
}

/// `camera` turned so that the centre of its pixel x sees what the centre of `camera`'s pixel
/// x + `j` sees (exactly at the image centre; about a tenth of a pixel off near the corners at a
/// 40° field of view): the target moves along the image plane, the eye stays.
pub fn jittered_camera(camera: &Camera, w: usize, h: usize, j: [f32; 2]) -> Camera {
    let (right, up, _) = camera.basis();
    let (hw, hh) = camera.half_extent(w, h);
    let dist = (camera.target - camera.origin).length();
    let shift = right * (j[0] * 2.0 * hw / w as f32) - up * (j[1] * 2.0 * hh / h as f32);
    Camera {
        target: camera.target + shift * dist,
        ..camera.clone()
    }
}

/// A tuning value of `LUMO_TEMPORAL_TUNE` (see [`tune`]).
pub fn tuned(key: &str) -> Option<f32> {
    let spec = std::env::var("LUMO_TEMPORAL_TUNE").ok()?;
    spec.split(',').find_map(|kv| {
        let (k, v) = kv.split_once('=')?;
        (k.trim() == key).then(|| v.trim().parse().ok()).flatten()
    })
}

/// Tuning aid (undocumented in `--help`): `LUMO_TEMPORAL_TUNE="alpha=0.1,levels=2,…"`
/// overrides the parameters for parameter sweeps without a rebuild. Keys: alpha (colour and
/// moments), levels, sigma_l, gr / gk / gg (gradient radius, sigmas, gain), rg (re-shaded rejection gain), rr (1: rescale the history by the re-shaded change), rr_radius (its window radius), rs (0: no re-shading), rd (0: re-shading carries points on deforming meshes by their instance's transform only), fh (1: filtered
/// history), cr (1: Catmull-Rom history reads), clamp (neighbourhood clamp, σ), sl / sn
/// (short-history À-Trous levels and frames), mh (max history), vs (1: variance of
/// the accumulated colour), taa / taag (TAA blend weight, 0 = off, and clip
/// width), jit (1: camera jitter), jm (1: with jitter, motion on the unjittered grid), ds (0:
/// no direct-light split), ra / rl (the shadow ratio filter's α and À-Trous levels), serial (1:
/// the stages that run side by side run one after the other, for a breakdown by stage).
/// Values that do not parse are ignored; the filter still checks ranges.
fn tune(p: &mut TemporalParams, taa: &mut Option<(f32, f32)>) {
    let Ok(spec) = std::env::var("LUMO_TEMPORAL_TUNE") else {
        return;
    };
    for kv in spec.split(',') {
        let Some((k, v)) = kv.split_once('=') else {
            continue;
        };
        let Ok(v) = v.trim().parse::<f32>() else {
            continue;
        };
        match k.trim() {
            "alpha" => {
                p.alpha = v;
                p.alpha_moments = v;
            }
            "levels" => p.atrous.iterations = v as usize,
            "sigma_l" => p.atrous.sigma_luminance = Some(v),
            "gr" => p.gradient_radius = v as usize,
            "gk" => p.gradient_sigmas = v,
            "gg" => p.gradient_gain = v,
            "rg" => p.reshade_gain = v,
            "rr" => p.reshade_rescale = v != 0.0,
            "rr_radius" => p.reshade_radius = v as usize,
            "fh" => p.filtered_history = v != 0.0,
            "cr" => {
                p.resample = if v != 0.0 {
                    Resample::CatmullRom
                } else {
                    Resample::Bilinear
                }
            }
            "clamp" => p.clamp_sigmas = v,
            "mh" => p.max_history = v as u32,
            "vs" => p.scale_variance = v != 0.0,
            "sl" => p.short_history_levels = v as usize,
            "sn" => p.short_history_frames = v as u32,
            "taa" if v > 0.0 => {
                *taa = Some((v, taa.map_or(lumo_filter::DEFAULT_TAA_GAMMA, |t| t.1)))
            }
            "taa" => *taa = None,
            "taag" => *taa = Some((taa.map_or(lumo_filter::DEFAULT_TAA_ALPHA, |t| t.0), v)),
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec2, Vec3};
    use lumo_render::direct_split;

    /// A still Cornell box, 24 one-sample frames: with the direct light split (the default)
    /// the temporal output has the mean brightness of a converged render (the split's light
    /// is added back once, not twice or not at all), and two runs with other random numbers
    /// differ by far less than without the split, which keeps the area light's sampling noise
    /// in its history. (Their difference is the noise alone: the pixel-centre aliasing that
    /// both share against an area-sampled reference cancels.)
    #[test]
    fn the_direct_light_split_keeps_the_brightness_and_lowers_the_noise() {
        use lumo_render::{render, RenderSettings};
        let (w, h) = (32, 32);
        let scene = lumo_scene::builtin_scene("cornell").expect("built-in scene");
        let rs = RenderScene::new(scene).expect("scene");
        let settings = |spp, seed| RenderSettings {
            width: w,
            height: h,
            spp,
            seed,
            path: PathSettings::default(),
        };
        let (reference, _) = render(&rs, &settings(1024, 99), &|_| {});
        let run = |split: bool, base: u32| {
            let mut seq =
                TemporalSequence::new(false, Some(PathSettings::default()), true).unwrap();
            if !split {
                seq.ratio = None;
            }
            let mut out = None;
            for f in 0..24u32 {
                let seed = base.wrapping_add(f.wrapping_mul(0x9e37_79b9));
                let (frame, _) = render(&rs, &settings(1, seed), &|_| {});
                out = Some(seq.filter(&rs, &frame, [0.0; 2], seed).unwrap().0);
            }
            out.unwrap()
        };
        let mean = |img: &Image| img.data.iter().map(|&v| v as f64).sum::<f64>();
        // Relative squared difference, so that the light's pixels do not dominate.
        let diff = |a: &Image, b: &Image| {
            let d: f64 = a
                .data
                .iter()
                .zip(&b.data)
                .zip(&reference.color.data)
                .map(|((&a, &b), &r)| ((a - b) as f64).powi(2) / ((r as f64).powi(2) + 1e-2))
                .sum();
            d / a.data.len() as f64
        };
        let with = [run(true, 7), run(true, 1234)];
        let without = [run(false, 7), run(false, 1234)];
        let ratio = mean(&with[0]) / mean(&reference.color);
        assert!((ratio - 1.0).abs() < 0.05, "mean brightness ratio {ratio}");
        let (a, b) = (diff(&with[0], &with[1]), diff(&without[0], &without[1]));
        assert!(a < 0.85 * b, "noise {a} with the split, {b} without");
    }

    /// With several samples per pixel, the pixels on a light's rim (some samples saw the
    /// light, the centre did not) are left unsplit, so their colour keeps its indirect light
    /// when `with_emitted` passes the light's share through; and frames without direct light
    /// (`--max-depth 1`) or with spectral transport are not split at all.
    #[test]
    fn light_rims_and_frames_without_rgb_direct_light_are_not_split() {
        use lumo_render::{render, RenderSettings};
        let (w, h) = (61, 61);
        let rs = RenderScene::new(lumo_scene::builtin_scene("cornell").expect("scene")).unwrap();
        let settings = RenderSettings {
            width: w,
            height: h,
            spp: 8,
            seed: 1,
            path: PathSettings::default(),
        };
        let (frame, _) = render(&rs, &settings, &|_| {});
        let mut d = direct_split(&rs, &PinholeCamera::new(&rs.scene.camera, w, h), w, h, 1);
        let rims = |d: &DirectSplit| {
            (0..w * h)
                .filter(|&i| d.split[i] && frame.emitted.data[i * 3..i * 3 + 3] != [0.0; 3])
                .count()
        };
        assert!(rims(&d) > 0, "the light's rim has split pixels before");
        keep_rims_whole(&mut d, &frame);
        assert_eq!(rims(&d), 0);
        assert!(d.split.iter().filter(|&&s| s).count() > w * h / 2);
        let mut p = PathSettings::default();
        assert!(splits_direct_light(&p));
        p.max_depth = 1;
        assert!(!splits_direct_light(&p));
        p.max_depth = 5;
        p.spectral = true;
        assert!(!splits_direct_light(&p));
    }

    /// The jittered camera's pixel centre x looks where the nominal camera's x + j looks (at
    /// the image centre exactly; about a tenth of a pixel off near the corners at 40°), and the
    /// jitter sequence covers the pixel.
    #[test]
    fn jittered_camera_shifts_the_pixel_grid() {
        let nominal = Camera {
            origin: Vec3::new(0.0, 1.0, 4.0),
            target: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            fov: 40.0,
            fov_axis: lumo_scene::FovAxis::Y,
            lens: Default::default(),
            filter: Default::default(),
        };
        let (w, h) = (128, 96);
        let j = [0.3, -0.4];
        let a = PinholeCamera::new(&jittered_camera(&nominal, w, h, j), w, h);
        let b = PinholeCamera::new(&nominal, w, h);
        for (x, y) in [(64.0, 48.0), (10.5, 80.5)] {
            let d = a.direction(Vec2::new(x, y));
            let p = b.project(d).unwrap();
            assert!((p.x - (x + j[0])).abs() < 0.15, "{x}: {p}");
            assert!((p.y - (y + j[1])).abs() < 0.15, "{y}: {p}");
        }
        let js: Vec<[f32; 2]> = (0..16).map(jitter).collect();
        assert!(js.iter().all(|j| j.iter().all(|v| v.abs() < 0.5)));
        let mean = js.iter().fold(0.0, |s, j| s + j[0]) / 16.0;
        assert!(mean.abs() < 0.05, "{mean}");
        assert_eq!(jitter(3), jitter(19));
    }
}
