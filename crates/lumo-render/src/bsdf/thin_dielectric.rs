//! A thin dielectric sheet (Mitsuba's `thindielectric`).

use glam::Vec3;

use super::{fresnel_dielectric, mirror_sample, BsdfSample};

/// A thin dielectric sheet: delta reflection and straight-through transmission, with the
/// internal bounces summed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinDielectric {
    /// Relative index of the sheet.
    pub eta: f32,
}

impl ThinDielectric {
    /// Reflection with the sheet's reflectance (chosen by `u_lobe`), else straight through.
    pub(super) fn sample(&self, wo: Vec3, u_lobe: f32) -> BsdfSample {
        let r = thin_dielectric_reflectance(wo.z.abs(), self.eta);
        if u_lobe < r {
            return mirror_sample(wo, Vec3::ONE, r);
        }
        // Straight through: the sheet's two refractions cancel.
        BsdfSample {
            wi: -wo,
            weight: Vec3::ONE,
            pdf: 1.0 - r,
            delta: true,
            eta: 1.0,
        }
    }
}

/// Reflectance of a thin dielectric sheet at incidence cosine `cos` (either side): the Fresnel
/// reflectance R of one interface with every path bouncing inside the sheet summed,
/// R + T²R(1 + R² + R⁴ + …) = R + T²R / (1 − R²) = 2R / (1 + R) with T = 1 − R; the rest
/// (1 − that) is transmitted. Mitsuba 3's `thindielectric`.
pub fn thin_dielectric_reflectance(cos: f32, eta: f32) -> f32 {
    let r = fresnel_dielectric(cos, eta).0;
    2.0 * r / (1.0 + r)
}
