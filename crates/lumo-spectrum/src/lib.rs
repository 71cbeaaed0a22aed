//! Spectral colour for lumo's spectral transport: the CIE 1931 observer and illuminant D65
//! ([`cie`]), hero-wavelength sampling of a path's wavelengths ([`Wavelengths`]), smooth
//! spectra for RGB inputs ([`upsample`], Jakob & Hanika 2019, with a coefficient table this
//! crate fits itself), piecewise-linear measured spectra ([`Tabulated`]), conductor presets
//! and dispersive glasses.
//!
//! A path carries [`HERO_LANES`] wavelengths in the lanes of the renderer's colour type: RGB
//! rendering and spectral rendering run the same code with different meanings of the lanes.
#![forbid(unsafe_code)]

pub mod cie;
mod data;
pub mod dispersion;
mod fit;
mod sigmoid;
mod table;
mod tabulated;
pub mod upsample;
mod wavelengths;

pub use data::conductors::CONDUCTORS;
pub use dispersion::Glass;
pub use sigmoid::Sigmoid;
pub use table::{coefficient_table, coefficients, CoefficientTable};
pub use tabulated::{conductor, Tabulated};
pub use wavelengths::{
    sample_visible, visible_pdf, Wavelengths, HERO_LANES, LAMBDA_MAX, LAMBDA_MIN,
};
