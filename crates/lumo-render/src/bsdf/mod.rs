//! BSDFs at a shading point, in the local frame (z = shading normal). `wo` points towards the
//! viewer, `wi` towards the light; both unit vectors. Values returned by `eval` include the
//! cosine factor |cos θi|, and sample weights are eval / pdf.

mod fresnel;
mod microfacet;

pub use fresnel::{fresnel_conductor, fresnel_dielectric, fresnel_diffuse_reflectance};
pub use microfacet::Ggx;

use glam::{Vec2, Vec3};

use crate::geometry::{cosine_hemisphere_pdf, reflect, square_to_cosine_hemisphere};

/// Roughness below which a microfacet BSDF is treated as perfectly smooth.
const SMOOTH_ALPHA: f32 = 1e-3;

/// A BSDF with its textures resolved at one surface point.
#[derive(Clone, Copy, Debug)]
pub enum Bsdf {
    /// Lambertian.
    Diffuse {
        /// Reflectance.
        albedo: Vec3,
    },
    /// Perfect mirror.
    Mirror {
        /// Reflectance.
        reflectance: Vec3,
    },
    /// GGX conductor (α < 1e-3: smooth).
    Conductor {
        /// Real index.
        eta: Vec3,
        /// Absorption.
        k: Vec3,
        /// GGX α.
        alpha: f32,
    },
    /// Diffuse base under a dielectric coat (Mitsuba's (rough)plastic, linear mode).
    Plastic {
        /// Base reflectance.
        diffuse: Vec3,
        /// Coat index.
        eta: f32,
        /// GGX α of the coat.
        alpha: f32,
        /// Internal diffuse Fresnel reflectance of the coat, precomputed.
        fdr_int: f32,
    },
    /// Dielectric interface (α < 1e-3: smooth).
    Dielectric {
        /// Relative index inside / outside.
        eta: f32,
        /// GGX α.
        alpha: f32,
    },
}

/// A sampled direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Direction towards the light, local frame.
    pub wi: Vec3,
    /// eval / pdf (for delta lobes: the lobe's reflectance / transmittance over its probability).
    pub weight: Vec3,
    /// Solid-angle density (for delta lobes: the discrete probability of the lobe).
    pub pdf: f32,
    /// True when the direction came from a Dirac lobe (not reachable by light sampling).
    pub delta: bool,
    /// Relative index crossed (1 for reflection); radiance through a refraction is scaled by
    /// 1/eta², which `weight` already includes.
    pub eta: f32,
}

#[inline]
fn conductor_fresnel(cos: f32, eta: Vec3, k: Vec3) -> Vec3 {
    Vec3::new(
        fresnel_conductor(cos, eta.x, k.x),
        fresnel_conductor(cos, eta.y, k.y),
        fresnel_conductor(cos, eta.z, k.z),
    )
}

impl Bsdf {
    /// True if every lobe is a Dirac delta (light sampling is useless there).
    pub fn is_delta(&self) -> bool {
        match *self {
            Bsdf::Diffuse { .. } | Bsdf::Plastic { .. } => false,
            Bsdf::Mirror { .. } => true,
            Bsdf::Conductor { alpha, .. } | Bsdf::Dielectric { alpha, .. } => alpha < SMOOTH_ALPHA,
        }
    }

    /// Transmissive BSDFs see both sides as different media; opaque ones are two-sided.
    fn is_transmissive(&self) -> bool {
        matches!(self, Bsdf::Dielectric { .. })
    }

    /// The G-buffer "albedo": diffuse reflectance, or the specular albedo at normal incidence.
    pub fn albedo(&self) -> Vec3 {
        match *self {
            Bsdf::Diffuse { albedo } => albedo,
            Bsdf::Mirror { reflectance } => reflectance,
            Bsdf::Conductor { eta, k, .. } => conductor_fresnel(1.0, eta, k),
            Bsdf::Plastic { diffuse, .. } => diffuse,
            Bsdf::Dielectric { .. } => Vec3::ONE,
        }
    }

    /// Opaque BSDFs are two-sided: flip both directions when the viewer is behind the surface.
    #[inline]
    fn orient(&self, wo: Vec3, wi: Vec3) -> (Vec3, Vec3) {
        if !self.is_transmissive() && wo.z < 0.0 {
            (-wo, -wi)
        } else {
            (wo, wi)
        }
    }

