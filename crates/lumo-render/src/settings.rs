//! What a render is asked for ([`RenderSettings`]) and what it reports ([`RenderStats`],
//! [`PixelEstimate`]): plain data the integrators and the image loops (`render.rs`) share, so
//! that the integrators need nothing from the loops above them.

use glam::Vec3;

#[cfg(doc)]
use crate::integrators::path::PathRadiance;
use crate::integrators::path::{FirstHit, PathSettings};

/// What to render.
#[derive(Clone, Copy, Debug)]
pub struct RenderSettings {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// Samples per pixel (the first goes through the pixel centre).
    pub spp: u32,
    /// Seed; the image is a pure function of (scene, settings, seed).
    pub seed: u32,
    /// Integrator parameters.
    pub path: PathSettings,
}

/// Work counters of a render.
#[derive(Clone, Copy, Debug, Default)]
pub struct RenderStats {
    /// Camera samples traced.
    pub samples: u64,
    /// Rays traced (closest-hit and shadow).
    pub rays: u64,
}

/// One pixel's estimates.
#[derive(Clone, Copy, Debug, Default)]
pub struct PixelEstimate {
    /// Mean direct radiance.
    pub direct: Vec3,
    /// Mean indirect radiance.
    pub indirect: Vec3,
    /// Sample variance of luminance (Welford); 0 with one sample.
    pub luminance_variance: f32,
    /// The pixel-centre ray's first hit, except its albedo: the mean of all samples' (see
    /// [`PathRadiance::albedo`]).
    pub first_hit: FirstHit,
    /// Mean over the samples of the radiance their first hit emits towards the camera (see
    /// [`PathRadiance::emitted`]): on a light's rim, the light's share of the pixel.
    pub emitted: Vec3,
    /// Rays traced.
    pub rays: u64,
}
