//! Participating media in transport: free-flight sampling (closed form in homogeneous media,
//! delta tracking over a majorant grid in heterogeneous ones), transmittance along shadow
//! rays (closed form / ratio tracking) and phase functions. The volumetric path tracer that
//! uses them is `integrators/path/volume.rs`; docs/media.md explains the choices.

pub mod phase;
pub mod tracking;

pub use tracking::{free_flight, transmittance_in, Coefficients, Flight};
