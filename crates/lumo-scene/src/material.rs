use glam::Vec3;

use crate::Texture;

/// How a surface scatters light. Roughness values are GGX α (0 = perfectly smooth).
#[derive(Clone, Debug)]
pub enum Bsdf {
    /// Lambertian reflection.
    Diffuse {
        /// Reflectance (albedo).
        reflectance: Texture,
    },
    /// Perfect specular reflection with a constant reflectance.
    Mirror {
        /// Reflectance.
        reflectance: Vec3,
    },
    /// A metal: GGX microfacets with the exact conductor Fresnel term (α = 0: smooth).
    Conductor {
        /// Real part of the complex index of refraction, per RGB channel.
        eta: Vec3,
        /// Imaginary part (absorption), per RGB channel.
        k: Vec3,
        /// GGX α.
        roughness: f32,
    },
    /// A diffuse base under a smooth or rough dielectric coat (Mitsuba's (rough)plastic).
    Plastic {
        /// Reflectance of the diffuse base.
        diffuse: Texture,
        /// Index of refraction of the coat.
        ior: f32,
        /// GGX α of the coat.
        roughness: f32,
    },
    /// Glass: refraction and reflection at an interface (α = 0: smooth).
    Dielectric {
        /// Interior index of refraction over exterior.
        ior: f32,
        /// GGX α.
        roughness: f32,
    },
}

/// A surface's BSDF and its emitted radiance (non-zero makes it an area light).
#[derive(Clone, Debug)]
pub struct Material {
    /// Name, used in messages.
    pub name: String,
    /// Scattering.
    pub bsdf: Bsdf,
    /// Emitted radiance (front side only).
    pub emission: Vec3,
    /// Whether an opaque BSDF reflects on both sides of the surface (lumo's built-in, glTF and
    /// OBJ scenes; Mitsuba's `twosided`). When false the back of an opaque surface is black,
    /// as Mitsuba's plain `diffuse`, `conductor` and `plastic` are. Transmissive BSDFs ignore it.
    pub two_sided: bool,
}

impl Material {
    /// A named Lambertian material with a constant reflectance.
    pub fn diffuse(name: &str, rgb: Vec3) -> Self {
        Self {
            name: name.into(),
            bsdf: Bsdf::Diffuse {
                reflectance: Texture::Constant(rgb),
            },
            emission: Vec3::ZERO,
            two_sided: true,
        }
    }

    /// This material with an emitted radiance.
    pub fn with_emission(mut self, radiance: Vec3) -> Self {
        self.emission = radiance;
        self
    }

    /// True when the surface emits light.
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }
}
