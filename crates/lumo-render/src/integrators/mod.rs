//! The light-transport algorithms: each reads the render scene (geometry, lights, materials,
//! camera) and returns estimates; none owns a thread pool (`render.rs`, with [`crate::render()`]
//! and [`crate::render_light`], and the callers' row loops are where parallelism lives).
//!
//! - [`path`]: unidirectional path tracing with next-event estimation and MIS, in a scalar form
//!   ([`path::trace_path`]), a wavefront form over ray packets ([`path::wavefront`]) and a
//!   vectorised diffuse bounce; all three give the same image.
//! - [`bdpt`]: bidirectional path tracing: camera and light subpaths joined by every
//!   strategy, weighted by multiple importance sampling (`lumo render --integrator bdpt`).
//! - [`light`]: particle (light) tracing, splatting onto the film: the server's light stream
//!   and `lumo render --integrator light`.
//! - [`photon`]: one-pass progressive photon mapping (`lumo render --integrator ppm`, the
//!   server's `ppm`): photon batches grow a shared kd-tree while camera samples gather from it.

pub mod bdpt;
pub mod light;
pub mod path;
pub mod photon;
