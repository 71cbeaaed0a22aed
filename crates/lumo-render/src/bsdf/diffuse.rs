//! Lambertian reflection.

use glam::{Vec2, Vec3};

use lumo_scene::Texture;

use super::{BsdfSample, SpecHit, SpectralColours};
use crate::geometry::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};

/// Lambertian reflection (Mitsuba's `diffuse`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Diffuse {
    /// Reflectance.
    pub albedo: Vec3,
}

impl Diffuse {
    /// f(wo, wi)·cos θi with `wo` above the surface.
    pub(super) fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        self.albedo * cosine_hemisphere_pdf(wi)
    }

    /// Cosine-weighted hemisphere density.
    pub(super) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 {
            0.0
        } else {
            cosine_hemisphere_pdf(wi)
        }
    }

    /// A cosine-weighted direction; the weight is the albedo.
    pub(super) fn sample(&self, u: Vec2) -> BsdfSample {
        let wi = square_to_cosine_hemisphere(u);
        BsdfSample {
            wi,
            weight: self.albedo,
            pdf: cosine_hemisphere_pdf(wi),
            delta: false,
            eta: 1.0,
        }
    }
}

impl Diffuse {
    /// The scene's diffuse `reflectance` at `hit`, tinted by the surface's colour.
    #[inline(always)]
    pub(super) fn at_hit(reflectance: &Texture, hit: &SpecHit) -> Self {
        Diffuse {
            albedo: hit.texture(reflectance) * hit.color,
        }
    }

    /// The albedo at a spectral path's wavelengths.
    #[inline]
    pub(super) fn at_wavelengths(self, c: &mut impl SpectralColours) -> Self {
        Diffuse {
            albedo: c.base(self.albedo),
        }
    }
}
