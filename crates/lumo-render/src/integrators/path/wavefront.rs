//! The wavefront renderer: the paths of a run of pixels advance together, one bounce at a
//! time, so their rays can be traced sixteen at a time ([`crate::accel::packet`]).
//!
//! Each bounce is three stages over the paths still alive: trace their rays in packets, let
//! every path take its hit ([`PathState::advance`]: emission, light sample, BSDF sample; paths
//! at simple diffuse surfaces sixteen at a time in [`crate::integrators::path::vector_bounce`]), then
//! trace the shadow rays in packets and credit the unoccluded ones. Paths are packed densely
//! each bounce (finished ones drop out), so packets stay full while paths end at different
//! depths. A path's arithmetic is the one-ray-at-a-time integrator's and packet traversal finds
//! the same hits, so the estimates equal [`crate::trace_sample`]'s bit for bit; and since a
//! pixel's paths depend only on (pixel, sample, seed), so does the image, whatever the
//! threads.

use std::ops::Range;

use crate::accel::packet::{RayPacket, LANES};
use crate::accel::Hit;
use crate::camera::PinholeCamera;
use crate::camera_sample::camera_sample_with;
use crate::integrators::path::mask_shadow;
use crate::integrators::path::vector_bounce::{self, diffuse_bounce, SimpleLane};
use crate::integrators::path::{FirstHit, PathRadiance, PathSettings, PathState, ShadowRay};
use crate::pixel_sums::PixelSums;
use crate::render_scene::RenderScene;
use crate::sampler::{PixelSampler, RUN};
use crate::settings::{PixelEstimate, RenderSettings};

/// Paths advanced together: enough to keep packets full as paths end, few enough that their
/// states (~200 bytes each) stay in the first- and second-level caches.
const BATCH_PATHS: usize = 256;

/// Packets of fewer paths take the scalar bounce: the vector bounce costs sixteen lanes
/// whatever the number of paths in it.
const MIN_VECTOR_LANES: usize = 4;

/// Renders samples `0..spp` of pixels `xs` of row `y`, in order: for each pixel the same
/// estimate as [`crate::render_pixel`] (which calls this for one pixel).
pub fn render_pixels(
    rs: &RenderScene,
    camera: &PinholeCamera,
    settings: &RenderSettings,
    y: usize,
    xs: Range<usize>,
) -> Vec<PixelEstimate> {
    render_pixels_from(rs, camera, settings, 0, y, xs)
}

/// [`render_pixels`] for samples `first..first + spp`: a progressive renderer adds sample
/// after sample of one sequence (sample 0 goes through the pixel centre and alone records the
/// first hit; later ones are jittered), so `n` calls of one sample each give the image of one
/// `n`-sample render.
pub fn render_pixels_from(
    rs: &RenderScene,
    camera: &PinholeCamera,
    settings: &RenderSettings,
    first: u32,
    y: usize,
    xs: Range<usize>,
) -> Vec<PixelEstimate> {
    render_pixel_sums(rs, camera, settings, first, y, xs)
        .iter()
        .map(PixelSums::estimate)
        .collect()
}

/// The exact sums ([`PixelSums`]) of samples `first..first + spp` of pixels `xs` of row `y`:
/// sums of disjoint sample ranges add up, bit for bit, to the sums of their union.
pub fn render_pixel_sums(
    rs: &RenderScene,
    camera: &PinholeCamera,
    settings: &RenderSettings,
    first: u32,
    y: usize,
    xs: Range<usize>,
) -> Vec<PixelSums> {
    let mut out = Vec::with_capacity(xs.len());
    for_each_pixel_sums(rs, camera, settings, first, y, xs, |sums| out.push(sums));
    out
}

/// [`render_pixels`] written into `out` (one estimate per pixel of `xs`, which must be as
/// long) instead of a new vector: the image loop that fills a whole frame's buffer in place
/// (`crate::render_estimates`) allocates no row of its own.
pub fn render_pixels_into(
    rs: &RenderScene,
    camera: &PinholeCamera,
    settings: &RenderSettings,
    y: usize,
    xs: Range<usize>,
    out: &mut [PixelEstimate],
) {
    debug_assert_eq!(out.len(), xs.len());
    let mut slots = out.iter_mut();
    for_each_pixel_sums(rs, camera, settings, 0, y, xs, |sums| {
        if let Some(slot) = slots.next() {
            *slot = sums.estimate();
        }
    });
}

