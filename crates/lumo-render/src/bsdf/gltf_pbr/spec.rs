//! The glTF material from the scene's description: its textures read at a hit, its colours at a
//! spectral path's wavelengths.

use glam::Vec3;
use lumo_scene::{GltfExtensions, Texture};
use lumo_spectrum::upsample::reflectance;

use super::GltfPbr;
use crate::bsdf::{SpecHit, SpectralColours};

impl GltfPbr {
    /// The scene's metallic-roughness material at `hit`, with what its extensions add.
    #[inline(always)]
    pub(in crate::bsdf) fn at_hit(
        base_color: &Texture,
        metallic_roughness: Option<&Texture>,
        metallic: f32,
        roughness: f32,
        extensions: Option<&GltfExtensions>,
        hit: &SpecHit,
    ) -> Self {
        // glTF reads roughness from the green channel and metalness from the blue one.
        let mr = metallic_roughness.map_or(Vec3::ONE, |t| hit.texture(t));
        let g = GltfPbr::new(
            hit.texture(base_color) * hit.color,
            metallic * mr.z,
            roughness * mr.y,
        );
        match extensions {
            None => g,
            Some(e) => g
                .with_specular(
                    e.ior,
                    hit.scalar(&e.specular),
                    hit.texture(&e.specular_color),
                )
                .with_transmission(hit.scalar(&e.transmission), e.thickness <= 0.0, e.ior)
                .with_clearcoat(
                    e.clearcoat_texture
                        .as_ref()
                        .map_or(e.clearcoat, |t| hit.scalar(t)),
                    e.clearcoat_roughness_texture
                        .as_ref()
                        .map_or(e.clearcoat_roughness, |t| hit.scalar(t)),
                )
                .with_sheen(hit.texture(&e.sheen_color), hit.scalar(&e.sheen_roughness))
                .with_coat_normal(
                    e.clearcoat_normal
                        .as_ref()
                        .filter(|_| e.clearcoat > 0.0)
                        .and_then(|t| (hit.normal_map)(t))
                        .unwrap_or(Vec3::Z),
                ),
        }
    }

    /// The base colour, the dielectric F0 and the sheen colour at a spectral path's wavelengths.
    #[inline]
    pub(in crate::bsdf) fn at_wavelengths(self, c: &mut impl SpectralColours) -> Self {
        GltfPbr {
            base_color: c.base(self.base_color),
            // A grey F0 (the common case) is the same at every wavelength.
            dielectric_f0: match self.dielectric_f0 {
                f if f.min_element() == f.max_element() => f,
                f => reflectance(f, c.wavelengths()),
            },
            sheen_color: match self.sheen_color {
                s if s.min_element() == s.max_element() => s,
                s => reflectance(s, c.wavelengths()),
            },
            ..self
        }
    }
}
