//! Fitting sigmoid-polynomial coefficients to a target RGB (the optimisation behind the
//! coefficient table): damped Gauss–Newton (Levenberg–Marquardt) on the RGB residual, where
//! the RGB of a spectrum is its reflectance under D65 on the CIE observer, integrated at the
//! observer table's 5 nm samples.

use glam::{DMat3, DVec3};

use crate::cie::{d65, quadrature, xyz_bar, CIE_Y_INTEGRAL, XYZ_TO_SRGB};
use crate::sigmoid::normalised;

/// Most damped Gauss–Newton steps per fit: reachable targets converge in a handful from a
/// neighbour's solution; unreachable ones (a channel at 0 or 1) only creep towards infinity.
const FIT_ITERATIONS: usize = 24;

/// The quadrature of the fit: per sample, t and its RGB weight (D65 · observer → sRGB, trapezoid
/// weight, normalised so reflectance 1 is RGB (1, 1, 1)).
pub(crate) struct Quadrature {
    t: Vec<f64>,
    w: Vec<DVec3>,
}

impl Quadrature {
    /// The 5 nm quadrature of the CIE tables.
    pub(crate) fn new() -> Self {
        let (mut t, mut w) = (Vec::new(), Vec::new());
        for (l, dl) in quadrature() {
            let rgb = XYZ_TO_SRGB * xyz_bar(l) * (d65(l) * dl / CIE_Y_INTEGRAL);
            t.push(normalised(l) as f64);
            w.push(rgb.as_dvec3());
        }
        Self { t, w }
    }

    /// RGB of coefficients `c` and its Jacobian (columns: ∂/∂c₀, ∂/∂c₁, ∂/∂c₂).
    fn rgb_and_jacobian(&self, c: DVec3) -> (DVec3, DMat3) {
        let (mut rgb, mut j0, mut j1, mut j2) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
        for (&t, &w) in self.t.iter().zip(&self.w) {
            let x = (c.x * t + c.y) * t + c.z;
            let r = 1.0 / (1.0 + x * x).sqrt();
            let s = 0.5 + 0.5 * x * r;
            // ds/dx = ½ (1 + x²)^(-3/2)
            let ds = 0.5 * r * r * r;
            rgb += w * s;
            j0 += w * (ds * t * t);
            j1 += w * (ds * t);
            j2 += w * ds;
        }
        (rgb, DMat3::from_cols(j0, j1, j2))
    }

    /// Coefficients whose RGB is closest to `target`, starting from `start`; returns them and
    /// the remaining RGB error (max over channels). Targets outside what a bounded spectrum can
    /// reach (a channel at exactly 0 or 1) end at large coefficients with a small error.
    pub(crate) fn fit(&self, target: DVec3, start: DVec3) -> (DVec3, f64) {
        let mut c = start;
        let (mut rgb, mut jac) = self.rgb_and_jacobian(c);
        let mut err = (rgb - target).length_squared();
        let mut mu = 1e-3;
        for _ in 0..FIT_ITERATIONS {
            if err < 1e-11 {
                break;
            }
            let r = rgb - target;
            let jt = jac.transpose();
            let jtj = jt * jac;
            let g = jt * r;
            let damped = jtj + DMat3::from_diagonal(DVec3::splat(mu * diagonal_max(&jtj)));
            if damped.determinant().abs() < 1e-300 {
                break;
            }
            let step = damped.inverse() * g;
            let trial = c - step;
            let (rgb_t, jac_t) = self.rgb_and_jacobian(trial);
            let err_t = (rgb_t - target).length_squared();
            if err_t.is_finite() && err_t < err {
                (c, rgb, jac, err) = (trial, rgb_t, jac_t, err_t);
                mu = (mu * 0.3).max(1e-12);
            } else {
                mu *= 10.0;
                if mu > 1e12 {
                    break;
                }
            }
        }
        (c, (rgb - target).abs().max_element())
    }
}

/// Largest diagonal entry of `m` (the scale of the damping term).
fn diagonal_max(m: &DMat3) -> f64 {
    m.x_axis.x.max(m.y_axis.y).max(m.z_axis.z).max(1e-30)
}
