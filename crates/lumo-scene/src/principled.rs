//! Mitsuba 3's `principled` BSDF (Burley's Disney BSDF as Mitsuba implements it) as a scene
//! describes it: every parameter a value or a texture.

use crate::Texture;

/// The parameters of Mitsuba's `principled` BSDF. Scalar parameters are textures read as their
/// luminance (a grey texture's own value), as Mitsuba reads them with `eval_1`.
#[derive(Clone, Debug)]
pub struct PrincipledSpec {
    /// Base colour: the diffuse and sheen colour, the metal's normal-incidence reflectance
    /// and (through its square root) the transmission tint.
    pub base_color: Texture,
    /// Perceptual roughness in [0, 1]: GGX α = roughness² (at least 0.001) and the diffuse
    /// lobe's retro-reflection.
    pub roughness: Texture,
    /// Anisotropy in [0, 1]: α along the tangent / bitangent stretched by √(1 − 0.9·it).
    pub anisotropic: Texture,
    /// Metalness in [0, 1].
    pub metallic: Texture,
    /// The share in [0, 1] of the non-metallic part that is a rough dielectric interface
    /// (reflection and refraction) rather than a diffuse base.
    pub spec_trans: Texture,
    /// The share in [0, 1] of the dielectric reflection tinted by the base colour.
    pub spec_tint: Texture,
    /// Weight of the sheen lobe (≥ 0).
    pub sheen: Texture,
    /// The share in [0, 1] of the sheen tinted by the base colour.
    pub sheen_tint: Texture,
    /// Weight of the clear coat (a GTR1 lobe with Schlick's F0 = 0.04), ≥ 0.
    pub clearcoat: Texture,
    /// Glossiness in [0, 1] of the clear coat: its α goes from 0.1 (0) to 0.001 (1).
    pub clearcoat_gloss: Texture,
    /// Blend in [0, 1] from the diffuse lobe to Hanrahan–Krueger's fake subsurface lobe.
    pub flatness: Texture,
    /// Relative index of refraction inside / outside (Mitsuba's `eta`, or the one its
    /// `specular` stands for).
    pub eta: f32,
    /// Mitsuba's sampling rates of the diffuse, main specular and clear-coat lobes (they change
    /// only the noise).
    pub sampling_rates: [f32; 3],
}

impl PrincipledSpec {
    /// Whether some texel can transmit: `spec_trans` is not the constant 0 and `metallic` is
    /// not the constant 1.
    pub fn transmits(&self) -> bool {
        let zero = |t: &Texture| matches!(t, Texture::Constant(c) if *c == glam::Vec3::ZERO);
        let one = |t: &Texture| matches!(t, Texture::Constant(c) if *c == glam::Vec3::ONE);
        !zero(&self.spec_trans) && !one(&self.metallic)
    }

    /// Whether some texel is anisotropic (the renderer then aligns the shading frame with the
    /// surface's tangent, as for an anisotropic α).
    pub fn is_anisotropic(&self) -> bool {
        !matches!(self.anisotropic, Texture::Constant(c) if c == glam::Vec3::ZERO)
    }

    /// Whether some texel has a diffuse lobe: not metallic everywhere, not transmitting
    /// everywhere.
    pub fn has_diffuse(&self) -> bool {
        let one = |t: &Texture| matches!(t, Texture::Constant(c) if *c == glam::Vec3::ONE);
        !one(&self.spec_trans) && !one(&self.metallic)
    }
}
