//! glTF 2.0's metallic-roughness material (the core specification's Appendix B): a mix, by
//! `metallic`, of a metal (GGX specular tinted by the base colour through Schlick's Fresnel) and
//! a dielectric (a Lambertian base colour under a GGX specular layer with F0 = 0.04).
//! KHR_materials_ior and KHR_materials_specular change the dielectric layer's Fresnel term:
//! F = w·(F0 + (1 − F0)(1 − cos)⁵) with F0 = min(((ior − 1)/(ior + 1))²·specular colour, 1) and
//! w the specular weight (the layer's reflectance at grazing angles, F90).
//!
//! One deviation from Appendix B, for energy conservation: the spec weighs the dielectric's
//! diffuse lobe by 1 − F(v·h), which makes a white base reflect more than it receives at grazing
//! views (the specular layer's reflection there is not taken from the diffuse lobe's share).
//! Here the diffuse lobe is weighed by (1 − E(ωo))(1 − E(ωi)) / (1 − E_avg), E being the
//! specular layer's directional albedo (tabulated over view cosine and roughness) and E_avg its
//! cosine-weighted mean: reciprocal, and a white dielectric reflects exactly what it receives.
//! Cycles' Principled BSDF, which Blender's glTF importer maps glTF materials to, also takes the
//! diffuse lobe's weight from the specular layer's albedo.

mod albedo_table;
mod charlie;
mod clearcoat;
mod sheen;
mod spec;
mod transmission;

use glam::{Vec2, Vec3};

use super::{mirror_sample, BsdfSample, Microfacet, SMOOTH_ALPHA};
use crate::geometry::{cosine_hemisphere_pdf, reflect, square_to_cosine_hemisphere};
use albedo_table::{ggx_of_roughness, schlick_weight, table};

/// The dielectric's reflectance at normal incidence without KHR_materials_ior (index 1.5).
const DIELECTRIC_F0: f32 = 0.04;

/// glTF's metallic-roughness BSDF at one surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GltfPbr {
    /// Base colour (texture × factor × vertex colour): the diffuse colour of the dielectric
    /// and the normal-incidence reflectance of the metal.
    pub base_color: Vec3,
    /// Metalness in [0, 1].
    pub metallic: f32,
    /// Perceptual roughness in [0, 1]; the GGX α is its square.
    pub roughness: f32,
    /// GGX of α = roughness².
    pub mf: Microfacet,
    /// The dielectric layer's reflectance at normal incidence, before `specular_weight`:
    /// min(((ior − 1)/(ior + 1))² × specular colour, 1) (0.04 without extensions).
    pub dielectric_f0: Vec3,
    /// KHR_materials_specular's weight of the dielectric layer (its reflectance at grazing
    /// angles), in [0, 1]; 1 without the extension.
    pub specular_weight: f32,
    /// KHR_materials_transmission's factor in [0, 1]: the share of the dielectric part that
    /// transmits (tinted by the base colour) instead of reflecting diffusely; 0 without it.
    pub transmission: f32,
    /// Whether the transmission goes through a thin sheet (no bending) rather than into a
    /// volume (refraction of index `eta`).
    pub thin: bool,
    /// Relative index of the volume a non-thin transmission refracts into (≥ 1).
    pub eta: f32,
    /// KHR_materials_clearcoat's intensity in [0, 1]: the weight of a GGX coat of F0 = 0.04
    /// over everything else; 0 without it.
    pub clearcoat: f32,
    /// The coat's perceptual roughness in [0, 1].
    pub clearcoat_roughness: f32,
    /// GGX of α = clearcoat roughness².
    pub coat_mf: Microfacet,
    /// The coat's shading normal (unit, above the surface) in the frame of the directions
    /// the BSDF is given: `Vec3::Z` where it is the base's normal.
    pub coat_normal: Vec3,
    /// KHR_materials_sheen's colour (linear, ≥ 0): the tint of a Charlie sheen layer under
    /// the coat; zero without it, which disables the layer.
    pub sheen_color: Vec3,
    /// The sheen's perceptual roughness in [0.07, 1] (α = its square).
    pub sheen_roughness: f32,
}

