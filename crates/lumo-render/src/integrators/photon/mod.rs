//! One-pass progressive photon mapping (the progressive client–server paper's §3.4, made
//! consistent with Knaus & Zwicker's shrinking radius).
//!
//! Photon paths are traced in batches while camera samples render, so the map grows linearly
//! with the samples; camera paths follow delta bounces and, at their first non-delta vertex,
//! add direct light by next-event estimation and indirect light from the photons within the
//! pass's radius. The pieces are pure functions of their inputs; `render.rs`
//! ([`crate::render_ppm`]) and the server's worker decide what runs in parallel.
//!
//! - [`kdtree`]: the space-balanced, incrementally split kd-tree;
//! - [`trace`]: photon paths and batches;
//! - [`map`]: the shared map (readers–writer lock, capacity, contention counters);
//! - [`radius`]: the per-pass radius schedule;
//! - [`gather`]: the camera path and density estimate.

pub mod gather;
pub mod kdtree;
pub mod map;
pub mod radius;
pub mod trace;

pub use gather::{trace_ppm_path, GatherStats};
pub use kdtree::{KdTree, Photon};
pub use map::{LockStats, MapState, PhotonMap};
pub use radius::RadiusSchedule;
pub use trace::{trace_photon_path, PhotonBatch, PHOTON_STREAM_X};

use glam::Vec2;

use crate::camera::PinholeCamera;
use crate::integrators::path::PathSettings;
use crate::render_scene::RenderScene;

/// Photon-mapping parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PpmSettings {
    /// Photon paths traced per pass (per camera sample of every pixel); 0: one per pixel.
    pub photons_per_pass: u64,
    /// Most photons the map keeps (memory bound; see [`map`]).
    pub max_photons: usize,
    /// Gather radius of the first pass as a fraction of the scene's bounding-box diagonal,
    /// for [`REFERENCE_PATHS`] photon paths per pass; other pass sizes scale it by
    /// `sqrt(REFERENCE_PATHS / photons_per_pass)`, which keeps the photons a gather finds (and
    /// so its cost and noise) independent of the image size.
    pub radius: f32,
    /// α of the radius schedule.
    pub alpha: f32,
}

/// Photon paths per pass at which [`PpmSettings::radius`] holds as given: a 512×512 image's
/// pixels.
pub const REFERENCE_PATHS: u64 = 1 << 18;

/// Default `max_photons`: 4 Mi photons, about 290 MB with the tree ([`KdTree::BYTES_PER_PHOTON`]).
pub const DEFAULT_MAX_PHOTONS: usize = 1 << 22;

impl Default for PpmSettings {
    fn default() -> Self {
        PpmSettings {
            photons_per_pass: 0,
            max_photons: DEFAULT_MAX_PHOTONS,
            radius: 0.0025,
            alpha: 2.0 / 3.0,
        }
    }
}

impl PpmSettings {
    /// Photon paths per pass for an image of `pixels` pixels.
    pub fn paths_per_pass(&self, pixels: u64) -> u64 {
        if self.photons_per_pass == 0 {
            pixels.max(1)
        } else {
            self.photons_per_pass
        }
    }

    /// The radius schedule for `rs`'s scene with `paths_per_pass` photon paths per pass.
    pub fn schedule(&self, rs: &RenderScene, paths_per_pass: u64) -> RadiusSchedule {
        let (lo, hi) = rs.scene.bounds();
        let scale = (REFERENCE_PATHS as f64 / paths_per_pass.max(1) as f64).sqrt() as f32;
        RadiusSchedule {
            initial: self.radius * scale * (hi - lo).length().max(1e-6),
            alpha: self.alpha,
        }
    }

    /// An empty shared map over `rs`'s scene box.
    pub fn new_map(&self, rs: &RenderScene) -> PhotonMap {
        let (lo, hi) = rs.scene.bounds();
        PhotonMap::new(lo, hi, self.max_photons)
    }
}

/// Why photon mapping cannot render `rs` as the path tracer would, as one line (None when it
/// can): no light emits photons, an environment's light (which emits none) is missing past
/// the first bounce, or no non-delta surface is in view (through up to `max_depth` delta
/// bounces) to gather at. Probes a 16×16 grid of pixel-centre rays of `camera`.
pub fn scene_warning(
    rs: &RenderScene,
    camera: &PinholeCamera,
    settings: &PathSettings,
) -> Option<String> {
    let mut problems = Vec::new();
    if rs.lights.emits_no_particles() {
        problems.push("no light emits photons (environment lights do not), so only emitters and direct light appear");
    } else if rs.lights.has_environment() {
        problems.push("the environment light emits no photons, so its light after the first bounce is missing");
    }
    let empty = MapState::new(glam::Vec3::ZERO, glam::Vec3::ONE, 0);
    let (w, h) = camera.film_size();
    let mut gathers = false;
    'probe: for j in 0..16 {
        for i in 0..16 {
            let film = Vec2::new((i as f32 + 0.5) / 16.0 * w, (j as f32 + 0.5) / 16.0 * h);
            let mut sampler = crate::sampler::PixelSampler::new(i, j, 0, 0);
            let (origin, dir) = camera.ray(film, Vec2::splat(0.5));
            let (_, st) = trace_ppm_path(rs, &empty, 0.0, origin, dir, &mut sampler, settings);
            if st.gathered {
                gathers = true;
                break 'probe;
            }
        }
    }
    if !gathers {
        problems.push("no diffuse or glossy surface is in view, so no photon is ever gathered");
    }
    (!problems.is_empty()).then(|| {
        format!(
            "warning: --integrator ppm: {}; --integrator path renders this scene fully",
            problems.join("; ")
        )
    })
}

#[cfg(test)]
mod tests;
