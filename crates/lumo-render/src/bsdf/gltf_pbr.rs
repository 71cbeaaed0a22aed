//! glTF 2.0's metallic-roughness material (the core specification's Appendix B): a mix, by
//! `metallic`, of a metal (GGX specular tinted by the base colour through Schlick's Fresnel) and
//! a dielectric (a Lambertian base colour under a GGX specular layer with F0 = 0.04).
//!
//! One deviation from Appendix B, for energy conservation: the spec weighs the dielectric's
//! diffuse lobe by 1 − F(v·h), which makes a white base reflect more than it receives at grazing
//! views (the specular layer's reflection there is not taken from the diffuse lobe's share).
//! Here the diffuse lobe is weighed by (1 − E(ωo))(1 − E(ωi)) / (1 − E_avg), E being the
//! specular layer's directional albedo (tabulated over view cosine and roughness) and E_avg its
//! cosine-weighted mean: reciprocal, and a white dielectric reflects exactly what it receives.
//! Cycles' Principled BSDF, which Blender's glTF importer maps glTF materials to, also takes the
//! diffuse lobe's weight from the specular layer's albedo.

use std::sync::OnceLock;

use glam::{Vec2, Vec3};

use super::{mirror_sample, BsdfSample, Microfacet, SMOOTH_ALPHA};
use crate::geometry::{cosine_hemisphere_pdf, reflect, square_to_cosine_hemisphere};

/// The dielectric's reflectance at normal incidence (glTF: index of refraction 1.5).
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
}

/// Schlick's Fresnel approximation with reflectance `f0` at normal incidence.
#[inline]
fn schlick(f0: Vec3, cos: f32) -> Vec3 {
    let c = (1.0 - cos.clamp(0.0, 1.0)).powi(5);
    f0 + (Vec3::ONE - f0) * c
}

impl GltfPbr {
    /// The BSDF of a texel's base colour, metallic and roughness, clamped to [0, 1] (NaN:
    /// a non-metal, fully rough).
    pub fn new(base_color: Vec3, metallic: f32, roughness: f32) -> Self {
        let unit = |x: f32, nan: f32| if x.is_nan() { nan } else { x.clamp(0.0, 1.0) };
        let (metallic, roughness) = (unit(metallic, 0.0), unit(roughness, 1.0));
        let alpha = roughness * roughness;
        Self {
            base_color: Vec3::from_array(base_color.to_array().map(|c| unit(c, 0.0))),
            metallic,
            roughness,
            mf: Microfacet::ggx(if alpha < SMOOTH_ALPHA {
                0.0
            } else {
                alpha.max(1e-4)
            }),
        }
    }

    /// Whether the specular lobes are Dirac deltas.
    #[inline]
    fn smooth(&self) -> bool {
        self.mf.max_alpha() < SMOOTH_ALPHA
    }

    /// Smooth and fully metallic: nothing but a mirror reflection.
    pub(super) fn is_delta(&self) -> bool {
        self.smooth() && self.metallic >= 1.0
    }

    /// The specular Fresnel term of the mix at microfacet cosine `cos`: the dielectric's
    /// F0 = 0.04 and the metal's base colour, weighed by metalness.
    #[inline]
    fn specular_fresnel(&self, cos: f32) -> Vec3 {
        let m = self.metallic;
        schlick(Vec3::splat(DIELECTRIC_F0), cos) * (1.0 - m) + schlick(self.base_color, cos) * m
    }

    /// The diffuse lobe's factor besides base/π·cos θi: (1 − metallic) and the share the
    /// specular layer leaves for it.
    #[inline]
    fn diffuse_weight(&self, cos_o: f32, cos_i: f32) -> f32 {
        let t = table();
        let (e_o, e_i) = (
            t.albedo(cos_o, self.roughness),
            t.albedo(cos_i, self.roughness),
        );
        (1.0 - self.metallic) * (1.0 - e_o) * (1.0 - e_i) / (1.0 - t.average(self.roughness))
    }

    /// f(wo, wi)·cos θi with `wo` above the surface.
    pub(super) fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
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
    pub(super) fn albedo(&self, wo: Vec3) -> Vec3 {
        let cos_o = wo.z.abs().min(1.0);
        let e = table().albedo(cos_o, self.roughness);
        let dielectric = Vec3::splat(e) + self.base_color * (1.0 - e);
        let metal = schlick(self.base_color, cos_o);
        dielectric * (1.0 - self.metallic) + metal * self.metallic
    }

    /// Probability of sampling the specular lobe: its share of the reflected energy (the
    /// metal's and the dielectric layer's albedo against the diffuse lobe's).
    #[inline]
    fn specular_probability(&self, cos_o: f32) -> f32 {
        let e = table().albedo(cos_o, self.roughness);
        let m = self.metallic;
        let spec = m + (1.0 - m) * e;
        let diffuse = (1.0 - m) * (1.0 - e) * self.base_color.element_sum() / 3.0;
        if spec + diffuse <= 0.0 {
            1.0
        } else {
            spec / (spec + diffuse)
        }
    }

