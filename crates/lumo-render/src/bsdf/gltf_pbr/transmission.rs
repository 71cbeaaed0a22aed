//! KHR_materials_transmission: the dielectric part of glTF's BSDF as a mix, by the
//! transmission factor, of the opaque dielectric (diffuse base under the specular layer) and a
//! transmissive one whose transmitted light is tinted by the base colour.
//!
//! The transmissive dielectric is either thin-walled (no KHR_materials_volume, or thickness
//! 0): the specular layer reflects F and what it does not reflect goes through the sheet
//! without bending, the rough lobe mirrored through the surface plane, as the extension
//! describes; or a volume boundary: lumo's (rough) dielectric interface of index `ior`, exact
//! Fresnel, the refracted light tinted.

use glam::{Vec2, Vec3};

use super::super::{mirror_sample, BsdfSample, Dielectric};
use super::GltfPbr;
use crate::geometry::reflect;

/// `v` mirrored through the surface plane.
#[inline]
fn flip_z(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.y, -v.z)
}

impl GltfPbr {
    /// The refracting interface of a volume boundary.
    #[inline]
    fn interface(&self) -> Dielectric {
        Dielectric {
            eta: self.eta,
            mf: self.mf,
        }
    }

    /// The thin sheet's reflectance F (the specular layer's, per channel) and the share it
    /// transmits, (1 − max F), at microfacet cosine `cos`.
    #[inline]
    fn thin_split(&self, cos: f32) -> (Vec3, f32) {
        let f = super::schlick(self.dielectric_f0, cos) * self.specular_weight;
        (f, (1.0 - f.max_element()).max(0.0))
    }

    /// Probability of choosing reflection at the sheet for microfacet cosine `cos`: its share
    /// of what the two lobes carry.
    #[inline]
    fn thin_reflect_probability(&self, cos: f32) -> f32 {
        let (f, t) = self.thin_split(cos);
        let (r, t) = (f.element_sum(), t * self.base_color.element_sum());
        if r + t <= 0.0 {
            1.0
        } else {
            r / (r + t)
        }
    }

    /// f·|cos θi| of the transmissive dielectric, `wo` on either side.
    pub(super) fn transmissive_eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !self.thin {
            let value = self.interface().eval(wo, wi);
            return if wo.z * wi.z < 0.0 {
                value * self.base_color
            } else {
                value
            };
        }
        if self.smooth() || wo.z == 0.0 || wi.z == 0.0 {
            return Vec3::ZERO;
        }
        // The sheet is the same from both sides: look from above, the transmitted direction
        // mirrored back up.
        let (wo, wi) = if wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) };
        let through = wi.z < 0.0;
        let wr = if through { flip_z(wi) } else { wi };
        let m = (wo + wr).normalize();
        let mf = self.mf;
        let lobe = mf.d(m) * mf.g1(wo, m) * mf.g1(wr, m) / (4.0 * wo.z);
        let (f, t) = self.thin_split(wo.dot(m));
        if through {
            self.base_color * (t * lobe)
        } else {
            f * lobe
        }
    }

    /// Density of [`Self::transmissive_sample`] (0 for its Dirac lobes).
    pub(super) fn transmissive_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !self.thin {
            return self.interface().pdf(wo, wi);
        }
        if self.smooth() || wo.z == 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        let (wo, wi) = if wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) };
        let through = wi.z < 0.0;
        let wr = if through { flip_z(wi) } else { wi };
        let m = (wo + wr).normalize();
        let cos = wo.dot(m);
        if cos <= 0.0 {
            return 0.0;
        }
        let p_r = self.thin_reflect_probability(cos);
        let p = if through { 1.0 - p_r } else { p_r };
        p * self.mf.pdf_visible(wo, m) / (4.0 * cos)
    }

    /// Reflection or transmission through the transmissive dielectric, `wo` on either side.
    pub(super) fn transmissive_sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if !self.thin {
            let mut s = self.interface().sample(wo, u_lobe, u)?;
            if s.wi.z * wo.z < 0.0 {
                s.weight *= self.base_color;
            }
            return Some(s);
        }
        let side = if wo.z < 0.0 { -1.0 } else { 1.0 };
        let wo_up = wo * side;
        if self.smooth() {
            let p_r = self.thin_reflect_probability(wo_up.z);
            let (f, t) = self.thin_split(wo_up.z);
            if u_lobe < p_r {
                return Some(mirror_sample(wo, f / p_r, p_r));
            }
            return Some(BsdfSample {
                wi: -wo,
                weight: self.base_color * (t / (1.0 - p_r)),
                pdf: 1.0 - p_r,
                delta: true,
                eta: 1.0,
            });
        }
        let m = self.mf.sample_visible(wo_up, u);
        let wr = reflect(wo_up, m);
        if wr.z <= 0.0 {
            return None;
        }
        let p_r = self.thin_reflect_probability(wo_up.dot(m));
        let wi = if u_lobe < p_r { wr } else { flip_z(wr) } * side;
        let pdf = self.transmissive_pdf(wo, wi);
        (pdf > 0.0).then(|| BsdfSample {
            wi,
            weight: self.transmissive_eval(wo, wi) / pdf,
            pdf,
            delta: false,
            eta: 1.0,
        })
    }
}
