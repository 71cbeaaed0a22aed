//! BSDFs at a shading point, in the local frame (z = shading normal). `wo` points towards the
//! viewer, `wi` towards the light; both unit vectors. Values returned by `eval` include the
//! cosine factor |cos θi|, and sample weights are eval / pdf.

mod coat;
mod fresnel;
mod microfacet;

pub use coat::RoughCoat;
pub use fresnel::{fresnel_conductor, fresnel_dielectric, fresnel_diffuse_reflectance};
pub use microfacet::{Distribution, Microfacet};

use glam::{Vec2, Vec3};

use crate::geometry::{cosine_hemisphere_pdf, reflect, square_to_cosine_hemisphere};

/// Roughness below which a microfacet BSDF is treated as perfectly smooth.
pub const SMOOTH_ALPHA: f32 = 1e-3;

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
    /// Microfacet conductor (α < 1e-3 on both axes: smooth).
    Conductor {
        /// Real index.
        eta: Vec3,
        /// Absorption.
        k: Vec3,
        /// Microfacet distribution.
        mf: Microfacet,
    },
    /// Diffuse base under a dielectric coat (Mitsuba's (rough)plastic, linear mode).
    Plastic {
        /// Base reflectance.
        diffuse: Vec3,
        /// Coat index.
        eta: f32,
        /// Microfacet distribution of the coat (α < 1e-3: smooth).
        mf: Microfacet,
        /// Internal diffuse reflectance of the coat, precomputed: of the smooth coat, or of
        /// the rough one when `coat` is given.
        fdr_int: f32,
        /// Mitsuba's rough coat (transmittance table); `None` uses the smooth coat's Fresnel
        /// terms for the diffuse layer whatever the roughness.
        coat: Option<&'static RoughCoat>,
        /// Mitsuba's `nonlinear`: divide by 1 − diffuse·fdr_int instead of 1 − fdr_int.
        nonlinear: bool,
    },
    /// Dielectric interface (α < 1e-3 on both axes: smooth).
    Dielectric {
        /// Relative index inside / outside.
        eta: f32,
        /// Microfacet distribution.
        mf: Microfacet,
    },
    /// Thin dielectric sheet (Mitsuba's `thindielectric`): delta reflection and straight-through
    /// transmission, with the internal bounces summed.
    ThinDielectric {
        /// Relative index of the sheet.
        eta: f32,
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
            Bsdf::Mirror { .. } | Bsdf::ThinDielectric { .. } => true,
            Bsdf::Conductor { mf, .. } | Bsdf::Dielectric { mf, .. } => {
                mf.max_alpha() < SMOOTH_ALPHA
            }
        }
    }

    /// Transmissive BSDFs see both sides as different media; opaque ones are two-sided.
    fn is_transmissive(&self) -> bool {
        matches!(self, Bsdf::Dielectric { .. } | Bsdf::ThinDielectric { .. })
    }

    /// The G-buffer "albedo": diffuse reflectance, or the specular albedo at normal incidence.
    pub fn albedo(&self) -> Vec3 {
        match *self {
            Bsdf::Diffuse { albedo } => albedo,
            Bsdf::Mirror { reflectance } => reflectance,
            Bsdf::Conductor { eta, k, .. } => conductor_fresnel(1.0, eta, k),
            Bsdf::Plastic { diffuse, .. } => diffuse,
            Bsdf::Dielectric { .. } | Bsdf::ThinDielectric { .. } => Vec3::ONE,
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
            Bsdf::Mirror { .. } | Bsdf::ThinDielectric { .. } => Vec3::ZERO,
            Bsdf::Conductor { eta, k, mf } => {
                if mf.max_alpha() < SMOOTH_ALPHA || wo.z <= 0.0 || wi.z <= 0.0 {
                    return Vec3::ZERO;
                }
                let m = (wo + wi).normalize();
                let g = mf;
                let f = conductor_fresnel(wo.dot(m), eta, k);
                f * (g.d(m) * g.g1(wo, m) * g.g1(wi, m) / (4.0 * wo.z))
            }
            Bsdf::Plastic {
                diffuse,
                eta,
                mf,
                fdr_int,
                coat,
                nonlinear,
            } => {
                if wo.z <= 0.0 || wi.z <= 0.0 {
                    return Vec3::ZERO;
                }
                // Transmittances into the coat towards the viewer and the light.
                let (t_o, t_i) = match coat {
                    Some(c) => (c.transmittance(wo.z), c.transmittance(wi.z)),
                    None => (
                        1.0 - fresnel_dielectric(wo.z, eta).0,
                        1.0 - fresnel_dielectric(wi.z, eta).0,
                    ),
                };
                let internal = if nonlinear {
                    Vec3::ONE - diffuse * fdr_int
                } else {
                    Vec3::splat(1.0 - fdr_int)
                };
                let mut value =
                    diffuse / internal * (cosine_hemisphere_pdf(wi) / (eta * eta) * t_i * t_o);
                if mf.max_alpha() >= SMOOTH_ALPHA {
                    let m = (wo + wi).normalize();
                    let g = mf;
                    let f = fresnel_dielectric(wo.dot(m), eta).0;
                    value += Vec3::splat(f * g.d(m) * g.g1(wo, m) * g.g1(wi, m) / (4.0 * wo.z));
                }
                value
            }
            Bsdf::Dielectric { eta, mf } => {
                if mf.max_alpha() < SMOOTH_ALPHA || wo.z == 0.0 || wi.z == 0.0 {
                    return Vec3::ZERO;
                }
                Vec3::splat(rough_dielectric(wo, wi, eta, mf).0)
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
            Bsdf::Mirror { .. } | Bsdf::ThinDielectric { .. } => 0.0,
            Bsdf::Conductor { mf, .. } => {
                if mf.max_alpha() < SMOOTH_ALPHA || wo.z <= 0.0 || wi.z <= 0.0 {
                    return 0.0;
                }
                let m = (wo + wi).normalize();
                mf.pdf_visible(wo, m) / (4.0 * wo.dot(m))
            }
            Bsdf::Plastic {
                diffuse,
                eta,
                mf,
                coat,
                ..
            } => {
                if wo.z <= 0.0 || wi.z <= 0.0 {
                    return 0.0;
                }
                let p_spec = plastic_specular_probability(wo.z, eta, diffuse, coat);
                let mut pdf = (1.0 - p_spec) * cosine_hemisphere_pdf(wi);
                if mf.max_alpha() >= SMOOTH_ALPHA {
                    let m = (wo + wi).normalize();
                    pdf += p_spec * mf.pdf_visible(wo, m) / (4.0 * wo.dot(m));
                }
                pdf
            }
            Bsdf::Dielectric { eta, mf } => {
                if mf.max_alpha() < SMOOTH_ALPHA || wo.z == 0.0 || wi.z == 0.0 {
                    return 0.0;
                }
                rough_dielectric(wo, wi, eta, mf).1
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
            Bsdf::ThinDielectric { eta } => {
                let r = thin_dielectric_reflectance(wo.z.abs(), eta);
                if u_lobe < r {
                    return Some(mirror(Vec3::ONE, r));
                }
                // Straight through: the sheet's two refractions cancel.
                Some(BsdfSample {
                    wi: -wo,
                    weight: Vec3::ONE,
                    pdf: 1.0 - r,
                    delta: true,
                    eta: 1.0,
                })
            }
            Bsdf::Conductor { eta, k, mf } => {
                if mf.max_alpha() < SMOOTH_ALPHA {
                    return Some(mirror(conductor_fresnel(wo.z, eta, k), 1.0));
                }
                let g = mf;
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
                mf,
                coat,
                ..
            } => {
                let p_spec = plastic_specular_probability(wo.z, eta, diffuse, coat);
                if mf.max_alpha() < SMOOTH_ALPHA {
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
                    reflect(wo, mf.sample_visible(wo, u))
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
            Bsdf::Dielectric { eta, mf } => {
                if mf.max_alpha() < SMOOTH_ALPHA {
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
                let g = mf;
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

/// Probability of sampling the coat of a plastic rather than its base: the coat's
/// reflectance (one minus its transmittance) against the base's, as Mitsuba weighs them.
#[inline]
fn plastic_specular_probability(
    cos_o: f32,
    eta: f32,
    diffuse: Vec3,
    coat: Option<&RoughCoat>,
) -> f32 {
    let f = match coat {
        Some(c) => 1.0 - c.transmittance(cos_o),
        None => fresnel_dielectric(cos_o, eta).0,
    };
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
