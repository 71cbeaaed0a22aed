//! What every filter shares: the feature planes and their checks, the typed error, albedo
//! demodulation, pass-through pixels, box means, the spatial noise estimate, outlier removal,
//! the fast `exp` and the `multiversion!` macro.
//!
//! Unlike a filter's folder, whose helpers are `pub(super)`, these are `pub(crate)`: they are
//! used by several filters. `multiversion!` and `fastmath` are self-contained (no use of the
//! rest of the crate), so that they can move into a shared SIMD crate as they are.

// First: the macro it defines is used by the modules below (and, through `#[macro_use]` on
// this module in lib.rs, by the filters).
#[macro_use]
pub(crate) mod multiversion;

pub(crate) mod albedo;
pub(crate) mod boxsum;
pub(crate) mod error;
pub(crate) mod fastmath;
pub(crate) mod gbuffer;
pub(crate) mod noise;
pub(crate) mod outliers;
pub(crate) mod passthrough;
