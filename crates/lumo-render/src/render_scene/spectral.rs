//! The scene at a path's wavelengths, for spectral rendering: every colour the integrators
//! read (BSDF parameters, emitted radiance, light samples) turned from the scene's RGB or its
//! tabulated spectra into values at the path's [`Wavelengths`].
//!
//! RGB values follow Mitsuba 3's spectral variants: reflectances become bounded smooth spectra,
//! indices of refraction given as RGB unbounded ones, emitters RGB × D65. Tabulated spectra
//! (Mitsuba `<spectrum>` pairs, measured conductor presets, dispersive glasses) are evaluated
//! directly.

use glam::Vec3;
use lumo_spectrum::upsample::{illuminant, reflectance, unbounded};
use lumo_spectrum::{Tabulated, Wavelengths};

use super::{RenderScene, Surface};
use crate::bsdf::{Bsdf, Conductor, Diffuse, Mirror, Plastic};
use crate::shading::ShadingBsdf;

/// A tabulated spectrum at the three wavelengths.
#[inline]
fn at(t: &Tabulated, wl: &Wavelengths) -> Vec3 {
    Vec3::from_array(wl.lambda.map(|l| t.eval(l)))
}

impl RenderScene {
    /// The BSDF `b` of surface `s` at the wavelengths of `wl`. A dispersive dielectric takes
    /// its index at the hero wavelength and stops the other lanes (their paths would refract
    /// elsewhere).
    #[inline]
    pub fn spectral_bsdf(&self, mut b: ShadingBsdf, s: &Surface, wl: &mut Wavelengths) -> ShadingBsdf {
        let spectra = &self.scene.materials[s.material].spectra;
        // A tabulated reflectance holds where the surface adds no colour of its own.
        let base = |rgb: Vec3| match &spectra.reflectance {
            Some(t) if s.color == Vec3::ONE => at(t, wl),
            _ => reflectance(rgb, wl),
        };
        b.bsdf = match b.bsdf {
            Bsdf::Diffuse(d) => Bsdf::Diffuse(Diffuse {
                albedo: base(d.albedo),
            }),
            Bsdf::Plastic(p) => Bsdf::Plastic(Plastic {
                diffuse: base(p.diffuse),
                ..p
            }),
            Bsdf::Mirror(m) => Bsdf::Mirror(Mirror {
                reflectance: reflectance(m.reflectance, wl),
            }),
            Bsdf::Conductor(c) => {
                let (eta, k) = match &spectra.conductor {
                    Some(t) => (at(&t.0, wl), at(&t.1, wl)),
                    None => (unbounded(c.eta, wl), unbounded(c.k, wl)),
                };
                Bsdf::Conductor(Conductor { eta, k, ..c })
            }
            Bsdf::Dielectric(mut d) => {
                if let Some((glass, exterior)) = &spectra.dispersion {
                    let n = glass.sellmeier(wl.hero());
                    let n_d = glass.sellmeier(lumo_spectrum::dispersion::D_LINE);
                    d.eta += (n - n_d) / exterior;
                    wl.terminate_secondary();
                }
                Bsdf::Dielectric(d)
            }
            other @ Bsdf::ThinDielectric(_) => other,
        };
        b
    }

    /// A reflectance `rgb` of material `material` at `wl` (its tabulated spectrum if it has one).
    #[inline]
    pub(crate) fn spectral_reflectance(&self, rgb: Vec3, material: usize, wl: &Wavelengths) -> Vec3 {
        match &self.scene.materials[material].spectra.reflectance {
            Some(t) => at(t, wl),
            None => reflectance(rgb, wl),
        }
    }

    /// Radiance `rgb` emitted by a surface of `material` at `wl`: its tabulated spectrum,
    /// scaled as `rgb` scales the material's emission (a light's weight divides it by a
    /// density), or else `rgb` × D65.
    #[inline]
    pub fn spectral_emission(&self, rgb: Vec3, material: usize, wl: &Wavelengths) -> Vec3 {
        let m = &self.scene.materials[material];
        match &m.spectra.emission {
            Some(t) => {
                let base = m.emission.max_element();
                if base > 0.0 {
                    at(t, wl) * (rgb.max_element() / base)
                } else {
                    Vec3::ZERO
                }
            }
            None => illuminant(rgb, wl),
        }
    }

    /// A light sample's `weight` (radiance or intensity over its density) from light `light`
    /// at `wl`.
    #[inline]
    pub fn spectral_light(&self, weight: Vec3, light: u32, wl: &Wavelengths) -> Vec3 {
        match self.lights.area_material(light) {
            Some(m) => self.spectral_emission(weight, m, wl),
            None => illuminant(weight, wl),
        }
    }

    /// Whether some emitter has a tabulated spectrum (the vector bounce, which reads emissive
    /// triangles without their material, then leaves spectral paths to the scalar bounce).
    pub fn has_emission_spectra(&self) -> bool {
        self.scene
            .materials
            .iter()
            .any(|m| m.spectra.emission.is_some() && m.is_emissive())
    }
}