/// Schlick's Fresnel approximation with reflectance `f0` at normal incidence.
#[inline]
pub(super) fn schlick(f0: Vec3, cos: f32) -> Vec3 {
    f0 + (Vec3::ONE - f0) * schlick_weight(cos)
}

/// The normal-incidence reflectance of a dielectric of index `ior` against air (1 at ior = 0,
/// which KHR_materials_specular allows for converted specular-glossiness materials).
fn dielectric_f0_of_ior(ior: f32) -> f32 {
    let r = (ior - 1.0) / (ior + 1.0);
    if r.is_finite() {
        r * r
    } else {
        1.0
    }
}

impl GltfPbr {
    /// The BSDF of a texel's base colour, metallic and roughness, clamped to [0, 1] (NaN:
    /// a non-metal, fully rough).
    pub fn new(base_color: Vec3, metallic: f32, roughness: f32) -> Self {
        let unit = |x: f32, nan: f32| if x.is_nan() { nan } else { x.clamp(0.0, 1.0) };
        let (metallic, roughness) = (unit(metallic, 0.0), unit(roughness, 1.0));
        Self {
            base_color: Vec3::from_array(base_color.to_array().map(|c| unit(c, 0.0))),
            metallic,
            roughness,
            mf: ggx_of_roughness(roughness),
            dielectric_f0: Vec3::splat(DIELECTRIC_F0),
            specular_weight: 1.0,
            transmission: 0.0,
            thin: true,
            eta: 1.5,
            clearcoat: 0.0,
            clearcoat_roughness: 0.0,
            coat_mf: Microfacet::ggx(0.0),
            coat_normal: Vec3::Z,
            sheen_color: Vec3::ZERO,
            sheen_roughness: 1.0,
        }
    }

    /// This BSDF with KHR_materials_transmission's factor `transmission` (clamped to [0, 1],
    /// NaN: 0), through a thin sheet or into a volume of index `ior` (read as 1 where it is
    /// below 1 or not a number: such a volume does not bend light).
    pub fn with_transmission(mut self, transmission: f32, thin: bool, ior: f32) -> Self {
        self.transmission = if transmission.is_nan() {
            0.0
        } else {
            transmission.clamp(0.0, 1.0)
        };
        self.thin = thin;
        self.eta = if ior >= 1.0 && ior.is_finite() {
            ior
        } else {
            1.0
        };
        self
    }

    /// The weight of the transmissive dielectric in the whole mix: (1 − metallic) ×
    /// transmission.
    #[inline]
    pub(crate) fn transmission_weight(&self) -> f32 {
        (1.0 - self.metallic) * self.transmission
    }

    /// The rest of the mix, the opaque BSDF: metal and opaque dielectric renormalised to
    /// 1 − transmission weight (its metalness m / (1 − w)).
    #[inline]
    fn opaque_part(&self, w: f32) -> Self {
        Self {
            metallic: if w < 1.0 {
                (self.metallic / (1.0 - w)).min(1.0)
            } else {
                1.0
            },
            transmission: 0.0,
            ..*self
        }
    }

    /// This BSDF with KHR_materials_ior's `ior` and KHR_materials_specular's `weight`
    /// (specularFactor × specularTexture's alpha) and `color` (specularColorFactor ×
    /// specularColorTexture): F0 = min(F0(ior) × color, 1), scaled with F90 by the weight.
    /// Out-of-range values are clamped (NaN: the extensions' defaults).
    pub fn with_specular(mut self, ior: f32, weight: f32, color: Vec3) -> Self {
        let f0 = if ior.is_nan() {
            DIELECTRIC_F0
        } else {
            dielectric_f0_of_ior(ior.max(0.0))
        };
        let color = Vec3::from_array(color.to_array().map(|c| if c.is_nan() { 1.0 } else { c }));
        self.dielectric_f0 = (color.max(Vec3::ZERO) * f0).min(Vec3::ONE);
        self.specular_weight = if weight.is_nan() {
            1.0
        } else {
            weight.clamp(0.0, 1.0)
        };
        self
    }

