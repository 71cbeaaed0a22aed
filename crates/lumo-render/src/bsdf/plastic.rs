//! A diffuse base under a dielectric coat (Mitsuba's `plastic`/`roughplastic`).

use glam::{Vec2, Vec3};

use lumo_scene::{Roughness, Texture};

use super::{
    fresnel_dielectric, fresnel_diffuse_reflectance, mirror_sample, texture, BsdfSample,
    Microfacet, Prepared, RoughCoat, SpecHit, SpectralColours, SMOOTH_ALPHA,
};
use crate::geometry::{cosine_hemisphere_pdf, reflect, square_to_cosine_hemisphere};

/// Diffuse base under a dielectric coat (Mitsuba's (rough)plastic, linear mode unless
/// `nonlinear`).
#[derive(Clone, Copy, Debug)]
pub struct Plastic {
    /// Base reflectance.
    pub diffuse: Vec3,
    /// Coat index.
    pub eta: f32,
    /// Microfacet distribution of the coat (α < 1e-3: smooth).
    pub mf: Microfacet,
    /// Internal diffuse reflectance of the coat, precomputed: of the smooth coat, or of the
    /// rough one when `coat` is given.
    pub fdr_int: f32,
    /// Mitsuba's rough coat (transmittance table); `None` uses the smooth coat's Fresnel terms
    /// for the diffuse layer whatever the roughness.
    pub coat: Option<&'static RoughCoat>,
    /// Mitsuba's `nonlinear`: divide by 1 − diffuse·fdr_int instead of 1 − fdr_int.
    pub nonlinear: bool,
}

impl Plastic {
    /// f(wo, wi)·cos θi with `wo` above the surface: the diffuse layer seen through the coat,
    /// plus the rough coat's own reflection.
    pub(super) fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let Plastic {
            diffuse,
            eta,
            mf,
            fdr_int,
            coat,
            nonlinear,
        } = *self;
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
        let mut value = diffuse / internal * (cosine_hemisphere_pdf(wi) / (eta * eta) * t_i * t_o);
        if mf.max_alpha() >= SMOOTH_ALPHA {
            let m = (wo + wi).normalize();
            let f = fresnel_dielectric(wo.dot(m), eta).0;
            value += Vec3::splat(f * mf.d(m) * mf.g1(wo, m) * mf.g1(wi, m) / (4.0 * wo.z));
        }
        value
    }

    /// The G-buffer albedo seen from `wo`: what the coat reflects (white; its Fresnel
    /// reflectance, or the rough coat's single-scattering lobe) plus the diffuse base's directional albedo through it, `eval`'s base term integrated
    /// over the incident directions (smooth coat, linear mode: diffuse · t_o, as
    /// 1 − fdr_int = (1 − fdr_ext)/η²); OIDN's convention for a layered material.
    ///
    /// Why not the base colour alone: the coat's reflection is in the colour but not
    /// proportional to the base colour, so a denoiser dividing by a base channel near 0 (a
    /// navy texel's red, 0.007) turned a grazing reflection into illumination tens of times
    /// its neighbours' and smeared it into magenta fringes and teal blobs (`box.obj`).
    pub(super) fn albedo(&self, wo: Vec3) -> Vec3 {
        let cos_o = wo.z.abs().min(1.0);
        let (t_o, coat) = match self.coat {
            Some(c) => (c.transmittance(cos_o), c.reflectance(cos_o)),
            None => {
                let f = fresnel_dielectric(cos_o, self.eta).0;
                (1.0 - f, f)
            }
        };
        // What reaches the base from cosine-distributed directions, over η² (the radiance
        // scaling of `eval`): 1 − fdr_int for the smooth coat.
        let through = match self.coat {
            Some(c) => c.diffuse_transmittance / (self.eta * self.eta),
            None => 1.0 - self.fdr_int,
        };
        let internal = if self.nonlinear {
            Vec3::ONE - self.diffuse * self.fdr_int
        } else {
            Vec3::splat(1.0 - self.fdr_int)
        };
        Vec3::splat(coat) + self.diffuse / internal * (through * t_o)
    }

    /// The mixture density of the coat and base lobes.
    pub(super) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let p_spec = self.specular_probability(wo.z);
        let mut pdf = (1.0 - p_spec) * cosine_hemisphere_pdf(wi);
        if self.mf.max_alpha() >= SMOOTH_ALPHA {
            let m = (wo + wi).normalize();
            pdf += p_spec * self.mf.pdf_visible(wo, m) / (4.0 * wo.dot(m));
        }
        pdf
    }

    /// The coat (chosen by `u_lobe`) or the base, with `wo` above the surface.
    pub(super) fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let (eta, mf) = (self.eta, self.mf);
        let p_spec = self.specular_probability(wo.z);
        if mf.max_alpha() < SMOOTH_ALPHA {
            if u_lobe < p_spec {
                let f = fresnel_dielectric(wo.z, eta).0;
                return Some(mirror_sample(wo, Vec3::splat(f / p_spec), p_spec));
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

    /// Probability of sampling the coat rather than the base: the coat's reflectance (one
    /// minus its transmittance) against the base's, as Mitsuba weighs them.
    #[inline]
    fn specular_probability(&self, cos_o: f32) -> f32 {
        let f = match self.coat {
            Some(c) => 1.0 - c.transmittance(cos_o),
            None => fresnel_dielectric(cos_o, self.eta).0,
        };
        let diffuse = self.diffuse;
        let d_mean = (diffuse.x + diffuse.y + diffuse.z) / 3.0;
        let s_weight = 1.0 / (1.0 + d_mean);
        let (ps, pd) = (f * s_weight, (1.0 - f) * (1.0 - s_weight));
        if ps + pd <= 0.0 {
            1.0
        } else {
            ps / (ps + pd)
        }
    }
}

impl Plastic {
    /// Once per material: the rough coat's tables if the scene asks for Mitsuba's exact rough
    /// coat, and the coat's internal reflectance over the diffuse base.
    pub(super) fn prepare(ior: f32, roughness: &Roughness, exact_rough_coat: bool) -> Prepared {
        let mf = Microfacet::of_roughness(roughness, None);
        let coat = (exact_rough_coat && mf.max_alpha() >= SMOOTH_ALPHA)
            .then(|| RoughCoat::shared(mf, ior));
        let fdr_int = match coat {
            Some(c) => c.internal_reflectance,
            None => fresnel_diffuse_reflectance(1.0 / ior),
        };
        Prepared { fdr_int, coat }
    }

    /// The scene's plastic at `hit`: its base read there and tinted by the surface's colour,
    /// with the coat prepared for its material.
    #[inline(always)]
    pub(super) fn at_hit(
        diffuse: &Texture,
        ior: f32,
        roughness: &Roughness,
        nonlinear: bool,
        hit: &SpecHit,
    ) -> Self {
        let prepared = hit.prepared();
        Plastic {
            diffuse: texture(diffuse, hit.uv) * hit.color,
            eta: ior,
            mf: Microfacet::of_roughness(roughness, Some(hit.uv)),
            fdr_int: prepared.fdr_int,
            coat: prepared.coat,
            nonlinear,
        }
    }

    /// The base at a spectral path's wavelengths.
    #[inline]
    pub(super) fn at_wavelengths(self, c: &mut impl SpectralColours) -> Self {
        Plastic {
            diffuse: c.base(self.diffuse),
            ..self
        }
    }
}