/// Calls `emit` with the sums of samples `first..first + spp` of each pixel of `xs` of row
/// `y`, left to right: the loop behind [`render_pixel_sums`] and [`render_pixels_into`].
fn for_each_pixel_sums(
    rs: &RenderScene,
    camera: &PinholeCamera,
    settings: &RenderSettings,
    first: u32,
    y: usize,
    xs: Range<usize>,
    mut emit: impl FnMut(PixelSums),
) {
    let spp = settings.spp as usize;
    let per_batch = (BATCH_PATHS / spp.max(1)).max(1);
    let mut batch = Batch::with_capacity(per_batch * spp.max(1));
    let mut x0 = xs.start;
    while x0 < xs.end {
        let x1 = (x0 + per_batch).min(xs.end);
        batch.run(rs, camera, settings, first, y, x0..x1);
        for paths in batch.paths.chunks(spp.max(1)) {
            let first_hit = paths.first().filter(|_| first == 0).map(|p| p.first_hit);
            let mut sums = PixelSums::new(first_hit);
            for p in paths {
                sums.add_sample(&p.result());
            }
            emit(sums);
        }
        x0 = x1;
    }
}

/// Traces `paths` (each made by [`PathState::new`], and made spectral where `settings` asks)
/// to their ends together, sixteen rays per packet, as the renderer traces a row's samples:
/// each path ends as [`PathState::run`] alone would leave it, bit for bit (the same arithmetic
/// per path, and packets find the same hits). For callers that start paths of their own, such
/// as the temporal filter's re-shading of the previous frame's samples; a few hundred paths
/// at a time keep their states in the caches.
pub fn trace_paths(rs: &RenderScene, settings: &PathSettings, paths: &mut Vec<PathState>) {
    let mut batch = Batch::with_capacity(0);
    std::mem::swap(&mut batch.paths, paths);
    batch.active.reserve(batch.paths.len());
    batch.next.reserve(batch.paths.len());
    batch.shadows.reserve(batch.paths.len());
    batch.trace(rs, settings);
    std::mem::swap(&mut batch.paths, paths);
}

/// Reusable buffers of one batch of paths.
struct Batch {
    paths: Vec<PathState>,
    active: Vec<u32>,
    next: Vec<u32>,
    shadows: Vec<(u32, ShadowRay)>,
    /// (x, y, sample index) of each path, in path order.
    samples: Vec<(u32, u32, u32)>,
}

impl Batch {
    /// Buffers for `paths` paths, so that a batch never grows them.
    fn with_capacity(paths: usize) -> Self {
        Batch {
            paths: Vec::with_capacity(paths),
            active: Vec::with_capacity(paths),
            next: Vec::with_capacity(paths),
            shadows: Vec::with_capacity(paths),
            samples: Vec::with_capacity(paths),
        }
    }

    /// Traces samples `first..first + spp` of pixels `xs` of row `y` to the end of their paths.
    fn run(
        &mut self,
        rs: &RenderScene,
        camera: &PinholeCamera,
        settings: &RenderSettings,
        first: u32,
        y: usize,
        xs: Range<usize>,
    ) {
        self.paths.clear();
        self.samples.clear();
        for x in xs {
            for index in first..first + settings.spp {
                self.samples.push((x as u32, y as u32, index));
            }
        }
        // Samplers are made sixteen samples at a time (vector lanes).
        let mut run = [PixelSampler::new(0, 0, 0, 0); RUN];
        for samples in self.samples.chunks(RUN) {
            let run = &mut run[..samples.len()];
            PixelSampler::run(samples, settings.seed, run);
            for (&(x, y, index), &sampler) in samples.iter().zip(run.iter()) {
                let pixel = (x as usize, y as usize);
                let (sampler, _, origin, dir) = camera_sample_with(camera, pixel, index, sampler);
                // Built in place: moving the ~230-byte state through `spectral(self)` cost
                // two memcpy calls per sample.
                self.paths
                    .push(PathState::new(origin, dir, sampler, index == 0));
                if settings.path.spectral {
                    if let Some(path) = self.paths.last_mut() {
                        path.make_spectral();
                    }
                }
            }
        }
        self.trace(rs, &settings.path);
    }