    /// Whether the specular lobes are Dirac deltas.
    #[inline]
    pub(super) fn smooth(&self) -> bool {
        self.mf.max_alpha() < SMOOTH_ALPHA
    }

    /// Smooth and without a diffuse lobe (fully metallic, or fully transmissive where not
    /// metallic): nothing but Dirac lobes.
    pub(super) fn is_delta(&self) -> bool {
        let coat_delta = self.clearcoat <= 0.0 || self.coat_mf.max_alpha() < SMOOTH_ALPHA;
        coat_delta
            && !self.has_sheen()
            && self.smooth()
            && (1.0 - self.metallic) * (1.0 - self.transmission) <= 0.0
    }

    /// The specular Fresnel term of the mix at microfacet cosine `cos`: the dielectric
    /// layer's and the metal's (F0 = base colour), weighed by metalness.
    #[inline]
    fn specular_fresnel(&self, cos: f32) -> Vec3 {
        let m = self.metallic;
        schlick(self.dielectric_f0, cos) * (self.specular_weight * (1.0 - m))
            + schlick(self.base_color, cos) * m
    }

    /// The dielectric layer's directional albedo from cosine `cos` for its largest channel:
    /// the share of the light the diffuse lobe below does not get.
    #[inline]
    fn layer_albedo(&self, cos: f32) -> f32 {
        let f0 = self.dielectric_f0.max_element();
        self.specular_weight * table().albedo(cos, self.roughness, f0)
    }

    /// The diffuse lobe's factor besides base/π·cos θi: (1 − metallic) and the share the
    /// specular layer leaves for it.
    #[inline]
    fn diffuse_weight(&self, cos_o: f32, cos_i: f32) -> f32 {
        let f0 = self.dielectric_f0.max_element();
        let rest = 1.0 - self.specular_weight * table().average(self.roughness, f0);
        // A layer that reflects everything (F0 = 1) leaves nothing below it.
        if rest <= 1e-6 {
            return 0.0;
        }
        let (e_o, e_i) = (self.layer_albedo(cos_o), self.layer_albedo(cos_i));
        (1.0 - self.metallic) * (1.0 - e_o).max(0.0) * (1.0 - e_i).max(0.0) / rest
    }

