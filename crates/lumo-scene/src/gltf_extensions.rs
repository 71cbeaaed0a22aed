//! The parameters glTF's KHR_materials_* extensions add to the metallic-roughness material.

use glam::Vec3;

use crate::Texture;

/// What a glTF material's extensions add to its metallic-roughness BSDF (each field holds the
/// extension's default where the file does not use it).
#[derive(Clone, Debug)]
pub struct GltfExtensions {
    /// KHR_materials_ior: the dielectric's index of refraction (1.5; 0 makes the dielectric
    /// layer a perfect reflector, as the extension allows for converted specular-glossiness
    /// materials).
    pub ior: f32,
    /// KHR_materials_specular: specularFactor × specularTexture's alpha channel (grey), the
    /// weight of the dielectric layer's reflection (1).
    pub specular: Texture,
    /// KHR_materials_specular: specularColorFactor × specularColorTexture (sRGB decoded),
    /// which multiplies the dielectric layer's F0 ((1, 1, 1)).
    pub specular_color: Texture,
    /// KHR_materials_transmission: transmissionFactor × transmissionTexture's red channel
    /// (grey), the share of the dielectric part that transmits (0).
    pub transmission: Texture,
    /// KHR_materials_volume's thicknessFactor: 0 is a thin-walled surface (transmission
    /// without refraction), more makes the mesh the boundary of a volume of index `ior` (0).
    pub thickness: f32,
    /// KHR_materials_volume's absorption inside the volume, σ_a = −ln(attenuationColor) /
    /// attenuationDistance per channel (per unit length of the mesh's space); `None` where
    /// nothing is absorbed. The loader makes it a homogeneous medium inside the meshes of
    /// the material.
    pub absorption: Option<Vec3>,
    /// KHR_materials_clearcoat's clearcoatFactor: the intensity of a GGX coat of F0 = 0.04
    /// over the material (0).
    pub clearcoat: f32,
    /// KHR_materials_clearcoat's clearcoatRoughnessFactor (perceptual) (0).
    pub clearcoat_roughness: f32,
    /// clearcoatFactor × clearcoatTexture's red channel (grey), per texel; `None` without the
    /// texture (the factor holds everywhere).
    pub clearcoat_texture: Option<Texture>,
    /// clearcoatRoughnessFactor × clearcoatRoughnessTexture's green channel (grey), per
    /// texel; `None` without the texture.
    pub clearcoat_roughness_texture: Option<Texture>,
    /// KHR_materials_clearcoat's clearcoatNormalTexture, its texels already scaled by the
    /// texture's `scale` as a normalTexture's are (tangent-space RGB in [0, 1]): the coat's
    /// own shading normal. `None`: the coat follows the mesh's normal, not the base's normal
    /// map, as the extension defines.
    pub clearcoat_normal: Option<Texture>,
    /// KHR_materials_sheen: sheenColorFactor × sheenColorTexture (sRGB decoded), the colour
    /// of a Charlie sheen layer under the coat ((0, 0, 0): no sheen).
    pub sheen_color: Texture,
    /// KHR_materials_sheen: sheenRoughnessFactor × sheenRoughnessTexture's alpha channel
    /// (grey), the sheen's perceptual roughness (0).
    pub sheen_roughness: Texture,
}

impl GltfExtensions {
    /// Whether any part of the material may transmit light.
    pub fn transmits(&self) -> bool {
        !matches!(self.transmission, Texture::Constant(c) if c.max_element() <= 0.0)
    }

    /// Whether any part of the material has a sheen layer.
    pub fn has_sheen(&self) -> bool {
        !matches!(self.sheen_color, Texture::Constant(c) if c.max_element() <= 0.0)
    }
}

impl Default for GltfExtensions {
    /// The extensions' defaults: the core metallic-roughness material.
    fn default() -> Self {
        Self {
            ior: 1.5,
            specular: Texture::Constant(Vec3::ONE),
            specular_color: Texture::Constant(Vec3::ONE),
            transmission: Texture::Constant(Vec3::ZERO),
            thickness: 0.0,
            absorption: None,
            clearcoat: 0.0,
            clearcoat_roughness: 0.0,
            clearcoat_texture: None,
            clearcoat_roughness_texture: None,
            clearcoat_normal: None,
            sheen_color: Texture::Constant(Vec3::ZERO),
            sheen_roughness: Texture::Constant(Vec3::ZERO),
        }
    }
}
