//! lumo's path tracer: a two-level BVH over obvhs, stateless Owen-scrambled Sobol sampling,
//! physically based BSDFs and lights, a unidirectional path tracer with next-event estimation
//! and MIS, and a film that keeps direct and indirect light and a G-buffer apart.
// Every unsafe block (the SIMD kernels) says why it is sound.
#![deny(clippy::undocumented_unsafe_blocks)]

pub mod accel;
mod analytic;
mod blas;
pub mod bsdf;
mod bvh4;
mod bvh8;
mod bvh_stack;
#[cfg(test)]
mod bvh_tests;
mod bvh_wide;
pub mod camera;
pub mod distribution;
mod frame;
pub mod geometry;
pub mod integrator;
pub mod light_tracer;
pub mod lights;
pub mod packet;
mod render;
mod render_scene;
pub mod sampler;
pub mod shading;
mod simd_bounce;
mod simd_level;
pub mod wavefront;

pub use frame::{Frame, AOV_NAMES};
pub use integrator::{trace_path, FirstHit, PathRadiance, PathSettings};
pub use render::{
    frame_from_estimates, map_pixels, map_rows, render, render_pixel, render_pixel_one_ray,
    trace_sample, PixelEstimate, RenderSettings, RenderStats,
};
pub use render_scene::{RenderScene, Surface};
