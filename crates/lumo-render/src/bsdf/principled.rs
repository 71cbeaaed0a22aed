//! Mitsuba 3's `principled` BSDF: Burley's Disney BSDF (2012, 2015) with the lobes, weights and
//! lobe-selection probabilities of Mitsuba's `principled.cpp`, so that a scene renders with the
//! same mean and comparable noise.
//!
//! Lobes, for a viewer outside (`wo.z > 0`): a diffuse lobe with Burley's retro-reflection
//! (blended towards Hanrahan–Krueger's fake subsurface by `flatness`), weighted by
//! (1 − metallic)(1 − spec_trans); a sheen; a GGX reflection whose Fresnel term mixes the
//! dielectric's exact one, a base-colour-tinted Schlick term (`spec_tint`) and the metal's
//! Schlick term with the base colour as F0; a GGX refraction weighted by
//! (1 − metallic)·spec_trans and tinted by √base_color; and a GTR1 clear coat with a fixed
//! Smith-GGX (α 0.25) shadowing term. From inside only the dielectric interface remains
//! (reflection and refraction weighted by (1 − metallic)·spec_trans). The model is not energy
//! conserving (the diffuse lobe's retro-reflection and the sheen add to the specular lobe
//! rather than taking their share from it); lumo keeps Mitsuba's values, not a fixed model.

use glam::{Vec2, Vec3};

use lumo_scene::PrincipledSpec;

use super::{fresnel_dielectric, BsdfSample, Microfacet, SpecHit, SpectralColours};
use crate::geometry::{reflect, square_to_cosine_hemisphere};

/// Mitsuba's principled BSDF at one surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Principled {
    /// Base colour.
    pub base_color: Vec3,
    /// The base colour over its luminance (white where the luminance is 0): the hue that
    /// `spec_tint` and `sheen_tint` tint towards.
    pub tint: Vec3,
    /// Perceptual roughness (the diffuse retro-reflection reads it).
    pub roughness: f32,
    /// GGX of the main specular lobes.
    pub mf: Microfacet,
    /// Metalness.
    pub metallic: f32,
    /// Share of the non-metallic part that is a dielectric interface.
    pub spec_trans: f32,
    /// Share of the dielectric reflection tinted by the base colour.
    pub spec_tint: f32,
    /// Sheen weight.
    pub sheen: f32,
    /// Share of the sheen tinted by the base colour.
    pub sheen_tint: f32,
    /// Clear-coat weight.
    pub clearcoat: f32,
    /// GTR1 α of the clear coat.
    pub clearcoat_alpha: f32,
    /// Diffuse / fake-subsurface blend.
    pub flatness: f32,
    /// Relative index inside / outside.
    pub eta: f32,
    /// Sampling rates of the diffuse, main specular and clear-coat lobes.
    pub rates: [f32; 3],
}

