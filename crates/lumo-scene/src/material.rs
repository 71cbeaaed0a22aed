use std::sync::Arc;

use glam::{Vec2, Vec3};

use lumo_spectrum::{Glass, Tabulated};

use crate::{BsdfSpec, Texture};

/// A microfacet normal distribution (Mitsuba's `distribution` parameter).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distribution {
    /// Beckmann–Spizzichino: Gaussian slopes (Mitsuba's default).
    Beckmann,
    /// GGX (Trowbridge–Reitz): long-tailed slopes (lumo's built-in, glTF and OBJ materials).
    Ggx,
}

/// The roughness of a microfacet surface: a distribution and its α along the shading
/// tangent (u) and bitangent (v). α = 0 on both axes means perfectly smooth.
#[derive(Clone, Debug)]
pub struct Roughness {
    /// The normal distribution.
    pub distribution: Distribution,
    /// α along the tangent (Mitsuba's `alpha_u`, or `alpha`); where `maps` is given, the
    /// average of its map (for what needs one number, such as light-path heuristics).
    pub alpha_u: f32,
    /// α along the bitangent (Mitsuba's `alpha_v`, or `alpha`); see `alpha_u`.
    pub alpha_v: f32,
    /// Per-texel α (Mitsuba's `alpha` / `alpha_u` / `alpha_v` given as a texture); `None`
    /// where α is the same everywhere.
    pub maps: Option<Arc<RoughnessMaps>>,
}

/// Textures of α along the two tangent directions, read as numbers (a colour texture's
/// luminance, as Mitsuba reads one where a number is expected).
#[derive(Clone, Debug)]
pub struct RoughnessMaps {
    /// α along the tangent.
    pub alpha_u: Texture,
    /// α along the bitangent.
    pub alpha_v: Texture,
    /// Whether the two are one texture (isotropic `alpha`).
    pub isotropic: bool,
}

impl PartialEq for Roughness {
    /// Equal distributions and α; maps are equal only when they are the same maps.
    fn eq(&self, other: &Self) -> bool {
        let maps = match (&self.maps, &other.maps) {
            (None, None) => true,
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            _ => false,
        };
        self.distribution == other.distribution
            && self.alpha_u == other.alpha_u
            && self.alpha_v == other.alpha_v
            && maps
    }
}

impl Roughness {
    /// Isotropic GGX of roughness α.
    pub const fn ggx(alpha: f32) -> Self {
        Self {
            distribution: Distribution::Ggx,
            alpha_u: alpha,
            alpha_v: alpha,
            maps: None,
        }
    }

    /// A perfectly smooth surface.
    pub const SMOOTH: Self = Self::ggx(0.0);

    /// True when α may differ between the two tangent directions (the shading frame's
    /// tangent then matters).
    pub fn is_anisotropic(&self) -> bool {
        match &self.maps {
            Some(maps) => !maps.isotropic,
            None => self.alpha_u != self.alpha_v,
        }
    }

    /// α along the tangent and the bitangent at texture coordinates `uv`.
    #[inline]
    pub fn alpha_at(&self, uv: Vec2) -> (f32, f32) {
        match &self.maps {
            None => (self.alpha_u, self.alpha_v),
            Some(maps) if maps.isotropic => {
                let a = maps.alpha_u.eval_1(uv);
                (a, a)
            }
            Some(maps) => (maps.alpha_u.eval_1(uv), maps.alpha_v.eval_1(uv)),
        }
    }
}

/// A surface's BSDF and its emitted radiance (non-zero makes it an area light).
#[derive(Clone, Debug)]
pub struct Material {
    /// Name, used in messages.
    pub name: String,
    /// Scattering.
    pub bsdf: BsdfSpec,
    /// Emitted radiance (front side only); where `emission_map` is given, its average (what
    /// weighs this light against the others).
    pub emission: Vec3,
    /// Per-texel emitted radiance (Mitsuba's area `radiance` given as a texture), looked up
    /// at the surface's uv; `None` where `emission` holds everywhere.
    pub emission_map: Option<Arc<Texture>>,
    /// Whether an opaque BSDF reflects on both sides of the surface (lumo's built-in, glTF and
    /// OBJ scenes; Mitsuba's `twosided`). When false the back of an opaque surface is black,
    /// as Mitsuba's plain `diffuse`, `conductor` and `plastic` are. Transmissive BSDFs ignore it.
    pub two_sided: bool,
    /// What the scene gave as spectra, kept for spectral rendering (RGB rendering reads the
    /// RGB fields above, which hold these spectra's colours).
    pub spectra: Spectra,
}

/// A material's spectral data where the scene gave more than RGB: measured or tabulated
/// spectra and dispersion. Everything absent is upsampled from the RGB values.
#[derive(Clone, Debug, Default)]
pub struct Spectra {
    /// Reflectance of the diffuse base (Mitsuba `<spectrum>` wavelength:value pairs).
    pub reflectance: Option<Arc<Tabulated>>,
    /// Emitted radiance (Mitsuba `<spectrum>` pairs on an area emitter), in radiance units.
    pub emission: Option<Arc<Tabulated>>,
    /// A conductor's (η, k) spectra: a measured preset or pairs from the file.
    pub conductor: Option<Arc<(Tabulated, Tabulated)>>,
    /// A named dispersive glass and the exterior index it is divided by: the dielectric's
    /// relative index at λ is `ior + (n_glass(λ) − n_glass(d line)) / exterior`.
    pub dispersion: Option<(Glass, f32)>,
}

impl Material {
    /// A named Lambertian material with a constant reflectance.
    pub fn diffuse(name: &str, rgb: Vec3) -> Self {
        Self {
            name: name.into(),
            bsdf: BsdfSpec::Diffuse {
                reflectance: Texture::Constant(rgb),
            },
            emission: Vec3::ZERO,
            two_sided: true,
            emission_map: None,
            spectra: Spectra::default(),
        }
    }

    /// A named smooth glass: a dielectric interface of relative index `ior`.
    pub fn glass(name: &str, ior: f32) -> Self {
        Self {
            name: name.into(),
            bsdf: BsdfSpec::Dielectric {
                ior,
                roughness: Roughness::SMOOTH,
            },
            emission: Vec3::ZERO,
            two_sided: true,
            emission_map: None,
            spectra: Spectra::default(),
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
