//! The smooth, bounded spectra RGB reflectances become (Jakob & Hanika 2019): a quadratic
//! polynomial in wavelength through a sigmoid, s(λ) = ½ + x / (2√(1 + x²)),
//! x = c₀t² + c₁t + c₂, with t the wavelength mapped from [360, 830] nm to [0, 1] (which keeps
//! the coefficients of similar size and the fit well conditioned).

use crate::wavelengths::{LAMBDA_MAX, LAMBDA_MIN};

/// A sigmoid-polynomial spectrum, values in (0, 1).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sigmoid {
    /// (c₀, c₁, c₂) of x = c₀t² + c₁t + c₂.
    pub c: [f32; 3],
}

/// `lambda` nm mapped to the polynomial's parameter t.
#[inline]
pub(crate) fn normalised(lambda: f32) -> f32 {
    (lambda - LAMBDA_MIN) * (1.0 / (LAMBDA_MAX - LAMBDA_MIN))
}

/// The sigmoid ½ + x / (2√(1 + x²)); finite at x = ±∞ (0 and 1).
#[inline]
pub(crate) fn sigmoid(x: f32) -> f32 {
    if x.is_infinite() {
        return if x > 0.0 { 1.0 } else { 0.0 };
    }
    0.5 + x / (2.0 * (1.0 + x * x).sqrt())
}

impl Sigmoid {
    /// The constant spectrum of value `v` in [0, 1] (the sigmoid inverted exactly).
    pub fn constant(v: f32) -> Self {
        let a = (2.0 * v - 1.0).clamp(-1.0, 1.0);
        let x = a / (1.0 - a * a).sqrt();
        Self { c: [0.0, 0.0, x] }
    }

    /// The spectrum at the wavelengths of `wl` (three lanes at once).
    #[inline]
    pub fn eval_lanes(&self, wl: &crate::Wavelengths) -> glam::Vec3 {
        let t = wl.normalised();
        let [c0, c1, c2] = self.c;
        let x = (t * c0 + c1) * t + c2;
        let q = glam::Vec3::ONE + x * x;
        let root = glam::Vec3::new(q.x.sqrt(), q.y.sqrt(), q.z.sqrt());
        let s = glam::Vec3::splat(0.5) + x * 0.5 / root;
        // x = ±∞ (a table node for a channel at exactly 0 or 1) is 0 or 1, not NaN.
        if s.is_finite() {
            s
        } else {
            glam::Vec3::from_array(wl.lambda.map(|l| self.eval(l)))
        }
    }

    /// The spectrum's value at `lambda` nm.
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        let t = normalised(lambda);
        let [c0, c1, c2] = self.c;
        sigmoid((c0 * t + c1) * t + c2)
    }
}