/// Schlick's weight (1 − cos)⁵, with the cosine clamped to [0, 1].
#[inline]
fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Schlick's Fresnel term of normal-incidence reflectance `r0` at signed cosine `cos` on an
/// interface of relative index `eta`; on the denser side it uses the refracted cosine (as
/// Mitsuba's principled does).
#[inline]
fn schlick(r0: Vec3, cos: f32, eta: f32) -> Vec3 {
    let (eta_it, eta_ti) = if cos >= 0.0 {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    let w = if eta_it > 1.0 {
        schlick_weight(cos.abs())
    } else {
        let cos_t2 = 1.0 - (1.0 - cos * cos) * eta_ti * eta_ti;
        schlick_weight(cos_t2.max(0.0).sqrt())
    };
    r0 + (Vec3::ONE - r0) * w
}

/// Burley's GTR1 distribution of roughness `alpha` at a normal of cosine `cos` (projected
/// area normalised).
#[inline]
fn gtr1(alpha: f32, cos: f32) -> f32 {
    let a2 = alpha * alpha;
    let d = (a2 - 1.0) / (std::f32::consts::PI * a2.ln() * (1.0 + (a2 - 1.0) * cos * cos));
    if d * cos > 1e-20 {
        d
    } else {
        0.0
    }
}

/// Smith's GGX masking of direction `w` over microfacet `m` for roughness `alpha` (the clear
/// coat's separable shadowing), zero where `w` sees the facet's back.
#[inline]
fn smith_ggx1(w: Vec3, m: Vec3, alpha: f32) -> f32 {
    if w.dot(m) * w.z <= 0.0 {
        return 0.0;
    }
    let c2 = w.z * w.z;
    let t2 = (1.0 - c2) / c2;
    2.0 / (1.0 + (1.0 + alpha * alpha * t2).sqrt())
}

/// Whether `wo` and `wi` both see microfacet `m` from the side each is on: for reflection
/// both on `wo`'s side of the facet, for refraction `wi` on the other.
#[inline]
fn facet_sides_agree(m: Vec3, wo: Vec3, wi: Vec3, reflection: bool) -> bool {
    let m = m * wo.z.signum();
    wo.dot(m) > 0.0
        && if reflection {
            wi.dot(m) > 0.0
        } else {
            wi.dot(m) < 0.0
        }
}

/// What both `eval` and `pdf` need about a pair of directions.
struct Pair {
    /// Same side (reflection) or opposite sides (refraction).
    reflect: bool,
    /// The half vector, pointing out of the surface.
    h: Vec3,
    /// The dielectric Fresnel reflectance at `wo · h`.
    f: f32,
    /// Relative index along the path: η from outside, 1/η from inside.
    eta_path: f32,
}

impl Principled {
    /// Weight of the diffuse lobes (and of the front-side reflection's dielectric part).
    #[inline]
    fn brdf(&self) -> f32 {
        (1.0 - self.metallic) * (1.0 - self.spec_trans)
    }

    /// Weight of the dielectric interface (reflection from inside and refraction).
    #[inline]
    pub(super) fn bsdf(&self) -> f32 {
        (1.0 - self.metallic) * self.spec_trans
    }

    fn pair(&self, wo: Vec3, wi: Vec3) -> Option<Pair> {
        let reflect = wo.z * wi.z > 0.0;
        if wo.z == 0.0 || wi.z == 0.0 {
            return None;
        }
        let eta_path = if wo.z > 0.0 { self.eta } else { 1.0 / self.eta };
        let h = (wo + wi * if reflect { 1.0 } else { eta_path }).normalize();
        let h = if h.z < 0.0 { -h } else { h };
        if !h.is_finite() {
            return None;
        }
        let (f, ..) = fresnel_dielectric(wo.dot(h), self.eta);
        Some(Pair {
            reflect,
            h,
            f,
            eta_path,
        })
    }

    /// The lobe-selection probabilities (diffuse, clear coat, reflection, refraction) for
    /// `wo`, given the dielectric Fresnel term `f` at the chosen microfacet. From outside
    /// reflection + refraction always sum to the main specular rate, so the diffuse and
    /// clear-coat probabilities do not depend on the facet.
    #[inline]
    fn lobe_probabilities(&self, front: bool, f: f32) -> [f32; 4] {
        let [rate_d, rate_s, rate_c] = self.rates;
        let bsdf = self.bsdf();
        let p = if front {
            [
                self.brdf() * rate_d,
                0.25 * self.clearcoat * rate_c,
                rate_s * (1.0 - bsdf * (1.0 - f)),
                rate_s * bsdf * (1.0 - f),
            ]
        } else {
            [0.0, 0.0, f, 1.0 - f]
        };
        let total = p[0] + p[1] + p[2] + p[3];
        if total > 0.0 {
            p.map(|x| x / total)
        } else {
            [0.0; 4]
        }
    }

    /// f(wo, wi)·|cos θi|, `wo` on either side; refraction carries radiance (× 1/η²).
    pub(super) fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let Some(Pair {
            reflect,
            h,
            f,
            eta_path,
        }) = self.pair(wo, wi)
        else {
            return Vec3::ZERO;
        };
        let front = wo.z > 0.0;
        let (brdf, bsdf, m) = (self.brdf(), self.bsdf(), self.metallic);
        let (cos_o, cos_i) = (wo.z.abs(), wi.z.abs());
        let (cos_oh, cos_ih) = (wo.dot(h), wi.dot(h));
        let d = self.mf.d(h);
        let g = self.mf.g1(wo, h) * self.mf.g1(wi, h);
        let mut value = Vec3::ZERO;
        if reflect && facet_sides_agree(h, wo, wi, true) {
            if f > 0.0 {
                let fresnel = if front {
                    let r0_tint = self.tint * dielectric_r0(cos_oh, self.eta);
                    Vec3::splat((1.0 - m) * (1.0 - self.spec_tint) * f)
                        + m * schlick(self.base_color, cos_oh, self.eta)
                        + (1.0 - m) * self.spec_tint * schlick(r0_tint, cos_oh, self.eta)
                } else {
                    Vec3::splat(bsdf * f)
                };
                value += fresnel * (d * g / (4.0 * cos_o));
            }
            if front && self.clearcoat > 0.0 {
                let fcc = schlick(Vec3::splat(0.04), cos_oh, self.eta).x;
                let dcc = gtr1(self.clearcoat_alpha, h.z);
                let gcc = smith_ggx1(wo, h, 0.25) * smith_ggx1(wi, h, 0.25);
                value += Vec3::splat(0.25 * self.clearcoat * fcc * dcc * gcc * cos_i);
            }
        }
        if !reflect && bsdf > 0.0 && f < 1.0 && facet_sides_agree(h, wo, wi, false) {
            let denom = cos_oh + eta_path * cos_ih;
            // Radiance is compressed by 1/η² entering the denser side.
            let t = (1.0 - f) * d * g * (cos_oh * cos_ih).abs() / (cos_o * denom * denom);
            value += self.base_color.map(f32::sqrt) * (bsdf * t);
        }
        if reflect && front {
            let fo = schlick_weight(cos_i);
            let fi = schlick_weight(cos_o);
            let cos_d = h.dot(wi);
            if brdf > 0.0 {
                let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
                let rr = 2.0 * self.roughness * cos_d * cos_d;
                let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
                let mut lobe = f_diff + f_retro;
                if self.flatness != 0.0 {
                    let fss90 = 0.5 * rr;
                    let fss = (1.0 + (fss90 - 1.0) * fo) * (1.0 + (fss90 - 1.0) * fi);
                    let f_ss = 1.25 * (fss * (1.0 / (cos_o + cos_i) - 0.5) + 0.5);
                    lobe += (f_ss - lobe) * self.flatness;
                }
                value += self.base_color * (brdf * cos_i * std::f32::consts::FRAC_1_PI * lobe);
            }
            // Mitsuba's llvm variants add the sheen wherever its own mask holds (its scalar
            // variants only where the diffuse lobe is on too); lumo follows the mask.
            if self.sheen > 0.0 && m < 1.0 {
                let c_sheen = Vec3::ONE + (self.tint - Vec3::ONE) * self.sheen_tint;
                value += c_sheen * (self.sheen * (1.0 - m) * schlick_weight(cos_d.abs()) * cos_i);
            }
        }
        value
    }

    /// Density of [`Principled::sample`].
    pub(super) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(Pair {
            reflect,
            h,
            f,
            eta_path,
        }) = self.pair(wo, wi)
        else {
            return 0.0;
        };
        let front = wo.z > 0.0;
        let [p_diffuse, p_coat, p_reflect, p_refract] = self.lobe_probabilities(front, f);
        let (cos_oh, cos_ih) = (wo.dot(h), wi.dot(h));
        let jacobian = if reflect {
            1.0 / (4.0 * cos_ih).abs()
        } else {
            let denom = cos_oh + eta_path * cos_ih;
            (eta_path * eta_path * cos_ih / (denom * denom)).abs()
        };
        let visible = self.mf.pdf_visible(wo * wo.z.signum(), h);
        let mut pdf = 0.0;
        if reflect {
            if facet_sides_agree(h, wo, wi, true) {
                pdf += p_reflect * visible * jacobian;
                if p_coat > 0.0 {
                    pdf += p_coat * h.z * gtr1(self.clearcoat_alpha, h.z) * jacobian;
                }
            }
            if p_diffuse > 0.0 {
                pdf += p_diffuse * wi.z.abs() * std::f32::consts::FRAC_1_PI;
            }
        } else if facet_sides_agree(h, wo, wi, false) {
            pdf += p_refract * visible * jacobian;
        }
        pdf
    }

    /// A lobe chosen by `u_lobe` with Mitsuba's probabilities, then its direction from `u`:
    /// a visible GGX normal for reflection and refraction, a GTR1 normal for the clear coat,
    /// a cosine-weighted direction for the diffuse lobes (which also cover the sheen).
    pub(super) fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let front = wo.z > 0.0;
        if !front && self.bsdf() <= 0.0 {
            return None;
        }
        let side = wo.z.signum();
        let m = self.mf.sample_visible(wo * side, u);
        let cos_om = wo.dot(m);
        let (f, cos_t, _, eta_ti) = fresnel_dielectric(cos_om, self.eta);
        let [p_diffuse, p_coat, _, p_refract] = self.lobe_probabilities(front, f);
        let (wi, crossed) = if u_lobe < p_diffuse {
            (square_to_cosine_hemisphere(u), 1.0)
        } else if u_lobe < p_diffuse + p_coat {
            let m = gtr1_sample(self.clearcoat_alpha, u);
            if wo.dot(m) <= 0.0 {
                return None;
            }
            (reflect(wo, m), 1.0)
        } else if u_lobe < p_diffuse + p_coat + p_refract {
            let wi = m * (cos_om * eta_ti + cos_t) - wo * eta_ti;
            if wi.z * wo.z >= 0.0 {
                return None;
            }
            (wi, 1.0 / eta_ti)
        } else {
            (reflect(wo, m), 1.0)
        };
        if crossed == 1.0 && wi.z * wo.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: self.eval(wo, wi) / pdf,
            pdf,
            delta: false,
            eta: crossed,
        })
    }

    /// The G-buffer albedo: the base colour (Mitsuba's diffuse reflectance of it).
    pub(super) fn albedo(&self) -> Vec3 {
        self.base_color
    }
}

