//! Metals: microfacet reflection with the exact conductor Fresnel term.

use glam::{Vec2, Vec3};

use lumo_scene::Roughness;
use lumo_spectrum::upsample::unbounded;

use super::{
    fresnel_conductor, mirror_sample, BsdfSample, Microfacet, SpecHit, SpectralColours,
    SMOOTH_ALPHA,
};
use crate::geometry::reflect;

/// A microfacet conductor (Mitsuba's `conductor`/`roughconductor`); α < 1e-3 on both axes is
/// a smooth mirror with the Fresnel term.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conductor {
    /// Real index per channel.
    pub eta: Vec3,
    /// Absorption per channel.
    pub k: Vec3,
    /// Microfacet distribution.
    pub mf: Microfacet,
}

/// The conductor Fresnel reflectance per channel at incidence cosine `cos`.
#[inline]
pub(super) fn conductor_fresnel(cos: f32, eta: Vec3, k: Vec3) -> Vec3 {
    Vec3::new(
        fresnel_conductor(cos, eta.x, k.x),
        fresnel_conductor(cos, eta.y, k.y),
        fresnel_conductor(cos, eta.z, k.z),
    )
}

impl Conductor {
    /// Smooth: a Dirac reflection.
    pub(super) fn is_delta(&self) -> bool {
        self.mf.max_alpha() < SMOOTH_ALPHA
    }

    /// Reflectance at normal incidence.
    pub(super) fn albedo(&self) -> Vec3 {
        conductor_fresnel(1.0, self.eta, self.k)
    }

    /// f(wo, wi)·cos θi with `wo` above the surface (0 when smooth).
    pub(super) fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let Conductor { eta, k, mf } = *self;
        if mf.max_alpha() < SMOOTH_ALPHA || wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let m = (wo + wi).normalize();
        let f = conductor_fresnel(wo.dot(m), eta, k);
        f * (mf.d(m) * mf.g1(wo, m) * mf.g1(wi, m) / (4.0 * wo.z))
    }

    /// Density of visible-normal sampling (0 when smooth).
    pub(super) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let mf = self.mf;
        if mf.max_alpha() < SMOOTH_ALPHA || wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let m = (wo + wi).normalize();
        mf.pdf_visible(wo, m) / (4.0 * wo.dot(m))
    }

    /// Reflection about a visible microfacet normal, or the mirror direction when smooth.
    pub(super) fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        let Conductor { eta, k, mf } = *self;
        if mf.max_alpha() < SMOOTH_ALPHA {
            return Some(mirror_sample(wo, conductor_fresnel(wo.z, eta, k), 1.0));
        }
        let m = mf.sample_visible(wo, u);
        let wi = reflect(wo, m);
        if wi.z <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: conductor_fresnel(wo.dot(m), eta, k) * mf.g1(wi, m),
            pdf: mf.pdf_visible(wo, m) / (4.0 * wo.dot(m)),
            delta: false,
            eta: 1.0,
        })
    }
}

impl Conductor {
    /// The scene's conductor at `hit` (its roughness read there).
    #[inline(always)]
    pub(super) fn at_hit(eta: Vec3, k: Vec3, roughness: &Roughness, hit: &SpecHit) -> Self {
        Conductor {
            eta,
            k,
            mf: Microfacet::of_roughness(roughness, Some(hit.uv)),
        }
    }

    /// η and k at a spectral path's wavelengths: measured, or the RGB values upsampled as
    /// unbounded spectra.
    #[inline]
    pub(super) fn at_wavelengths(self, c: &mut impl SpectralColours) -> Self {
        let (eta, k) = match c.conductor() {
            Some(measured) => measured,
            None => (
                unbounded(self.eta, c.wavelengths()),
                unbounded(self.k, c.wavelengths()),
            ),
        };
        Conductor { eta, k, ..self }
    }
}
