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
//! - [`auto()`]: guided filters at several radii blended per pixel by a leave-one-out error
//!   estimate (the default of `lumo denoise`).
//! - [`most_similar`]: the geometry-aware lookup of Bauszat et al. (eqs 3–5).
//! - [`TemporalFilter`]: spatiotemporal variance-guided filtering (SVGF, Schied et al. 2017),
//!   the one stateful filter: reprojected, accumulated history + the variance-guided À-Trous;
//!   [`motion_vectors`] computes its motion vectors for a static scene and a moving camera,
//!   [`object_motion_vectors`] for objects that move too, [`surface_motion_vectors`] for
//!   surfaces that deform.
//!
//! Every filter is also a [`Denoiser`] (one interface: a [`FilterInput`] in, [`Filtered`] out,
//! parameters held by the denoiser, one [`FilterError`]), and [`FILTERS`] lists them all: the
//! one list that the command line and the benchmarks use.
//!
//! Colour images have 3 channels. Non-finite colour pixels are treated as missing (weight 0);
//! results are always finite and report how many pixels were missing.
//! See docs/filters.md for parameters, defaults and how they were chosen.
//!
//! Layout: one folder or file per filter (`atrous/`, `auto/`, `guided/`, `bilateral.rs`,
//! `jbu.rs`, `temporal/`), the interface and the list in `denoiser.rs`, what the filters share in
//! `common/`, benchmark inputs in `bench/`. This file only declares the modules and
//! re-exports their public items.
// Every unsafe block (the SIMD kernels) says why it is sound.
#![deny(clippy::undocumented_unsafe_blocks)]
// Index loops over several parallel planes read more clearly than zips of six iterators.
#![allow(clippy::needless_range_loop)]
// `!(x > 0.0)` is deliberate: it rejects NaN as well as non-positive values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

// lumo-simd's `multiversion!` macro, used by the filters' loops.
#[macro_use]
extern crate lumo_simd;

mod common;

mod atrous;
mod auto;
mod bench;
mod bilateral;
mod denoiser;
mod guided;
mod jbu;
mod temporal;

pub use atrous::{
    atrous, AtrousDenoiser, AtrousFilter, AtrousParams, B3, DEFAULT_SIGMA_LUMINANCE,
    DEFAULT_SIGMA_NORMAL, DEFAULT_SIGMA_POSITION,
};
pub use auto::{auto, AutoDenoiser, AutoParams};
pub use bench::synthetic::{synthetic_frame, SyntheticFrame};
pub use bench::{synthetic, table2};
pub use bilateral::{bilateral, BilateralDenoiser, BilateralParams};
pub use common::albedo::{
    albedo_passes_through, demodulate, surface_albedo, with_demodulation, Demodulated, ALBEDO_EPS,
};
pub use common::boxsum::box_mean;
pub use common::emitters::{detect_emitters, EmitterMask, EmitterParams};
pub use common::error::FilterError;
pub use common::fastmath::exp_neg;
pub use common::gbuffer::{check_depth_plane, missing_pixels, Features, Filtered};
pub use common::noise::spatial_variance;
pub use common::outliers::remove_outliers;
pub use common::passthrough::{with_emitted, with_hidden, with_passthrough};
pub use denoiser::{Denoiser, FilterInfo, FilterInput, FilterKind, Shape, FILTERS};
pub use guided::{
    build_guide, guided, most_similar, most_similar_in_grid, neighbour_cells, DepthNorm, Guide,
    GuideKind, GuidedDenoiser, GuidedParams, DEFAULT_EPS_DEPTH, DEFAULT_EPS_NORMAL, DEFAULT_RADIUS,
    MAX_GUIDE_DIMS,
};
pub use jbu::{jbu, JbuDenoiser, JbuParams};
pub use temporal::{
    motion_vectors, object_motion, object_motion_vectors, pinhole_view_projection,
    project_to_pixel, surface_motion_vectors, Resample, ShadingChange, TemporalAntialias,
    TemporalFilter, TemporalFrame, TemporalParams, DEFAULT_ALPHA, DEFAULT_TAA_ALPHA,
    DEFAULT_TAA_GAMMA, DEFAULT_TEMPORAL_SIGMA_LUMINANCE, NO_OBJECT,
};