/// ((η − 1)/(η + 1))² for the index seen from the side of signed cosine `cos`.
#[inline]
fn dielectric_r0(cos: f32, eta: f32) -> f32 {
    let eta_it = if cos >= 0.0 { eta } else { 1.0 / eta };
    let r = (eta_it - 1.0) / (eta_it + 1.0);
    r * r
}

/// A GTR1 microfacet normal of roughness `alpha`, density D(m)·cos θm.
#[inline]
fn gtr1_sample(alpha: f32, u: Vec2) -> Vec3 {
    let a2 = alpha * alpha;
    let cos2 = (1.0 - a2.powf(1.0 - u.y)) / (1.0 - a2);
    let (sin_t, cos_t) = ((1.0 - cos2).max(0.0).sqrt(), cos2.max(0.0).sqrt());
    let (s, c) = (2.0 * std::f32::consts::PI * u.x).sin_cos();
    Vec3::new(c * sin_t, s * sin_t, cos_t)
}

impl Principled {
    /// The BSDF of explicit parameters, clamped as Mitsuba's would act on them: GGX α =
    /// max(0.001, roughness²), anisotropy stretching it along the tangent by
    /// 1/√(1 − 0.9·anisotropic); an index of 1 read as 1.001 where the surface transmits.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        base_color: Vec3,
        roughness: f32,
        anisotropic: f32,
        metallic: f32,
        spec_trans: f32,
        eta: f32,
        clearcoat: f32,
        clearcoat_gloss: f32,
    ) -> Self {
        let r2 = roughness * roughness;
        let aspect = (1.0 - 0.9 * anisotropic).max(0.0).sqrt();
        let (ax, ay) = if anisotropic == 0.0 {
            (r2, r2)
        } else {
            (r2 / aspect, r2 * aspect)
        };
        let lum = lumo_image::luminance(base_color.to_array());
        Principled {
            base_color,
            tint: if lum > 0.0 {
                base_color / lum
            } else {
                Vec3::ONE
            },
            roughness,
            mf: Microfacet {
                distribution: super::Distribution::Ggx,
                alpha_u: ax.max(0.001),
                alpha_v: ay.max(0.001),
            },
            metallic,
            spec_trans,
            spec_tint: 0.0,
            sheen: 0.0,
            sheen_tint: 0.0,
            clearcoat,
            clearcoat_alpha: 0.1 + (0.001 - 0.1) * clearcoat_gloss,
            flatness: 0.0,
            eta: if spec_trans > 0.0 && eta == 1.0 {
                1.001
            } else {
                eta
            },
            rates: [1.0; 3],
        }
    }

    /// This BSDF with `spec_tint`, `sheen`, `sheen_tint` and `flatness`.
    pub fn with_tints(
        mut self,
        spec_tint: f32,
        sheen: f32,
        sheen_tint: f32,
        flatness: f32,
    ) -> Self {
        self.spec_tint = spec_tint;
        self.sheen = sheen;
        self.sheen_tint = sheen_tint;
        self.flatness = flatness;
        self
    }

    /// The scene's principled material with its textures read at `hit` (the base colour
    /// tinted by the surface's colour).
    #[inline]
    pub(super) fn at_hit(p: &PrincipledSpec, hit: &SpecHit) -> Self {
        let uv = hit.uv;
        // The loader keeps constants in [0, 1]; a texel outside it (an HDR bitmap) or NaN is
        // read at the nearest end (NaN as 0) rather than let it make light or NaN radiance.
        let unit = |t: &lumo_scene::Texture| {
            let x = t.eval_1(uv);
            if x.is_nan() {
                0.0
            } else {
                x.clamp(0.0, 1.0)
            }
        };
        let mut b = Principled::new(
            super::texture(&p.base_color, uv) * hit.color,
            unit(&p.roughness),
            unit(&p.anisotropic),
            unit(&p.metallic),
            unit(&p.spec_trans),
            p.eta,
            unit(&p.clearcoat),
            unit(&p.clearcoat_gloss),
        )
        .with_tints(
            unit(&p.spec_tint),
            unit(&p.sheen),
            unit(&p.sheen_tint),
            unit(&p.flatness),
        );
        b.rates = p.sampling_rates;
        b
    }

    /// The base colour and its tint at a spectral path's wavelengths (the tint divided by
    /// the RGB luminance).
    #[inline]
    pub(super) fn at_wavelengths(mut self, c: &mut impl SpectralColours) -> Self {
        let lum = lumo_image::luminance(self.base_color.to_array());
        self.base_color = c.base(self.base_color);
        if lum > 0.0 {
            self.tint = self.base_color / lum;
        }
        self
    }
}