    /// f(wo, wi)·|cos θi|.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let (wo, wi) = self.orient(wo, wi);
        match *self {
            Bsdf::Diffuse { albedo } => {
                if wo.z <= 0.0 || wi.z <= 0.0 {
                    return Vec3::ZERO;
                }
                albedo * cosine_hemisphere_pdf(wi)
            }
            Bsdf::Mirror { .. } => Vec3::ZERO,
            Bsdf::Conductor { eta, k, alpha } => {
                if alpha < SMOOTH_ALPHA || wo.z <= 0.0 || wi.z <= 0.0 {
                    return Vec3::ZERO;
                }
                let m = (wo + wi).normalize();
                let g = Ggx { alpha };
                let f = conductor_fresnel(wo.dot(m), eta, k);
                f * (g.d(m) * g.g1(wo, m) * g.g1(wi, m) / (4.0 * wo.z))
            }
            Bsdf::Plastic {
                diffuse,
                eta,
                alpha,
                fdr_int,
            } => {
                if wo.z <= 0.0 || wi.z <= 0.0 {
                    return Vec3::ZERO;
                }
                let f_o = fresnel_dielectric(wo.z, eta).0;
                let f_i = fresnel_dielectric(wi.z, eta).0;
                let mut value = diffuse / (1.0 - fdr_int)
                    * (cosine_hemisphere_pdf(wi) / (eta * eta) * (1.0 - f_i) * (1.0 - f_o));
                if alpha >= SMOOTH_ALPHA {
                    let m = (wo + wi).normalize();
                    let g = Ggx { alpha };
                    let f = fresnel_dielectric(wo.dot(m), eta).0;
                    value += Vec3::splat(f * g.d(m) * g.g1(wo, m) * g.g1(wi, m) / (4.0 * wo.z));
                }
                value
            }
            Bsdf::Dielectric { eta, alpha } => {
                if alpha < SMOOTH_ALPHA || wo.z == 0.0 || wi.z == 0.0 {
                    return Vec3::ZERO;
                }
                Vec3::splat(rough_dielectric(wo, wi, eta, alpha).0)
            }
        }
    }

    /// Solid-angle density with which [`Bsdf::sample`] picks `wi` (0 for delta lobes).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi) = self.orient(wo, wi);
        match *self {
            Bsdf::Diffuse { .. } => {
                if wo.z <= 0.0 {
                    0.0
                } else {
                    cosine_hemisphere_pdf(wi)
                }
            }
            Bsdf::Mirror { .. } => 0.0,
            Bsdf::Conductor { alpha, .. } => {
                if alpha < SMOOTH_ALPHA || wo.z <= 0.0 || wi.z <= 0.0 {
                    return 0.0;
                }
                let m = (wo + wi).normalize();
                Ggx { alpha }.pdf_visible(wo, m) / (4.0 * wo.dot(m))
            }
            Bsdf::Plastic {
                diffuse,
                eta,
                alpha,
                ..
            } => {
                if wo.z <= 0.0 || wi.z <= 0.0 {
                    return 0.0;
                }
                let p_spec = plastic_specular_probability(wo.z, eta, diffuse);
                let mut pdf = (1.0 - p_spec) * cosine_hemisphere_pdf(wi);
                if alpha >= SMOOTH_ALPHA {
                    let m = (wo + wi).normalize();
                    pdf += p_spec * Ggx { alpha }.pdf_visible(wo, m) / (4.0 * wo.dot(m));
                }
                pdf
            }
            Bsdf::Dielectric { eta, alpha } => {
                if alpha < SMOOTH_ALPHA || wo.z == 0.0 || wi.z == 0.0 {
                    return 0.0;
                }
                rough_dielectric(wo, wi, eta, alpha).1
            }
        }
    }

    /// Samples `wi` given `wo`, a lobe-selection number and a 2-D point.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let flip = !self.is_transmissive() && wo.z < 0.0;
        let wo_o = if flip { -wo } else { wo };
        let mut s = self.sample_oriented(wo_o, u_lobe, u)?;
        if flip {
            s.wi = -s.wi;
        }
        (s.weight.is_finite() && s.pdf > 0.0).then_some(s)
    }

    fn sample_oriented(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let mirror = |weight: Vec3, pdf: f32| BsdfSample {
            wi: Vec3::new(-wo.x, -wo.y, wo.z),
            weight,
            pdf,
            delta: true,
            eta: 1.0,
        };
        match *self {
            Bsdf::Diffuse { albedo } => {
                let wi = square_to_cosine_hemisphere(u);
                Some(BsdfSample {
                    wi,
                    weight: albedo,
                    pdf: cosine_hemisphere_pdf(wi),
                    delta: false,
                    eta: 1.0,
                })
            }
            Bsdf::Mirror { reflectance } => Some(mirror(reflectance, 1.0)),
            Bsdf::Conductor { eta, k, alpha } => {
                if alpha < SMOOTH_ALPHA {
                    return Some(mirror(conductor_fresnel(wo.z, eta, k), 1.0));
                }
                let g = Ggx { alpha };
                let m = g.sample_visible(wo, u);
                let wi = reflect(wo, m);
                if wi.z <= 0.0 {
                    return None;
                }
                Some(BsdfSample {
                    wi,
                    weight: conductor_fresnel(wo.dot(m), eta, k) * g.g1(wi, m),
                    pdf: g.pdf_visible(wo, m) / (4.0 * wo.dot(m)),
                    delta: false,
                    eta: 1.0,
                })
            }
            Bsdf::Plastic {
                diffuse,
                eta,
                alpha,
                ..
            } => {
                let p_spec = plastic_specular_probability(wo.z, eta, diffuse);
                if alpha < SMOOTH_ALPHA {
                    if u_lobe < p_spec {
                        let f = fresnel_dielectric(wo.z, eta).0;
                        return Some(mirror(Vec3::splat(f / p_spec), p_spec));
                    }
                    let wi = square_to_cosine_hemisphere(u);
                    let pdf = (1.0 - p_spec) * cosine_hemisphere_pdf(wi);
                    let weight = self.eval(wo, wi) / pdf;
                    return Some(BsdfSample {
                        wi,
                        weight,
                        pdf,
                        delta: false,
                        eta: 1.0,
                    });
                }
                let wi = if u_lobe < p_spec {
                    reflect(wo, Ggx { alpha }.sample_visible(wo, u))
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
            Bsdf::Dielectric { eta, alpha } => {
                if alpha < SMOOTH_ALPHA {
                    let (f, cos_t, _, eta_ti) = fresnel_dielectric(wo.z, eta);
                    if u_lobe < f {
                        return Some(mirror(Vec3::ONE, f));
                    }
                    return Some(BsdfSample {
                        wi: Vec3::new(-eta_ti * wo.x, -eta_ti * wo.y, cos_t),
                        weight: Vec3::splat(eta_ti * eta_ti),
                        pdf: 1.0 - f,
                        delta: true,
                        eta: 1.0 / eta_ti,
                    });
                }
                let g = Ggx { alpha };
                // Sample in the frame where wo is above; the microfacet normal stays in the
                // upper hemisphere so the signed cosine tells Fresnel which side wo is on.
                let side = wo.z.signum();
                let m = g.sample_visible(wo * side, u);
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
                let (value, pdf) = rough_dielectric(wo, wi, eta, alpha);
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
    }
}

/// Probability of sampling the coat of a plastic rather than its base.
#[inline]
fn plastic_specular_probability(cos_o: f32, eta: f32, diffuse: Vec3) -> f32 {
    let f = fresnel_dielectric(cos_o, eta).0;
    let d_mean = (diffuse.x + diffuse.y + diffuse.z) / 3.0;
    let s_weight = 1.0 / (1.0 + d_mean);
    let (ps, pd) = (f * s_weight, (1.0 - f) * (1.0 - s_weight));
    if ps + pd <= 0.0 {
        1.0
    } else {
        ps / (ps + pd)
    }
}

/// Rough dielectric (Walter et al. 2007) value f·|cos θi| and sampling density.
fn rough_dielectric(wo: Vec3, wi: Vec3, eta: f32, alpha: f32) -> (f32, f32) {
    let g = Ggx { alpha };
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
