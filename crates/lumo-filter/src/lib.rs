//! Screen-space denoising filters for lumo: pure functions from image planes to image planes,
//! with no dependency on the renderer.
//!
//! - [`atrous()`]: edge-avoiding À-Trous wavelet filter (Dammertz et al. 2010), optionally
//!   variance-guided (SVGF), with albedo demodulation and sparse-input in-painting.
//! - [`guided()`]: guided image filter (He et al.) with a 1–8 dimensional guide built from
//!   normals and depth (Bauszat et al. 2011), and the fast sub-sampled variant (He & Sun 2015).
//! - [`bilateral()`]: brute-force cross (joint) bilateral filter, the quality reference.
//! - [`jbu()`]: joint bilateral upsampling of a low-resolution buffer (Kopf et al. 2007), with
//!   [`remove_outliers`] and an optional bilateral pre-filter.
//! - [`most_similar`]: the geometry-aware lookup of Bauszat et al. (eqs 3–5).
//! - [`TemporalFilter`]: spatiotemporal variance-guided filtering (SVGF, Schied et al. 2017),
//!   the one stateful filter: reprojected, accumulated history + the variance-guided À-Trous;
//!   [`motion_vectors`] computes its motion vectors for a static scene and a moving camera.
//!
//! Colour images have 3 channels. Non-finite colour pixels are treated as missing (weight 0);
//! results are always finite and report how many pixels were missing.
//! See docs/filters.md for parameters, defaults and how they were chosen.
// Every unsafe block (the SIMD kernels) says why it is sound.
#![deny(clippy::undocumented_unsafe_blocks)]
// Index loops over several parallel planes read more clearly than zips of six iterators.
#![allow(clippy::needless_range_loop)]
// `!(x > 0.0)` is deliberate: it rejects NaN as well as non-positive values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

// First: the macro it defines is used by the modules below.
#[macro_use]
mod multiversion;

mod albedo;
mod atrous;
mod atrous_fused;
mod atrous_input;
mod atrous_kernel;
mod atrous_layout;
mod atrous_pairs;
mod atrous_pipeline;
#[cfg(test)]
mod atrous_tests;
mod bilateral;
mod boxsum;
mod cholesky;
mod error;
mod fastmath;
mod gbuffer;
mod guided;
mod guided_stream;
mod jbu;
mod lookup;
mod noise;
mod outliers;
mod passthrough;
pub mod synthetic;
pub use synthetic::{synthetic_frame, SyntheticFrame};
pub mod table2;
mod temporal;

pub use albedo::{demodulate, with_demodulation, Demodulated, ALBEDO_EPS};
pub use atrous::{
    atrous, AtrousFilter, AtrousParams, B3, DEFAULT_SIGMA_LUMINANCE, DEFAULT_SIGMA_NORMAL,
    DEFAULT_SIGMA_POSITION,
};
pub use bilateral::{bilateral, BilateralParams};
pub use boxsum::box_mean;
pub use error::FilterError;
pub use fastmath::exp_neg;
pub use gbuffer::{missing_pixels, Features, Filtered};
pub use guided::{
    build_guide, guided, DepthNorm, Guide, GuideKind, GuidedParams, DEFAULT_EPS_DEPTH,
    DEFAULT_EPS_NORMAL, DEFAULT_RADIUS, MAX_GUIDE_DIMS,
};
pub use jbu::{jbu, JbuParams};
pub use lookup::{most_similar, most_similar_in_grid, neighbour_cells};
pub use noise::spatial_variance;
pub use outliers::remove_outliers;
pub use passthrough::with_passthrough;
pub use temporal::{
    motion_vectors, pinhole_view_projection, project_to_pixel, TemporalFilter, TemporalFrame,
    TemporalParams, DEFAULT_ALPHA, DEFAULT_TEMPORAL_SIGMA_LUMINANCE,
};
