//! The À-Trous parameters, their defaults (chosen by the sweep in docs/filters.md) and the
//! checks every call makes of its images and parameters.

use lumo_image::Image;

use crate::common::error::param;
use crate::common::gbuffer::{check_color, check_features, Features};
use crate::FilterError;

/// The B3 spline taps (1/16, 1/4, 3/8, 1/4, 1/16); the 5×5 kernel is their outer product.
pub const B3: [f32; 5] = [1.0 / 16.0, 1.0 / 4.0, 3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0];

/// Parameters of [`atrous`](crate::atrous()). A `None` sigma switches that edge weight off
/// (the paper's Table 2 times 0–3 weights).
#[derive(Clone, Debug, PartialEq)]
pub struct AtrousParams {
    /// Number of à-trous levels; level i uses taps 2^i pixels apart (5 → 125 px footprint).
    pub iterations: usize,
    /// Colour σ when no variance plane is used: in units of the image's mean luminance, halved
    /// every iteration (paper). Off by default: on 1–4 spp heavy-tailed noise it keeps
    /// fireflies and dark speckles apart from their neighbours (see docs/filters.md).
    pub sigma_color: Option<f32>,
    /// Variance-guided colour σ (SVGF's σ_l), used instead of `sigma_color` when
    /// `features.variance` is given and `use_variance` is set: the luminance distance is divided
    /// by σ_l·sqrt(3×3 Gaussian of the variance) + ε. Not halved: the variance itself shrinks as
    /// it is filtered (with squared weights).
    pub sigma_luminance: Option<f32>,
    /// Normal σ (normals in [-1,1]); the distance is divided by stepwidth² as in the paper.
    pub sigma_normal: Option<f32>,
    /// Position σ in units of the scene's extent (diagonal of the positions' bounding box).
    pub sigma_position: Option<f32>,
    /// Sparse input: only pixels with x % n == 0 and y % n == 0 are valid (n = 1, 2 or 4); the
    /// rest is in-painted, and the colour weight is skipped for the first log2(n) iterations.
    pub sparse: usize,
    /// Filter colour / albedo and multiply back (needs `features.albedo`).
    pub demodulate: bool,
    /// Use `features.variance` (if given) to steer the colour weight, as SVGF does.
    pub use_variance: bool,
}

impl Default for AtrousParams {
    /// Defaults chosen by the sweep in docs/filters.md.
    fn default() -> Self {
        Self {
            iterations: 5,
            sigma_color: None,
            sigma_luminance: Some(DEFAULT_SIGMA_LUMINANCE),
            sigma_normal: Some(DEFAULT_SIGMA_NORMAL),
            sigma_position: Some(DEFAULT_SIGMA_POSITION),
            sparse: 1,
            demodulate: false,
            use_variance: true,
        }
    }
}

/// Default variance-guided σ_l (multiplies the local luminance standard deviation): the best
/// value with `spatial_variance` on real 1- and 4-spp renders (docs/filters.md, "Validation on
/// the renderer"); the synthetic sweep had picked 64.
pub const DEFAULT_SIGMA_LUMINANCE: f32 = 16.0;
/// Default normal σ, see docs/filters.md.
pub const DEFAULT_SIGMA_NORMAL: f32 = 0.3;
/// Default position σ (fraction of the scene extent), see docs/filters.md.
pub const DEFAULT_SIGMA_POSITION: f32 = 0.1;

/// Keeps variance-guided weights finite where the variance is 0 (relative to mean luminance).
pub(super) const VARIANCE_EPS: f32 = 1e-6;

/// Checks the images and parameters of one call.
pub(super) fn validate(
    color: &Image,
    features: &Features,
    params: &AtrousParams,
) -> Result<(), FilterError> {
    check_color("color", color)?;
    check_features(features, color.width, color.height)?;
    if params.iterations == 0 || params.iterations > 16 {
        return Err(param(
            "iterations",
            format!("{} (use 1..=16)", params.iterations),
        ));
    }
    if ![1, 2, 4].contains(&params.sparse) {
        return Err(param(
            "sparse",
            format!("{} (use 1, 2 or 4)", params.sparse),
        ));
    }
    for (name, s) in [
        ("sigma_color", params.sigma_color),
        ("sigma_luminance", params.sigma_luminance),
        ("sigma_normal", params.sigma_normal),
        ("sigma_position", params.sigma_position),
    ] {
        if let Some(s) = s {
            if !(s > 0.0) {
                return Err(param(name, format!("{s} (must be > 0, or off)")));
            }
        }
    }
    if params.sigma_normal.is_some() && features.normal.is_none() {
        return Err(FilterError::MissingFeature {
            filter: "the À-Trous normal weight",
            needs: "a normal plane".into(),
        });
    }
    if params.sigma_position.is_some() && features.position.is_none() {
        return Err(FilterError::MissingFeature {
            filter: "the À-Trous position weight",
            needs: "a position plane".into(),
        });
    }
    if params.demodulate && features.albedo.is_none() {
        return Err(FilterError::MissingFeature {
            filter: "albedo demodulation",
            needs: "an albedo plane".into(),
        });
    }
    Ok(())
}
