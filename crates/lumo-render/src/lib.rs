//! lumo's renderer: a two-level BVH over obvhs (with exact spheres, disks and cylinders),
//! stateless Owen-scrambled Sobol sampling, physically based BSDFs (one file per material in
//! [`bsdf`]), lights that sample both ways (towards a surface point and as particle sources,
//! [`lights`]), participating media ([`media`]), a pinhole camera with ray generation and
//! importance, the integrators ([`integrators`]: the path tracer with next-event estimation
//! and MIS, scalar, wavefront and with a vectorised diffuse bounce, RGB or spectral; the light
//! tracer; bidirectional path tracing; progressive photon mapping), and a film that keeps
//! direct and indirect light and a G-buffer apart. `render.rs` holds the parallel loops that
//! render whole images with each integrator; `render_scene/` the scene prepared for them.
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
mod settings;
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
    render_pixel, render_pixel_one_ray, render_ppm, render_sums, trace_sample, PpmStats,
    LIGHT_STREAM_X,
};
pub use render_scene::{RenderScene, SceneUpdate, Surface};
pub use settings::{PixelEstimate, RenderSettings, RenderStats};