    /// The mixture density of the specular and diffuse lobes (the specular one only where it
    /// is rough).
    pub(super) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
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

    /// The specular lobe (chosen by `u_lobe`) or the diffuse one, with `wo` above the surface.
    pub(super) fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
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
        let pdf = self.pdf(wo, wi);
        Some(BsdfSample {
            wi,
            weight: self.eval(wo, wi) / pdf,
            pdf,
            delta: false,
            eta: 1.0,
        })
    }
}

/// View cosines and roughnesses tabulated (the cosines evenly in √cos θo, as E changes fastest
/// at grazing views).
const COS_STEPS: usize = 32;
const ROUGHNESS_STEPS: usize = 24;
/// Visible normals per table entry (a stratified grid of this size squared).
const STRATA: usize = 48;

/// The dielectric specular layer's directional albedo E(cos θo, roughness) (GGX with
/// separable Smith masking, Schlick's Fresnel with F0 = 0.04) and its cosine-weighted mean.
pub struct GltfAlbedoTable {
    /// E at √cos θo = i/(COS_STEPS − 1) and roughness j/(ROUGHNESS_STEPS − 1), row-major by j.
    albedo: Vec<f32>,
    /// 2∫E(μ)μ dμ per roughness step (of the interpolated table, so the diffuse weights
    /// integrate exactly).
    average: Vec<f32>,
}

/// The shared table, computed on first use (about a million microfacet samples).
fn table() -> &'static GltfAlbedoTable {
    static TABLE: OnceLock<GltfAlbedoTable> = OnceLock::new();
    TABLE.get_or_init(GltfAlbedoTable::compute)
}

impl GltfAlbedoTable {
    fn compute() -> Self {
        let mut albedo = Vec::with_capacity(COS_STEPS * ROUGHNESS_STEPS);
        for j in 0..ROUGHNESS_STEPS {
            let b = GltfPbr::new(Vec3::ZERO, 0.0, j as f32 / (ROUGHNESS_STEPS - 1) as f32);
            for i in 0..COS_STEPS {
                let cos = (i as f32 / (COS_STEPS - 1) as f32).powi(2).max(1e-4);
                albedo.push(if b.smooth() {
                    schlick(Vec3::splat(DIELECTRIC_F0), cos).x
                } else {
                    specular_albedo(b.mf, cos)
                });
            }
        }
        let mut t = Self {
            albedo,
            average: vec![0.0; ROUGHNESS_STEPS],
        };
        const N: usize = 1024;
        for j in 0..ROUGHNESS_STEPS {
            let r = j as f32 / (ROUGHNESS_STEPS - 1) as f32;
            let sum: f32 = (0..N)
                .map(|k| {
                    let mu = (k as f32 + 0.5) / N as f32;
                    t.albedo(mu, r) * mu
                })
                .sum();
            t.average[j] = 2.0 * sum / N as f32;
        }
        t
    }

    /// E at view cosine `cos` and roughness `r`, bilinearly interpolated.
    #[inline]
    fn albedo(&self, cos: f32, r: f32) -> f32 {
        let (i, fi) = grid(cos.max(0.0).sqrt(), COS_STEPS);
        let (j, fj) = grid(r, ROUGHNESS_STEPS);
        let at = |i: usize, j: usize| self.albedo[j * COS_STEPS + i];
        let row = |j: usize| at(i, j) * (1.0 - fi) + at(i + 1, j) * fi;
        row(j) * (1.0 - fj) + row(j + 1) * fj
    }

    /// E_avg at roughness `r`, linearly interpolated.
    #[inline]
    fn average(&self, r: f32) -> f32 {
        let (j, fj) = grid(r, ROUGHNESS_STEPS);
        self.average[j] * (1.0 - fj) + self.average[j + 1] * fj
    }
}

/// The cell of `x` ∈ [0, 1] on a grid of `n` points and the fraction into it.
#[inline]
fn grid(x: f32, n: usize) -> (usize, f32) {
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    } * (n - 1) as f32;
    let i = (x as usize).min(n - 2);
    (i, x - i as f32)
}

/// ∫ f·cos θi of the dielectric specular layer seen from cosine `cos`: the mean, over visible
/// normals on a stratified grid, of the sampled reflection's weight F(ωo·m)·G1(ωi, m).
fn specular_albedo(mf: Microfacet, cos: f32) -> f32 {
    let wo = Vec3::new((1.0 - cos * cos).max(0.0).sqrt(), 0.0, cos);
    let mut sum = 0.0f64;
    for a in 0..STRATA {
        for b in 0..STRATA {
            let u = Vec2::new(
                (a as f32 + 0.5) / STRATA as f32,
                (b as f32 + 0.5) / STRATA as f32,
            );
            let m = mf.sample_visible(wo, u);
            let wi = reflect(wo, m);
            if wi.z > 0.0 {
                let f = schlick(Vec3::splat(DIELECTRIC_F0), wo.dot(m)).x;
                sum += f64::from(f * mf.g1(wi, m));
            }
        }
    }
    (sum / (STRATA * STRATA) as f64) as f32
}
