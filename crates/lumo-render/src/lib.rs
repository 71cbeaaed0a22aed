//! lumo's renderer: a two-level BVH over obvhs, stateless Owen-scrambled Sobol sampling,
//! physically based BSDFs (one file per material) and lights that sample both ways (towards a
//! surface point and as particle sources), a pinhole camera with ray generation and
//! importance, the integrators (a path tracer with next-event estimation and MIS, a light
//! tracer), and a film that keeps direct and indirect light and a G-buffer apart.
// Every unsafe block (the SIMD kernels) says why it is sound.
#![deny(clippy::undocumented_unsafe_blocks)]

pub mod accel;
pub mod bsdf;
pub mod camera;
mod direct_split;
mod film;
pub mod geometry;
pub mod integrators;
pub mod lights;
pub mod media;
pub mod pixel_filter;
mod pixel_sums;
mod render;
mod render_scene;
pub mod sampler;
pub mod shading;
mod specular_albedo;
#[cfg(test)]
mod test_lights;

pub use direct_split::{direct_split, DirectSplit, MAX_ANALYTIC_TRIANGLES};
pub use film::{Frame, AOV_NAMES};
pub use integrators::path::{trace_path, trace_path_xyz, FirstHit, PathRadiance, PathSettings};
pub use integrators::photon::PpmSettings;
pub use pixel_sums::PixelSums;
pub use render::{
    frame_from_estimates, instance_ids, map_pixels, map_rows, render, render_bdpt, render_light,
    render_pixel, render_pixel_one_ray, render_ppm, render_sums, trace_sample, PixelEstimate,
    PpmStats, RenderSettings, RenderStats, LIGHT_STREAM_X,
};
pub use render_scene::{RenderScene, SceneUpdate, Surface};