    /// Traces the batch's paths to their ends.
    fn trace(&mut self, rs: &RenderScene, settings: &PathSettings) {
        if rs.scene.media.is_active() {
            // Media and null boundaries are the scalar volumetric path tracer's (one ray at a
            // time): the packets' bounce knows only surfaces.
            for path in &mut self.paths {
                path.run(rs, settings);
            }
            return;
        }
        self.active.clear();
        self.active.extend(0..self.paths.len() as u32);
        while !self.active.is_empty() {
            self.bounce(rs, settings);
            std::mem::swap(&mut self.active, &mut self.next);
        }
    }

    /// One bounce of every active path: closest hits, shading and sampling, shadow rays.
    fn bounce(&mut self, rs: &RenderScene, settings: &PathSettings) {
        self.next.clear();
        self.shadows.clear();
        let mut hits: [Option<Hit>; LANES] = [None; LANES];
        // Paths at simple diffuse surfaces bounce sixteen at a time in vector registers.
        let vector = vector_bounce::applies(settings);
        let active = std::mem::take(&mut self.active);
        for group in active.chunks(LANES) {
            let mut rays = RayPacket::default();
            for (lane, &p) in group.iter().enumerate() {
                let path = &self.paths[p as usize];
                rays.set(lane, path.origin, path.dir, 0.0, f32::INFINITY);
            }
            rs.accel.intersect_packet(&rays, &mut hits);
            if rs.prefetches_surfaces() {
                for h in hits.iter().take(group.len()).flatten() {
                    rs.prefetch_indices(h);
                }
                for h in hits.iter().take(group.len()).flatten() {
                    rs.prefetch_corners(h);
                }
            }
            let vector_group = vector && group.len() >= MIN_VECTOR_LANES;
            let mut simple: [SimpleLane; LANES] = [Default::default(); LANES];
            let mut n_simple = 0;
            for (&p, &hit) in group.iter().zip(&hits) {
                if let Some(h) = hit.filter(|_| vector_group) {
                    if rs.is_simple_diffuse(h.instance) {
                        simple[n_simple] = (p, h);
                        n_simple += 1;
                        continue;
                    }
                }
                let (shadow, goes_on) = self.paths[p as usize].advance(rs, settings, hit);
                if let Some(sh) = shadow {
                    self.shadows.push((p, sh));
                }
                if goes_on {
                    self.next.push(p);
                }
            }
            if n_simple > 0 {
                diffuse_bounce(
                    rs,
                    settings,
                    &mut self.paths,
                    &simple[..n_simple],
                    &mut self.shadows,
                    &mut self.next,
                );
            }
        }
        self.active = active;
        let masks = mask_shadow::applies(rs);
        for group in self.shadows.chunks(LANES) {
            let mut rays = RayPacket::default();
            for (lane, (_, sh)) in group.iter().enumerate() {
                rays.set(lane, sh.origin, sh.dir, 0.0, sh.tmax);
            }
            let blocked = rs.accel.occluded_packet(&rays);
            for (lane, (p, sh)) in group.iter().enumerate() {
                let path = &mut self.paths[*p as usize];
                if blocked & (1 << lane) == 0 {
                    path.add_unoccluded(sh);
                } else if masks {
                    mask_shadow::credit_blocked(rs, path, sh, settings.max_depth);
                }
            }
        }
    }
}

/// A pixel's estimate from the radiance of its samples and its first hit, through the exact
/// sums every render uses ([`PixelSums`]).
pub(crate) fn estimate(
    radiance: impl Iterator<Item = PathRadiance>,
    first_hit: FirstHit,
) -> PixelEstimate {
    let mut sums = PixelSums::new(Some(first_hit));
    for r in radiance {
        sums.add_sample(&r);
    }
    sums.estimate()
}
