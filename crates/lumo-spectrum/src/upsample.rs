//! RGB values as spectra at a path's wavelengths, by what they describe (Mitsuba 3's
//! conventions, so an RGB scene renders the same colours spectrally):
//! - reflectances: the bounded sigmoid spectrum of the table ([`reflectance`]);
//! - unbounded quantities (indices of refraction given as RGB): the sigmoid of the colour
//!   scaled into [0, ½] by 2·max, times that scale ([`unbounded`]);
//! - emitters: the unbounded spectrum times D65 ([`illuminant`]), so RGB (1, 1, 1) is D65 and
//!   renders white. Both unbounded forms are linear in the colour's scale, so a radiance
//!   multiplied by a number (a light's falloff, a sampling weight) upsamples to the same
//!   multiple.

use glam::Vec3;

use crate::sigmoid::Sigmoid;
use crate::table::coefficients;
use crate::wavelengths::Wavelengths;

/// A reflectance `rgb` (clamped to [0, 1]) at the wavelengths of `wl`.
#[inline]
pub fn reflectance(rgb: Vec3, wl: &Wavelengths) -> Vec3 {
    coefficients(rgb).eval_lanes(wl)
}

/// An unbounded non-negative `rgb` at the wavelengths of `wl`.
#[inline]
pub fn unbounded(rgb: Vec3, wl: &Wavelengths) -> Vec3 {
    let m = rgb.max_element();
    if m <= 0.0 || !m.is_finite() {
        return Vec3::ZERO;
    }
    let (scale, s) = unbounded_coefficients(rgb);
    s.eval_lanes(wl) * scale
}

/// The scale and sigmoid of an unbounded non-negative `rgb` ([`unbounded`] is the sigmoid × the
/// scale): for a colour used many times, fetched once.
#[inline]
pub fn unbounded_coefficients(rgb: Vec3) -> (f32, Sigmoid) {
    let m = rgb.max_element();
    if m <= 0.0 || !m.is_finite() {
        return (0.0, Sigmoid::constant(0.0));
    }
    let scale = 2.0 * m;
    (scale, coefficients(rgb.max(Vec3::ZERO) / scale))
}

/// An emitted radiance `rgb` at the wavelengths of `wl`: [`unbounded`] × D65.
#[inline]
pub fn illuminant(rgb: Vec3, wl: &Wavelengths) -> Vec3 {
    unbounded(rgb, wl) * wl.d65()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cie::{d65, reflectance_to_rgb, spectrum_to_xyz, XYZ_TO_SRGB};

    /// RGB → spectrum → XYZ → RGB within 1e-3 for in-gamut colours, on a grid that does not
    /// sit on the table's nodes.
    #[test]
    fn reflectance_round_trip() {
        let mut worst = (0.0f32, Vec3::ZERO);
        let steps = [0.03f32, 0.11, 0.27, 0.41, 0.5, 0.63, 0.77, 0.89, 0.97];
        for &r in &steps {
            for &g in &steps {
                for &b in &steps {
                    let rgb = Vec3::new(r, g, b);
                    let s = coefficients(rgb);
                    let back = reflectance_to_rgb(|l| s.eval(l));
                    let e = (back - rgb).abs().max_element();
                    if e > worst.0 {
                        worst = (e, rgb);
                    }
                }
            }
        }
        assert!(
            worst.0 < 1e-3,
            "worst round trip {} at {}",
            worst.0,
            worst.1
        );
    }

    #[test]
    fn greys_are_flat_and_bounded() {
        for v in [0.0f32, 0.18, 0.5, 0.9, 1.0] {
            let s = coefficients(Vec3::splat(v));
            for l in [380.0, 500.0, 700.0] {
                assert!((s.eval(l) - v).abs() < 1e-6, "{v} at {l}: {}", s.eval(l));
            }
        }
        // Saturated colours stay in [0, 1].
        let s = coefficients(Vec3::new(1.0, 0.0, 0.0));
        for l in (360..=830).step_by(10) {
            let v = s.eval(l as f32);
            assert!((0.0..=1.0).contains(&v));
        }
    }

    #[test]
    fn illuminant_is_linear_and_white_is_d65() {
        let wl = Wavelengths::fixed([450.0, 550.0, 650.0]);
        let a = illuminant(Vec3::new(2.0, 1.0, 0.5), &wl);
        let b = illuminant(Vec3::new(6.0, 3.0, 1.5), &wl);
        assert!((b - a * 3.0).abs().max_element() < 1e-4 * b.max_element());
        let w = illuminant(Vec3::ONE, &wl);
        for (i, l) in wl.lambda.iter().enumerate() {
            assert!((w[i] - d65(*l)).abs() < 1e-5, "{w}");
        }
        // An RGB emitter renders as its RGB.
        let rgb = Vec3::new(3.0, 1.5, 0.25);
        let s = |l: f32| illuminant(rgb, &Wavelengths::fixed([l; 3])).x;
        let back = XYZ_TO_SRGB * spectrum_to_xyz(s);
        assert!((back - rgb).abs().max_element() < 3e-3 * 3.0, "{back}");
    }
}
