//! lumo's renderer: a two-level BVH over obvhs (with exact spheres, disks and cylinders),
//! stateless Owen-scrambled Sobol sampling, physically based BSDFs (one file per material in
//! [`bsdf`]), lights that sample both ways (towards a surface point and as particle sources,
//! [`lights`]), participating media ([`media`]), cameras (pinhole, thin lens, orthographic)
//! with ray generation and the pinhole's importance, the integrators ([`integrators`]: the
//! path tracer with next-event estimation and MIS, scalar, wavefront and with a vectorised
//! diffuse bounce, RGB or spectral; the light tracer; bidirectional path tracing; progressive
//! photon mapping), and a film that keeps direct and indirect light and a G-buffer apart.
//!
//! [`Integrator`] is the one table of the integrators (names, capabilities, sample units) and
//! the one entry point that renders an image with any of them, or its samples one by one for a
//! progressive viewer's streams ([`stream`]); `render.rs` holds the parallel
//! loops it calls, `parallel.rs` the row loops they share, `settings.rs` the plain data a
//! render is asked for and reports, and `render_scene/` the scene prepared for them.
// Every unsafe block (the SIMD kernels) says why it is sound.
#![deny(clippy::undocumented_unsafe_blocks)]

pub mod accel;
pub mod bsdf;
pub mod camera;
mod camera_hits;
mod camera_sample;
mod dirac_direct;
mod direct_split;
mod film;
pub mod geometry;
mod integrator;
pub mod integrators;
pub mod light_pilot;
pub mod lights;
pub mod media;
mod parallel;
pub mod pixel_filter;
mod pixel_sums;
mod render;
mod render_scene;
pub mod sampler;
mod settings;
pub mod shading;
mod specular_albedo;
pub mod stream;
mod surface_motion;
#[cfg(test)]
mod test_camera;
#[cfg(test)]
mod test_lights;
#[cfg(test)]
mod test_shapes;

pub use camera_hits::{camera_hits, camera_hits_into, pixel_centre_ray};
pub use dirac_direct::dirac_direct;
pub use direct_split::{
    direct_split, direct_split_at, direct_split_into, DirectSplit, MAX_ANALYTIC_TRIANGLES,
};
pub use film::{Frame, AOV_NAMES};
pub use integrator::{
    sentence, Capabilities, Integrator, IntegratorInfo, IntegratorOptions, Particles, RenderedImage,
};
pub use integrators::path::{trace_path, trace_path_xyz, FirstHit, PathRadiance, PathSettings};
pub use integrators::photon::PpmSettings;
pub use light_pilot::{LightPilot, PilotReport, PilotSums};
pub use parallel::{map_pixels, map_rows};
pub use pixel_sums::PixelSums;
pub use render::{
    frame_from_estimates, instance_ids, render, render_bdpt, render_estimates, render_light,
    render_pixel, render_pixel_one_ray, render_ppm, render_sums, trace_sample, PpmStats,
    LIGHT_STREAM_X,
};
pub use render_scene::{RenderScene, SceneUpdate, Surface};
pub use settings::{PixelEstimate, RenderSettings, RenderStats};
pub use surface_motion::{
    deformation_back, deformed_point, pixel_hits, DeformedPoint, MeshPoses, PixelHit,
};
