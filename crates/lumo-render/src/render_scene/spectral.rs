//! The scene at a path's wavelengths, for spectral rendering: every colour the integrators
//! read (BSDF parameters, emitted radiance, light samples) turned from the scene's RGB or its
//! tabulated spectra into values at the path's [`Wavelengths`].
//!
//! RGB values follow Mitsuba 3's spectral variants: reflectances become bounded smooth spectra,
//! indices of refraction given as RGB unbounded ones, emitters RGB × D65. Tabulated spectra
//! (Mitsuba `<spectrum>` pairs, measured conductor presets, dispersive glasses) are evaluated
//! directly.

use glam::Vec3;
use lumo_spectrum::upsample::{illuminant, reflectance, unbounded, unbounded_coefficients};
use lumo_spectrum::{coefficients, Sigmoid, Tabulated, Wavelengths};

use super::{RenderScene, Surface};
use crate::bsdf::{Bsdf, Conductor, Diffuse, GltfPbr, Mirror, Plastic};
use crate::shading::ShadingBsdf;

/// A tabulated spectrum at the three wavelengths.
#[inline]
fn at(t: &Tabulated, wl: &Wavelengths) -> Vec3 {
    Vec3::from_array(wl.lambda.map(|l| t.eval(l)))
}

/// What every spectral lookup of a material would fetch again: the sigmoids of its constant
/// base colour and of its emission. Each entry keeps the colour it was fitted for, so a
/// material edited since (its colour no longer equal) takes the table lookup instead.
pub(crate) struct SpectralCache {
    /// Per material: its constant base reflectance and that colour's sigmoid.
    reflectance: Vec<Option<(Vec3, Sigmoid)>>,
    /// Per material: its emitted radiance and that colour's unbounded (scale, sigmoid).
    emission: Vec<(Vec3, f32, Sigmoid)>,
}

impl SpectralCache {
    fn new(rs: &RenderScene) -> Self {
        let reflectance = rs
            .scene
            .materials
            .iter()
            .map(|m| {
                let c = m.bsdf.base_color()?.constant()?;
                Some((c, coefficients(c)))
            })
            .collect();
        let emission = rs
            .scene
            .materials
            .iter()
            .map(|m| {
                let (scale, s) = unbounded_coefficients(m.emission);
                (m.emission, scale, s)
            })
            .collect();
        Self {
            reflectance,
            emission,
        }
    }
}

impl RenderScene {
    /// The spectral constants, fitted on first use.
    #[inline]
    fn spectral_cache(&self) -> &SpectralCache {
        self.spectral.get_or_init(|| SpectralCache::new(self))
    }

    /// Reflectance `rgb` of `material` at `wl` from an upsampled RGB: the cached sigmoid when
    /// `rgb` is the material's constant colour.
    #[inline]
    fn upsampled_reflectance(&self, rgb: Vec3, material: usize, wl: &Wavelengths) -> Vec3 {
        match self.spectral_cache().reflectance.get(material) {
            Some(Some((c, s))) if *c == rgb => s.eval_lanes(wl),
            _ => reflectance(rgb, wl),
        }
    }

    /// The BSDF `b` of surface `s` at the wavelengths of `wl`. A dispersive dielectric takes
    /// its index at the hero wavelength and stops the other lanes (their paths would refract
    /// elsewhere).
    #[inline]
    pub fn spectral_bsdf(
        &self,
        mut b: ShadingBsdf,
        s: &Surface,
        wl: &mut Wavelengths,
    ) -> ShadingBsdf {
        let spectra = &self.scene.materials[s.material].spectra;
        // A tabulated reflectance holds where the surface adds no colour of its own.
        let base = |rgb: Vec3| match &spectra.reflectance {
            Some(t) if s.color == Vec3::ONE => at(t, wl),
            _ => self.upsampled_reflectance(rgb, s.material, wl),
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
                reflectance: self.upsampled_reflectance(m.reflectance, s.material, wl),
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
            Bsdf::GltfPbr(g) => Bsdf::GltfPbr(GltfPbr {
                base_color: base(g.base_color),
                // A grey F0 (the common case) is the same at every wavelength.
                dielectric_f0: match g.dielectric_f0 {
                    f if f.min_element() == f.max_element() => f,
                    f => reflectance(f, wl),
                },
                sheen_color: match g.sheen_color {
                    c if c.min_element() == c.max_element() => c,
                    c => reflectance(c, wl),
                },
                ..g
            }),
        };
        b
    }

    /// A reflectance `rgb` of material `material` at `wl` (its tabulated spectrum if it has one).
    #[inline]
    pub(crate) fn spectral_reflectance(
        &self,
        rgb: Vec3,
        material: usize,
        wl: &Wavelengths,
    ) -> Vec3 {
        match &self.scene.materials[material].spectra.reflectance {
            Some(t) => at(t, wl),
            None => self.upsampled_reflectance(rgb, material, wl),
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
            None => {
                // Light weights are the material's emission times a number: use its sigmoid.
                match self.spectral_cache().emission.get(material) {
                    Some((e, scale, sig)) => {
                        let c = rgb.max_element() / e.max_element();
                        if c.is_finite()
                            && (rgb - *e * c).abs().max_element() <= 1e-5 * rgb.max_element()
                        {
                            sig.eval_lanes(wl) * (scale * c) * wl.d65()
                        } else {
                            illuminant(rgb, wl)
                        }
                    }
                    None => illuminant(rgb, wl),
                }
            }
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
}
