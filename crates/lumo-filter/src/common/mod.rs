//! What every filter shares: the feature planes and their checks, the typed error, albedo
//! demodulation, pass-through pixels and finding them without an emission plane, box means, the spatial noise estimate and outlier
//! removal. (The fast `exp` and the `multiversion!` macro live in lumo-simd, shared with the
//! renderer.)
//!
//! Unlike a filter's folder, whose helpers are `pub(super)`, these are `pub(crate)`: they are
//! used by several filters.

/// Branch-free fast math (lumo-simd's), under the path the filters have always used.
pub(crate) use lumo_simd::fastmath;

pub(crate) mod albedo;
pub(crate) mod boxsum;
pub(crate) mod emitters;
pub(crate) mod error;
pub(crate) mod gbuffer;
pub(crate) mod noise;
pub(crate) mod nonnegative;
pub(crate) mod outliers;
pub(crate) mod passthrough;
pub(crate) mod transpose;
pub(crate) mod zeroed;