    /// f(wo, wi)·|cos θi|: the opaque part (two-sided) and the transmissive one mixed.
    pub(super) fn uncoated_eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let w = self.transmission_weight();
        if w <= 0.0 {
            return self.opaque_eval(wo, wi);
        }
        let (o, i) = if wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) };
        self.opaque_part(w).opaque_eval(o, i) * (1.0 - w) + self.transmissive_eval(wo, wi) * w
    }

    /// The mixture density of the opaque and transmissive parts.
    pub(super) fn uncoated_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let w = self.transmission_weight();
        if w <= 0.0 {
            return self.opaque_pdf(wo, wi);
        }
        let (o, i) = if wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) };
        self.opaque_part(w).opaque_pdf(o, i) * (1.0 - w) + self.transmissive_pdf(wo, wi) * w
    }

    /// The transmissive part with probability w (the transmission weight), else the opaque
    /// one; a sample off a Dirac lobe keeps its lobe's weight, any other is weighed by the
    /// whole mixture.
    pub(super) fn uncoated_sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let w = self.transmission_weight();
        if w <= 0.0 {
            return self.opaque_sample(wo, u_lobe, u);
        }
        let mut s = if u_lobe < w {
            let mut s = self.transmissive_sample(wo, u_lobe / w, u)?;
            s.pdf *= w;
            s
        } else {
            let side = if wo.z < 0.0 { -1.0 } else { 1.0 };
            let u_rest = ((u_lobe - w) / (1.0 - w)).min(1.0 - f32::EPSILON);
            let mut s = self.opaque_part(w).opaque_sample(wo * side, u_rest, u)?;
            s.wi *= side;
            s.pdf *= 1.0 - w;
            s
        };
        if !s.delta {
            s.pdf = self.uncoated_pdf(wo, s.wi);
            if s.pdf <= 0.0 {
                return None;
            }
            s.weight = self.uncoated_eval(wo, s.wi) / s.pdf;
        }
        Some(s)
    }

    /// f(wo, wi)·cos θi of the opaque BSDF with `wo` above the surface.
    fn opaque_eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let mut value =
            self.base_color * (self.diffuse_weight(wo.z, wi.z) * cosine_hemisphere_pdf(wi));
        if !self.smooth() {
            let mf = self.mf;
            let m = (wo + wi).normalize();
            let f = self.specular_fresnel(wo.dot(m));
            value += f * (mf.d(m) * mf.g1(wo, m) * mf.g1(wi, m) / (4.0 * wo.z));
        }
        value
    }

    /// The G-buffer albedo seen from `wo`: the specular layer's reflectance plus what of the
    /// base colour the diffuse lobe reflects — the base colour itself for a metal, as a
    /// denoiser divides the colour by it.
    pub(super) fn uncoated_albedo(&self, wo: Vec3) -> Vec3 {
        let cos_o = wo.z.abs().min(1.0);
        let layer = table().albedo_rgb(cos_o, self.roughness, self.dielectric_f0);
        let e = self.layer_albedo(cos_o);
        let dielectric = layer * self.specular_weight + self.base_color * (1.0 - e).max(0.0);
        let metal = schlick(self.base_color, cos_o);
        dielectric * (1.0 - self.metallic) + metal * self.metallic
    }

    /// Probability of sampling the specular lobe: its share of the reflected energy (the
    /// metal's and the dielectric layer's albedo against the diffuse lobe's).
    #[inline]
    fn specular_probability(&self, cos_o: f32) -> f32 {
        let t = table();
        let mean_f0 = self.dielectric_f0.element_sum() / 3.0;
        let e = self.specular_weight * t.albedo(cos_o, self.roughness, mean_f0);
        let m = self.metallic;
        let spec = m + (1.0 - m) * e;
        let rest = (1.0 - self.layer_albedo(cos_o)).max(0.0);
        let diffuse = (1.0 - m) * rest * self.base_color.element_sum() / 3.0;
        if spec + diffuse <= 0.0 {
            1.0
        } else {
            spec / (spec + diffuse)
        }
    }

    /// The opaque BSDF's mixture density of the specular and diffuse lobes (the specular one
    /// only where it is rough).
    fn opaque_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let p_spec = self.specular_probability(wo.z);
        let mut pdf = (1.0 - p_spec) * cosine_hemisphere_pdf(wi);
        if !self.smooth() {
            let m = (wo + wi).normalize();
            pdf += p_spec * self.mf.pdf_visible(wo, m) / (4.0 * wo.dot(m));
        }
        pdf
    }

    /// The opaque BSDF's specular lobe (chosen by `u_lobe`) or its diffuse one, with `wo`
    /// above the surface.
    fn opaque_sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let p_spec = self.specular_probability(wo.z);
        let wi = if u_lobe < p_spec {
            if self.smooth() {
                let f = self.specular_fresnel(wo.z);
                return Some(mirror_sample(wo, f / p_spec, p_spec));
            }
            reflect(wo, self.mf.sample_visible(wo, u))
        } else {
            square_to_cosine_hemisphere(u)
        };
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.opaque_pdf(wo, wi);
        Some(BsdfSample {
            wi,
            weight: self.opaque_eval(wo, wi) / pdf,
            pdf,
            delta: false,
            eta: 1.0,
        })
    }
}
