//! KHR_materials_clearcoat: a GGX coat of F0 = 0.04 (index 1.5) and its own roughness over the
//! whole glTF BSDF, weighed by the clearcoat intensity c. The extension attenuates the base by
//! 1 − c·F(v·h); here, for energy conservation and reciprocity, by (1 − c·E(ωo))(1 − c·E(ωi)),
//! E being the coat's directional albedo (the glTF albedo table at F0 = 0.04): light crosses
//! the coat on the way in and out, and no direction gets back more than the coat left. The coat
//! lies over the sheen (KHR_materials_sheen), as the extensions define.
//!
//! The coat has a shading normal of its own (`coat_normal`: clearcoatNormalTexture's, or the
//! mesh's where the base has a normal map and the coat none): its lobe and the cosines of E
//! are taken in the frame of that normal, the layers below keep the base's frame. Where the
//! viewer would see the coat's normal from behind it is mirrored about the base's normal, as
//! normal maps are (`crate::shading`).

use glam::{Vec2, Vec3};

use super::super::{mirror_sample, BsdfSample, SMOOTH_ALPHA};
use super::albedo_table::{ggx_of_roughness, table};
use super::{schlick, GltfPbr, DIELECTRIC_F0};
use crate::geometry::{reflect, Basis};
use crate::shading::perturbed_frame;

/// The coat as one viewer sees it: the side of the surface the viewer is on and, where the
/// coat's normal is not the base's, the coat's frame on that side.
#[derive(Clone, Copy)]
struct CoatView {
    /// 1 where the viewer is in front of the surface, −1 behind it (the coat lies on both
    /// sides of a transmissive surface).
    side: f32,
    /// The coat's frame in the base's frame turned to the viewer's side; `None`: the base's.
    frame: Option<Basis>,
}

impl CoatView {
    /// `w` (base frame) in the coat's frame, turned to the viewer's side.
    #[inline]
    fn local(&self, w: Vec3) -> Vec3 {
        let w = w * self.side;
        self.frame.map_or(w, |f| f.to_local(w))
    }

    /// A direction in the coat's frame back in the base's frame.
    #[inline]
    fn world(&self, v: Vec3) -> Vec3 {
        self.frame.map_or(v, |f| f.to_world(v)) * self.side
    }
}

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

    /// This BSDF with the coat's shading normal `normal` (unit, in the frame of the
    /// directions the BSDF is given; z = the base's normal). A normal not above the surface
    /// plane or not finite leaves the coat in the base's frame.
    pub fn with_coat_normal(mut self, normal: Vec3) -> Self {
        self.coat_normal = match normal.try_normalize() {
            Some(n) if n.z > 0.0 => n,
            _ => Vec3::Z,
        };
        self
    }

    /// The coat as viewer `wo` sees it.
    #[inline]
    fn coat_view(&self, wo: Vec3) -> CoatView {
        let side = if wo.z < 0.0 { -1.0 } else { 1.0 };
        if self.coat_normal == Vec3::Z {
            return CoatView { side, frame: None };
        }
        let n = self.coat_normal;
        // Seen from behind, the normal is mirrored about the base's (as a normal map's).
        let n = if (wo * side).dot(n) <= 0.0 {
            Vec3::new(-n.x, -n.y, n.z)
        } else {
            n
        };
        CoatView {
            side,
            frame: Some(perturbed_frame(n)),
        }
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

    /// Probability of sampling the coat from `wo` (`co` in the coat's frame): its albedo
    /// against what it leaves the rest.
    #[inline]
    fn coat_probability(&self, wo: Vec3, co: Vec3) -> f32 {
        let t = self.coat_transmittance(co.z);
        let coat = 1.0 - t;
        let rest = t * self.sheened_albedo(wo).element_sum() / 3.0;
        if coat + rest <= 0.0 {
            1.0
        } else {
            coat / (coat + rest)
        }
    }

    /// `wo` and `wi` in the coat's frame of `view`: `None` where `wi` is on the other side
    /// of the surface or of the coat (the coat only reflects).
    #[inline]
    fn coat_dirs(view: &CoatView, wo: Vec3, wi: Vec3) -> Option<(Vec3, Vec3)> {
        if wo.z * wi.z <= 0.0 {
            return None;
        }
        let (co, ci) = (view.local(wo), view.local(wi));
        (co.z > 0.0 && ci.z > 0.0).then_some((co, ci))
    }

    /// f·|cos θi| of the coat lobe alone, from the coat's frame directions.
    fn coat_eval(&self, dirs: Option<(Vec3, Vec3)>) -> Vec3 {
        let Some((wo, wi)) = dirs.filter(|_| !self.coat_smooth()) else {
            return Vec3::ZERO;
        };
        let mf = self.coat_mf;
        let m = (wo + wi).normalize();
        let f = schlick(Vec3::splat(DIELECTRIC_F0), wo.dot(m)) * self.clearcoat;
        f * (mf.d(m) * mf.g1(wo, m) * mf.g1(wi, m) / (4.0 * wo.z))
    }

    /// Density of sampling the coat lobe's visible normals (a rotation to the coat's frame
    /// keeps solid angles).
    fn coat_pdf(&self, dirs: Option<(Vec3, Vec3)>) -> f32 {
        let Some((wo, wi)) = dirs.filter(|_| !self.coat_smooth()) else {
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
        let view = self.coat_view(wo);
        let (co, ci) = (view.local(wo), view.local(wi));
        let through = self.coat_transmittance(co.z) * self.coat_transmittance(ci.z);
        self.coat_eval(Self::coat_dirs(&view, wo, wi)) + self.sheened_eval(wo, wi) * through
    }

    /// The density of [`Self::sample`].
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.clearcoat <= 0.0 {
            return self.sheened_pdf(wo, wi);
        }
        let view = self.coat_view(wo);
        let p = self.coat_probability(wo, view.local(wo));
        p * self.coat_pdf(Self::coat_dirs(&view, wo, wi)) + (1.0 - p) * self.sheened_pdf(wo, wi)
    }

    /// The coat (by its share of the reflected light) or what lies under it.
    pub(crate) fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if self.clearcoat <= 0.0 {
            return self.sheened_sample(wo, u_lobe, u);
        }
        let view = self.coat_view(wo);
        let co = view.local(wo);
        let p = self.coat_probability(wo, co);
        let s = if u_lobe < p {
            if co.z <= 0.0 {
                return None;
            }
            if self.coat_smooth() {
                let f = schlick(Vec3::splat(DIELECTRIC_F0), co.z) * self.clearcoat;
                let s = mirror_sample(co, f / p, p);
                let wi = view.world(s.wi);
                // A mirror direction below the surface is lost.
                return (wi.z * wo.z > 0.0).then_some(BsdfSample { wi, ..s });
            }
            let ci = reflect(co, self.coat_mf.sample_visible(co, u));
            let wi = view.world(ci);
            if ci.z <= 0.0 || wi.z * wo.z <= 0.0 {
                return None;
            }
            BsdfSample {
                wi,
                weight: Vec3::ZERO,
                pdf: 0.0,
                delta: false,
                eta: 1.0,
            }
        } else {
            let u_rest = ((u_lobe - p) / (1.0 - p)).min(1.0 - f32::EPSILON);
            let mut s = self.sheened_sample(wo, u_rest, u)?;
            if s.delta {
                let ci = view.local(s.wi);
                let through = self.coat_transmittance(co.z) * self.coat_transmittance(ci.z);
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
        let t = self.coat_transmittance(self.coat_view(wo).local(wo).z);
        Vec3::splat(1.0 - t) + rest * t
    }
}
