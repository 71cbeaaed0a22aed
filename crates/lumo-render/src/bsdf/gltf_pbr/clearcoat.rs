//! KHR_materials_clearcoat: a GGX coat of F0 = 0.04 (index 1.5) and its own roughness over the
//! whole glTF BSDF, weighed by the clearcoat intensity c. The extension attenuates the base by
//! 1 − c·F(v·h); here, for energy conservation and reciprocity, by (1 − c·E(ωo))(1 − c·E(ωi)),
//! E being the coat's directional albedo (the glTF albedo table at F0 = 0.04): light crosses
//! the coat on the way in and out, and no direction gets back more than the coat left. The coat
//! lies over the sheen (KHR_materials_sheen), as the extensions define.

use glam::{Vec2, Vec3};

use super::super::{mirror_sample, BsdfSample, SMOOTH_ALPHA};
use super::albedo_table::{ggx_of_roughness, table};
use super::{schlick, GltfPbr, DIELECTRIC_F0};
use crate::geometry::reflect;

impl GltfPbr {
    /// This BSDF under a clear coat of intensity `clearcoat` and perceptual roughness
    /// `roughness` (both clamped to [0, 1]; NaN: 0).
    pub fn with_clearcoat(mut self, clearcoat: f32, roughness: f32) -> Self {
        let unit = |x: f32| if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
        self.clearcoat = unit(clearcoat);
        self.clearcoat_roughness = unit(roughness);
        self.coat_mf = ggx_of_roughness(self.clearcoat_roughness);
        self
    }

    /// The share of the light crossing the coat at cosine `cos`: 1 − c·E(|cos|).
    #[inline]
    fn coat_transmittance(&self, cos: f32) -> f32 {
        let e = table().albedo(cos.abs().min(1.0), self.clearcoat_roughness, DIELECTRIC_F0);
        (1.0 - self.clearcoat * e).max(0.0)
    }

    /// Whether the coat is a Dirac mirror.
    #[inline]
    fn coat_smooth(&self) -> bool {
        self.coat_mf.max_alpha() < SMOOTH_ALPHA
    }

    /// Probability of sampling the coat from `wo`: its albedo against what it leaves the
    /// rest.
    #[inline]
    fn coat_probability(&self, wo: Vec3) -> f32 {
        let coat = 1.0 - self.coat_transmittance(wo.z);
        let rest = self.coat_transmittance(wo.z) * self.sheened_albedo(wo).element_sum() / 3.0;
        if coat + rest <= 0.0 {
            1.0
        } else {
            coat / (coat + rest)
        }
    }

    /// `wo` and `wi` seen from `wo`'s side (the coat lies on both sides of a transmissive
    /// surface); `None` where `wi` is on the other side.
    #[inline]
    fn coat_frame(wo: Vec3, wi: Vec3) -> Option<(Vec3, Vec3)> {
        if wo.z * wi.z <= 0.0 {
            return None;
        }
        Some(if wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) })
    }

    /// f·|cos θi| of the coat lobe alone.
    fn coat_eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let Some((wo, wi)) = Self::coat_frame(wo, wi).filter(|_| !self.coat_smooth()) else {
            return Vec3::ZERO;
        };
        let mf = self.coat_mf;
        let m = (wo + wi).normalize();
        let f = schlick(Vec3::splat(DIELECTRIC_F0), wo.dot(m)) * self.clearcoat;
        f * (mf.d(m) * mf.g1(wo, m) * mf.g1(wi, m) / (4.0 * wo.z))
    }

    /// Density of sampling the coat lobe's visible normals.
    fn coat_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some((wo, wi)) = Self::coat_frame(wo, wi).filter(|_| !self.coat_smooth()) else {
            return 0.0;
        };
        let m = (wo + wi).normalize();
        let cos = wo.dot(m);
        if cos <= 0.0 {
            return 0.0;
        }
        self.coat_mf.pdf_visible(wo, m) / (4.0 * cos)
    }

    /// f(wo, wi)·|cos θi| with the coat (where there is one).
    pub(crate) fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if self.clearcoat <= 0.0 {
            return self.sheened_eval(wo, wi);
        }
        let through = self.coat_transmittance(wo.z) * self.coat_transmittance(wi.z);
        self.coat_eval(wo, wi) + self.sheened_eval(wo, wi) * through
    }

    /// The density of [`Self::sample`].
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.clearcoat <= 0.0 {
            return self.sheened_pdf(wo, wi);
        }
        let p = self.coat_probability(wo);
        p * self.coat_pdf(wo, wi) + (1.0 - p) * self.sheened_pdf(wo, wi)
    }

    /// The coat (by its share of the reflected light) or what lies under it.
    pub(crate) fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if self.clearcoat <= 0.0 {
            return self.sheened_sample(wo, u_lobe, u);
        }
        let p = self.coat_probability(wo);
        let s = if u_lobe < p {
            let side = if wo.z < 0.0 { -1.0 } else { 1.0 };
            if self.coat_smooth() {
                let f = schlick(Vec3::splat(DIELECTRIC_F0), wo.z.abs()) * self.clearcoat;
                return Some(mirror_sample(wo, f / p, p));
            }
            let wo_up = wo * side;
            let wi = reflect(wo_up, self.coat_mf.sample_visible(wo_up, u));
            if wi.z <= 0.0 {
                return None;
            }
            BsdfSample {
                wi: wi * side,
                weight: Vec3::ZERO,
                pdf: 0.0,
                delta: false,
                eta: 1.0,
            }
        } else {
            let u_rest = ((u_lobe - p) / (1.0 - p)).min(1.0 - f32::EPSILON);
            let mut s = self.sheened_sample(wo, u_rest, u)?;
            if s.delta {
                let through = self.coat_transmittance(wo.z) * self.coat_transmittance(s.wi.z);
                s.weight *= through / (1.0 - p);
                s.pdf *= 1.0 - p;
                return Some(s);
            }
            s
        };
        let pdf = self.pdf(wo, s.wi);
        (pdf > 0.0).then(|| BsdfSample {
            weight: self.eval(wo, s.wi) / pdf,
            pdf,
            ..s
        })
    }

    /// The G-buffer albedo seen from `wo`: the coat's reflectance plus what it lets through
    /// of the rest's.
    pub(crate) fn albedo(&self, wo: Vec3) -> Vec3 {
        let rest = self.sheened_albedo(wo);
        if self.clearcoat <= 0.0 {
            return rest;
        }
        let t = self.coat_transmittance(wo.z);
        Vec3::splat(1.0 - t) + rest * t
    }
}
