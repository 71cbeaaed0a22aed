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

/// Quadrature samples, padded to a multiple of the lane count with zero weights.
const SAMPLES: usize = 96;
/// Lanes of the accumulation (written so the compiler keeps them in vector registers).
const LANES: usize = 8;

/// The quadrature of the fit: per sample, t and its RGB weight (D65 · observer → sRGB,
/// trapezoid weight, normalised so reflectance 1 is RGB (1, 1, 1)). Evaluated in f32 lanes:
/// a fit needs 1e-5, the table 786 432 fits, and f32 lanes made the table 3× faster to build
/// than the f64 loop it replaced.
pub(crate) struct Quadrature {
    t: [f32; SAMPLES],
    w: [[f32; SAMPLES]; 3],
}

impl Quadrature {
    /// The 5 nm quadrature of the CIE tables.
    pub(crate) fn new() -> Self {
        let mut q = Self {
            t: [0.0; SAMPLES],
            w: [[0.0; SAMPLES]; 3],
        };
        for (i, (l, dl)) in quadrature().enumerate() {
            let rgb = XYZ_TO_SRGB * xyz_bar(l) * (d65(l) * dl / CIE_Y_INTEGRAL);
            q.t[i] = normalised(l);
            for c in 0..3 {
                q.w[c][i] = rgb[c];
            }
        }
        q
    }

    /// RGB of coefficients `c` and its Jacobian (columns: ∂/∂c₀, ∂/∂c₁, ∂/∂c₂).
    #[allow(clippy::needless_range_loop)]
    fn rgb_and_jacobian(&self, c: DVec3) -> (DVec3, DMat3) {
        let (c0, c1, c2) = (c.x as f32, c.y as f32, c.z as f32);
        // acc[0..3]: RGB; acc[3..6], [6..9], [9..12]: ∂RGB/∂c₀, ∂c₁, ∂c₂.
        let mut acc = [[0.0f32; LANES]; 12];
        for k in (0..SAMPLES).step_by(LANES) {
            for l in 0..LANES {
                let t = self.t[k + l];
                let x = (c0 * t + c1) * t + c2;
                let r = 1.0 / (1.0 + x * x).sqrt();
                let s = 0.5 + 0.5 * x * r;
                // ds/dx = ½ (1 + x²)^(-3/2)
                let ds = 0.5 * r * r * r;
                for ch in 0..3 {
                    let w = self.w[ch][k + l];
                    acc[ch][l] += w * s;
                    acc[3 + ch][l] += w * ds * t * t;
                    acc[6 + ch][l] += w * ds * t;
                    acc[9 + ch][l] += w * ds;
                }
            }
        }
        let sum = |a: &[f32; LANES]| a.iter().map(|&v| v as f64).sum::<f64>();
        let v = |i: usize| DVec3::new(sum(&acc[i]), sum(&acc[i + 1]), sum(&acc[i + 2]));
        (v(0), DMat3::from_cols(v(3), v(6), v(9)))
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
            if err < 1e-10 {
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
