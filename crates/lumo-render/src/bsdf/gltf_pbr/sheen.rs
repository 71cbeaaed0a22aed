//! KHR_materials_sheen: a Charlie sheen lobe of colour C over the glTF BSDF (and under the
//! clear coat), layered by the extension's albedo scaling: f = f_sheen + f_base ×
//! min(1 − max(C)·E(ωo), 1 − max(C)·E(ωi)), E being the white sheen's directional albedo. The
//! scaling is symmetric in the two directions (reciprocal) and leaves each direction no more
//! than the sheen did not reflect, so a white base under a white sheen reflects at most 1.
//! Where the lobe's fitted masking lets it reflect more than 1 (smooth sheens at grazing
//! angles, see `charlie`), it is divided by max(1, E(ωo), E(ωi)) and E is read as at most 1.

use glam::{Vec2, Vec3};

use super::super::BsdfSample;
use super::charlie::{self, sheen_table, MIN_SHEEN_ROUGHNESS};
use super::GltfPbr;
use crate::geometry::cosine_hemisphere_pdf;

impl GltfPbr {
    /// This BSDF under a sheen of colour `color` (linear, negative or NaN channels read as 0)
    /// and perceptual roughness `roughness` (clamped to [0, 1]; NaN: 0; below
    /// [`MIN_SHEEN_ROUGHNESS`] it reads as that).
    pub fn with_sheen(mut self, color: Vec3, roughness: f32) -> Self {
        let clean = |c: f32| if c.is_nan() { 0.0 } else { c.max(0.0) };
        self.sheen_color = Vec3::from_array(color.to_array().map(clean));
        self.sheen_roughness = clean(roughness).clamp(MIN_SHEEN_ROUGHNESS, 1.0);
        self
    }

    /// Whether the sheen layer is on (a zero colour disables it, as the extension says).
    #[inline]
    pub(super) fn has_sheen(&self) -> bool {
        self.sheen_color.max_element() > 0.0
    }

    /// The white sheen lobe's directional albedo at cosine `cos` (may exceed 1).
    #[inline]
    fn sheen_lobe_albedo(&self, cos: f32) -> f32 {
        sheen_table().albedo(cos, self.sheen_roughness)
    }

    /// The white sheen layer's directional albedo at cosine `cos` (at most 1).
    #[inline]
    fn sheen_albedo(&self, cos: f32) -> f32 {
        self.sheen_lobe_albedo(cos).min(1.0)
    }

    /// The share of the layers below that the sheen leaves for the pair of cosines.
    #[inline]
    fn sheen_scaling(&self, cos_o: f32, cos_i: f32) -> f32 {
        let e = self.sheen_albedo(cos_o).max(self.sheen_albedo(cos_i));
        (1.0 - self.sheen_color.max_element() * e).max(0.0)
    }

    /// `wo` and `wi` turned to the upper side, `None` where they are on different sides.
    #[inline]
    fn sheen_frame(wo: Vec3, wi: Vec3) -> Option<(Vec3, Vec3)> {
        if wo.z * wi.z <= 0.0 {
            return None;
        }
        Some(if wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) })
    }

    /// f·|cos θi| of the sheen lobe alone (on the side of `wo`; the surface is two-sided).
    fn sheen_eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        Self::sheen_frame(wo, wi).map_or(Vec3::ZERO, |(o, i)| {
            let f = charlie::lobe(charlie::alpha_of(self.sheen_roughness), o, i);
            let excess = self
                .sheen_lobe_albedo(o.z)
                .max(self.sheen_lobe_albedo(i.z))
                .max(1.0);
            self.sheen_color * (f / excess)
        })
    }

    /// The density of sampling the sheen lobe (cosine-weighted on the side of `wo`).
    fn sheen_pdf(wo: Vec3, wi: Vec3) -> f32 {
        Self::sheen_frame(wo, wi).map_or(0.0, |(_, i)| cosine_hemisphere_pdf(i))
    }

    /// Probability of sampling the sheen from `wo`: its albedo against what it leaves the
    /// layers below.
    #[inline]
    fn sheen_probability(&self, wo: Vec3) -> f32 {
        let e = self.sheen_albedo(wo.z);
        let sheen = e * self.sheen_color.element_sum() / 3.0;
        let rest = self.sheen_scaling(wo.z, wo.z) * self.uncoated_albedo(wo).element_sum() / 3.0;
        if sheen + rest <= 0.0 {
            1.0
        } else {
            sheen / (sheen + rest)
        }
    }

    /// f(wo, wi)·|cos θi| of the sheen over the base BSDF.
    pub(super) fn sheened_eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !self.has_sheen() {
            return self.uncoated_eval(wo, wi);
        }
        self.sheen_eval(wo, wi) + self.uncoated_eval(wo, wi) * self.sheen_scaling(wo.z, wi.z)
    }

    /// The density of [`Self::sheened_sample`].
    pub(super) fn sheened_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !self.has_sheen() {
            return self.uncoated_pdf(wo, wi);
        }
        let p = self.sheen_probability(wo);
        p * Self::sheen_pdf(wo, wi) + (1.0 - p) * self.uncoated_pdf(wo, wi)
    }

    /// The sheen lobe (by its share of the reflected light) or the base BSDF; a Dirac sample
    /// of the base keeps its lobe's weight, scaled by what the sheen leaves it.
    pub(super) fn sheened_sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if !self.has_sheen() {
            return self.uncoated_sample(wo, u_lobe, u);
        }
        let p = self.sheen_probability(wo);
        let s = if u_lobe < p {
            let side = if wo.z < 0.0 { -1.0 } else { 1.0 };
            BsdfSample {
                wi: charlie::sample(u) * side,
                weight: Vec3::ZERO,
                pdf: 0.0,
                delta: false,
                eta: 1.0,
            }
        } else {
            let u_rest = ((u_lobe - p) / (1.0 - p)).min(1.0 - f32::EPSILON);
            let mut s = self.uncoated_sample(wo, u_rest, u)?;
            if s.delta {
                s.weight *= self.sheen_scaling(wo.z, s.wi.z) / (1.0 - p);
                s.pdf *= 1.0 - p;
                return Some(s);
            }
            s
        };
        let pdf = self.sheened_pdf(wo, s.wi);
        (pdf > 0.0).then(|| BsdfSample {
            weight: self.sheened_eval(wo, s.wi) / pdf,
            pdf,
            ..s
        })
    }

    /// The G-buffer albedo seen from `wo`: the sheen's reflectance plus what it leaves of the
    /// base's.
    pub(super) fn sheened_albedo(&self, wo: Vec3) -> Vec3 {
        let base = self.uncoated_albedo(wo);
        if !self.has_sheen() {
            return base;
        }
        self.sheen_color * self.sheen_albedo(wo.z) + base * self.sheen_scaling(wo.z, wo.z)
    }
}
