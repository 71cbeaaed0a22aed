//! Wavelength:value spectra to linear sRGB, as Mitsuba's RGB variants do for reflectances: the
//! spectrum lit by D65 is projected on the CIE 1931 observer and converted XYZ → sRGB, so that a
//! constant spectrum of 1 is RGB (1, 1, 1). Negative (out-of-gamut) results are clamped to 0.

use glam::{Mat3, Vec3};

/// CIE standard illuminant D65, 380–780 nm in 10 nm steps (relative power).
const D65: [f32; 41] = [
    49.98, 54.65, 82.75, 91.49, 93.43, 86.68, 104.86, 117.01, 117.81, 114.86, 115.92, 108.81,
    109.35, 107.80, 104.79, 107.69, 104.41, 104.05, 100.00, 96.33, 95.79, 88.69, 90.01, 89.60,
    87.70, 83.29, 83.70, 80.03, 80.21, 82.28, 78.28, 69.72, 71.61, 74.35, 61.60, 69.89, 75.09,
    63.59, 46.42, 66.81, 63.38,
];

fn d65(lambda: f32) -> f32 {
    let x = ((lambda - 380.0) / 10.0).clamp(0.0, 40.0);
    let i = (x as usize).min(39);
    let t = x - i as f32;
    D65[i] * (1.0 - t) + D65[i + 1] * t
}

/// Piecewise Gaussian used by the analytic CIE fit.
fn g(x: f32, mu: f32, s1: f32, s2: f32) -> f32 {
    let s = if x < mu { s1 } else { s2 };
    let t = (x - mu) / s;
    (-0.5 * t * t).exp()
}

/// CIE 1931 colour matching functions, multi-lobe Gaussian fit (Wyman, Sloan & Shirley 2013).
fn cie_xyz(l: f32) -> Vec3 {
    Vec3::new(
        1.056 * g(l, 599.8, 37.9, 31.0) + 0.362 * g(l, 442.0, 16.0, 26.7)
            - 0.065 * g(l, 501.1, 20.4, 26.2),
        0.821 * g(l, 568.8, 46.9, 40.5) + 0.286 * g(l, 530.9, 16.3, 31.1),
        1.217 * g(l, 437.0, 11.8, 36.0) + 0.681 * g(l, 459.0, 26.0, 13.8),
    )
}

fn xyz_to_srgb() -> Mat3 {
    Mat3::from_cols_array(&[
        3.240_454, -0.969_266, 0.055_643, -1.537_139, 1.876_011, -0.204_026, -0.498_531, 0.041_556,
        1.057_225,
    ])
}

/// Linear-sRGB of `value(λ)` under D65, unnormalised.
fn project(value: impl Fn(f32) -> f32) -> Vec3 {
    let mut xyz = Vec3::ZERO;
    let mut l = 360.0;
    while l <= 830.0 {
        xyz += cie_xyz(l) * (value(l) * d65(l));
        l += 1.0;
    }
    xyz_to_srgb() * xyz
}

/// RGB of the piecewise-linear spectrum through `pairs` (increasing wavelengths in nm; zero
/// outside their range, as Mitsuba's irregular spectra).
pub(crate) fn spectrum_to_rgb(pairs: &[(f32, f32)]) -> Vec3 {
    let value = |l: f32| -> f32 {
        let (Some(first), Some(last)) = (pairs.first(), pairs.last()) else {
            return 0.0;
        };
        if l < first.0 || l > last.0 {
            return 0.0;
        }
        if pairs.len() == 1 {
            return first.1;
        }
        let i = pairs
            .partition_point(|p| p.0 <= l)
            .clamp(1, pairs.len() - 1);
        let (a, b) = (pairs[i - 1], pairs[i]);
        let t = (l - a.0) / (b.0 - a.0);
        a.1 + (b.1 - a.1) * t
    };
    let white = project(|_| 1.0);
    (project(value) / white).max(Vec3::ZERO)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_spectrum_is_grey_and_matches_mitsuba() {
        let c = spectrum_to_rgb(&[(360.0, 1.0), (830.0, 1.0)]);
        assert!((c - Vec3::ONE).abs().max_element() < 1e-4, "{c}");
        // Mitsuba 3.9.1 scalar_rgb gives (0.878015, 0.635779, 0.270342) for this reflectance.
        let c = spectrum_to_rgb(&[(400.0, 0.1), (500.0, 0.5), (600.0, 0.8), (700.0, 0.9)]);
        let m = Vec3::new(0.878015, 0.635779, 0.270342);
        assert!(((c - m) / m).abs().max_element() < 0.03, "{c} vs {m}");
    }
}
