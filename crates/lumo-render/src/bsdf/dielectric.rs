//! A dielectric interface: smooth (delta reflection and refraction) or rough (Walter et al.
//! 2007), Mitsuba's `dielectric`/`roughdielectric`.

use glam::{Vec2, Vec3};

use lumo_scene::Roughness;

use super::{
    fresnel_dielectric, mirror_sample, BsdfSample, Microfacet, SpecHit, SpectralColours,
    SMOOTH_ALPHA,
};
use crate::geometry::reflect;

/// A dielectric interface (α < 1e-3 on both axes: smooth).
#[derive(Clone, Copy, Debug)]
pub struct Dielectric {
    /// Relative index inside / outside.
    pub eta: f32,
    /// Microfacet distribution.
    pub mf: Microfacet,
}

impl Dielectric {
    /// Smooth: Dirac reflection and refraction.
    pub(super) fn is_delta(&self) -> bool {
        self.mf.max_alpha() < SMOOTH_ALPHA
    }

    /// f(wo, wi)·|cos θi| (0 when smooth); `wo` on either side.
    pub(super) fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if self.is_delta() || wo.z == 0.0 || wi.z == 0.0 {
            return Vec3::ZERO;
        }
        Vec3::splat(rough_dielectric(wo, wi, self.eta, self.mf).0)
    }

    /// Density of [`Dielectric::sample`] (0 when smooth).
    pub(super) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.is_delta() || wo.z == 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        rough_dielectric(wo, wi, self.eta, self.mf).1
    }

    /// Reflection with the Fresnel probability (chosen by `u_lobe`), else refraction, about
    /// the normal when smooth or a visible microfacet normal when rough.
    pub(super) fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let Dielectric { eta, mf } = *self;
        if mf.max_alpha() < SMOOTH_ALPHA {
            let (f, cos_t, _, eta_ti) = fresnel_dielectric(wo.z, eta);
            if u_lobe < f {
                return Some(mirror_sample(wo, Vec3::ONE, f));
            }
            return Some(BsdfSample {
                wi: Vec3::new(-eta_ti * wo.x, -eta_ti * wo.y, cos_t),
                weight: Vec3::splat(eta_ti * eta_ti),
                pdf: 1.0 - f,
                delta: true,
                eta: 1.0 / eta_ti,
            });
        }
        // Sample in the frame where wo is above; the microfacet normal stays in the upper
        // hemisphere so the signed cosine tells Fresnel which side wo is on.
        let side = wo.z.signum();
        let m = mf.sample_visible(wo * side, u);
        let cos_om = wo.dot(m);
        let (f, cos_t, _, eta_ti) = fresnel_dielectric(cos_om, eta);
        let (wi, crossed) = if u_lobe < f {
            (reflect(wo, m), 1.0)
        } else {
            (m * (cos_om * eta_ti + cos_t) - wo * eta_ti, 1.0 / eta_ti)
        };
        if (wi.z * wo.z > 0.0) != (u_lobe < f) {
            return None;
        }
        let (value, pdf) = rough_dielectric(wo, wi, eta, mf);
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: Vec3::splat(value / pdf),
            pdf,
            delta: false,
            eta: crossed,
        })
    }
}

/// Rough dielectric (Walter et al. 2007) value f·|cos θi| and sampling density.
fn rough_dielectric(wo: Vec3, wi: Vec3, eta: f32, g: Microfacet) -> (f32, f32) {
    let reflect = wo.z * wi.z > 0.0;
    let eta_rel = if wo.z > 0.0 { eta } else { 1.0 / eta };
    let mut m = if reflect {
        (wo + wi).normalize()
    } else {
        (wo + wi * eta_rel).normalize()
    };
    if m.z < 0.0 {
        m = -m;
    }
    if !m.is_finite() {
        return (0.0, 0.0);
    }
    let (cos_om, cos_im) = (wo.dot(m), wi.dot(m));
    // Both directions must see the microfacet from their own sides.
    if cos_om * wo.z <= 0.0 || cos_im * wi.z <= 0.0 {
        return (0.0, 0.0);
    }
    let (f, _, _, eta_ti) = fresnel_dielectric(cos_om, eta);
    let d = g.d(m);
    let gg = g.g1(wo, m) * g.g1(wi, m);
    let side = wo.z.signum();
    let pdf_m = g.pdf_visible(wo * side, m);
    if reflect {
        let value = f * d * gg / (4.0 * wo.z.abs());
        let pdf = f * pdf_m / (4.0 * cos_om.abs());
        (value, pdf)
    } else {
        let denom = cos_om + eta_rel * cos_im;
        let denom2 = denom * denom;
        let value =
            (eta_ti * eta_ti) * (1.0 - f) * d * gg * eta_rel * eta_rel * (cos_im * cos_om).abs()
                / (wo.z.abs() * denom2);
        let dwh_dwi = eta_rel * eta_rel * cos_im.abs() / denom2;
        let pdf = (1.0 - f) * pdf_m * dwh_dwi;
        (value, pdf)
    }
}

impl Dielectric {
    /// The scene's dielectric of relative index `ior` at `hit` (its roughness read there).
    #[inline(always)]
    pub(super) fn at_hit(ior: f32, roughness: &Roughness, hit: &SpecHit) -> Self {
        Dielectric {
            eta: ior,
            mf: Microfacet::of_roughness(roughness, Some(hit.uv)),
        }
    }

    /// The index at a spectral path's hero wavelength where the glass disperses.
    #[inline]
    pub(super) fn at_wavelengths(mut self, c: &mut impl SpectralColours) -> Self {
        if let Some(change) = c.dispersion() {
            self.eta += change;
        }
        self
    }
}
