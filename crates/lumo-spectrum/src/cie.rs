//! The CIE 1931 2° standard observer, illuminant D65 and the XYZ ↔ linear sRGB matrices.
//!
//! Tables are linearly interpolated between their 5 nm samples and zero outside 360–830 nm.
//! D65 is normalised to luminance 1 (Y = 1 under the observer's normalisation below), so that
//! an emitter given as RGB (1, 1, 1) × D65 renders as RGB (1, 1, 1).

use glam::{Mat3, Vec3};

use crate::data::cie::{CIE_MIN, CIE_SAMPLES, CIE_STEP, CIE_X, CIE_Y, CIE_Z, D65};

/// ∫ ȳ(λ) dλ over the table (nm): XYZ = ∫ L(λ) (x̄, ȳ, z̄)(λ) dλ / CIE_Y_INTEGRAL, so a
/// spectrum of constant radiance 1 has Y = 1.
pub const CIE_Y_INTEGRAL: f32 = 106.856_895;

/// Linear interpolation of a 5 nm table at `lambda` (nm); 0 outside its range.
#[inline]
fn lerp_table(table: &[f32; CIE_SAMPLES], lambda: f32) -> f32 {
    let x = (lambda - CIE_MIN) / CIE_STEP;
    if !(0.0..=(CIE_SAMPLES - 1) as f32).contains(&x) {
        return 0.0;
    }
    let i = (x as usize).min(CIE_SAMPLES - 2);
    let t = x - i as f32;
    table[i] * (1.0 - t) + table[i + 1] * t
}

/// The colour-matching functions (x̄, ȳ, z̄) at `lambda` nm.
#[inline]
pub fn xyz_bar(lambda: f32) -> Vec3 {
    let x = (lambda - CIE_MIN) / CIE_STEP;
    if !(0.0..=(CIE_SAMPLES - 1) as f32).contains(&x) {
        return Vec3::ZERO;
    }
    let i = (x as usize).min(CIE_SAMPLES - 2);
    let t = x - i as f32;
    let node = |j: usize| Vec3::new(CIE_X[j], CIE_Y[j], CIE_Z[j]);
    node(i) * (1.0 - t) + node(i + 1) * t
}

/// Illuminant D65 at `lambda` nm, normalised to luminance 1.
#[inline]
pub fn d65(lambda: f32) -> f32 {
    lerp_table(&D65, lambda) * d65_normalisation()
}

/// The factor that gives D65 luminance 1: ∫ ȳ / ∫ D65·ȳ over the tables (trapezoid sums of
/// the 5 nm samples; the tables are linear between them).
fn d65_normalisation() -> f32 {
    static NORM: std::sync::OnceLock<f32> = std::sync::OnceLock::new();
    *NORM.get_or_init(|| {
        let y: f64 = trapezoid(|i| CIE_Y[i] as f64);
        let dy: f64 = trapezoid(|i| (CIE_Y[i] * D65[i]) as f64);
        (y / dy) as f32
    })
}

/// Trapezoid sum over the 5 nm table samples.
fn trapezoid(f: impl Fn(usize) -> f64) -> f64 {
    let n = CIE_SAMPLES;
    let inner: f64 = (1..n - 1).map(&f).sum();
    (inner + 0.5 * (f(0) + f(n - 1))) * CIE_STEP as f64
}

/// XYZ → linear sRGB (D65 white), IEC 61966-2-1.
pub const XYZ_TO_SRGB: Mat3 = Mat3::from_cols_array(&[
    3.240_454_2,
    -0.969_266,
    0.055_643_4,
    -1.537_138_5,
    1.876_010_8,
    -0.204_025_9,
    -0.498_531_4,
    0.041_556,
    1.057_225_2,
]);

/// Linear sRGB → XYZ (D65 white), IEC 61966-2-1.
pub const SRGB_TO_XYZ: Mat3 = Mat3::from_cols_array(&[
    0.412_456_4,
    0.212_672_9,
    0.019_333_9,
    0.357_576_1,
    0.715_152_2,
    0.119_192,
    0.180_437_5,
    0.072_175,
    0.950_304_1,
]);

/// The wavelengths (nm) and trapezoid weights (nm) of the 5 nm table samples: what fits and
/// tests integrate spectra with.
pub fn quadrature() -> impl Iterator<Item = (f32, f32)> {
    (0..CIE_SAMPLES).map(|i| {
        let w = if i == 0 || i == CIE_SAMPLES - 1 {
            0.5 * CIE_STEP
        } else {
            CIE_STEP
        };
        (CIE_MIN + CIE_STEP * i as f32, w)
    })
}

/// XYZ of a radiance spectrum `value(λ)` (integrated on the 5 nm table samples).
pub fn spectrum_to_xyz(value: impl Fn(f32) -> f32) -> Vec3 {
    let mut xyz = glam::DVec3::ZERO;
    for (l, w) in quadrature() {
        xyz += (xyz_bar(l) * (value(l) * w)).as_dvec3();
    }
    (xyz / CIE_Y_INTEGRAL as f64).as_vec3()
}

/// Linear sRGB of a reflectance spectrum `value(λ)` lit by D65 (so that reflectance 1 is
/// RGB (1, 1, 1)).
pub fn reflectance_to_rgb(value: impl Fn(f32) -> f32) -> Vec3 {
    XYZ_TO_SRGB * spectrum_to_xyz(|l| value(l) * d65(l))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn y_integral_matches_the_table() {
        let y = trapezoid(|i| CIE_Y[i] as f64) as f32;
        assert!((y - CIE_Y_INTEGRAL).abs() < 1e-3 * CIE_Y_INTEGRAL, "{y}");
    }

    #[test]
    fn d65_is_white_of_luminance_one() {
        let rgb = XYZ_TO_SRGB * spectrum_to_xyz(d65);
        for c in rgb.to_array() {
            assert!((c - 1.0).abs() < 2e-3, "{rgb}");
        }
        let white = reflectance_to_rgb(|_| 1.0);
        assert!((white - Vec3::ONE).abs().max_element() < 2e-3, "{white}");
    }

    #[test]
    fn matrices_are_inverse() {
        let m = XYZ_TO_SRGB * SRGB_TO_XYZ;
        assert!(m.abs_diff_eq(Mat3::IDENTITY, 1e-5), "{m}");
    }

    #[test]
    fn observer_peaks_where_the_cie_says() {
        // ȳ peaks at 555 nm with value 1; x̄ has its long-wave peak near 600 nm.
        assert!((xyz_bar(555.0).y - 1.0).abs() < 1e-3);
        assert!(xyz_bar(600.0).x > 1.0 && xyz_bar(600.0).x < 1.07);
        assert_eq!(xyz_bar(300.0), Vec3::ZERO);
    }
}
