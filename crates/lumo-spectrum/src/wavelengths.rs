//! The wavelengths one path carries (hero-wavelength spectral sampling, Wilkie et al. 2014).
//!
//! A path samples one hero wavelength from a density shaped like the visible response and
//! carries the others at equal offsets in the density's primary sample space, so each lane is
//! marginally distributed by that density and the lanes stratify the visible range together.
//! Everything non-dispersive along the path (directions, lobes, roulette) is shared by the
//! lanes, so their estimates use the same path density; at a dispersive interface the other
//! lanes stop and the hero carries the path alone (weight × lanes, as its own estimator).
//!
//! [`HERO_LANES`] is three, not Wilkie's four: every code path of the renderer — the scalar
//! integrator, the wavefront and the sixteen-wide vector bounce, the light tracer — carries
//! colour in three-lane vectors, and spectral rendering reuses all of them unchanged.

use glam::Vec3;

use crate::cie::{d65, xyz_bar, CIE_Y_INTEGRAL, XYZ_TO_SRGB};

/// Wavelengths a path carries.
pub const HERO_LANES: usize = 3;
/// Shortest wavelength sampled, nm.
pub const LAMBDA_MIN: f32 = 360.0;
/// Longest wavelength sampled, nm.
pub const LAMBDA_MAX: f32 = 830.0;

/// The wavelengths of one path and the weight of each lane's estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wavelengths {
    /// Wavelengths in nm; lane 0 is the hero.
    pub lambda: [f32; HERO_LANES],
    /// Density each was sampled with, per nm.
    pub pdf: [f32; HERO_LANES],
    /// Whether the secondary lanes were stopped (a dispersive interface).
    terminated: bool,
    /// D65 (luminance 1) at each wavelength: every RGB emitter multiplies by it.
    d65: [f32; HERO_LANES],
}

/// The sech² bump the visible sampling follows (per nm, normalised on [LAMBDA_MIN,
/// LAMBDA_MAX]): centred at 538 nm, the shape and constants of pbrt-v4's visible sampling
/// (Pharr, Jakob & Humphreys, 4th ed., §4.6.4), which follows the luminance response. (The
/// sampler uses its tabulated inverse; tests compare with this.)
#[cfg(test)]
fn sech2_pdf(lambda: f32) -> f32 {
    let c = (0.0072 * (lambda - 538.0)).cosh();
    0.003_939_804 / (c * c)
}

/// Inverse of the sech² bump's distribution function.
fn sech2_sample(u: f64) -> f64 {
    538.0 - 138.888_889 * (0.856_910_62 - 1.827_501_97 * u).atanh()
}

/// Segments of the tabulated inverse distribution.
const SEGMENTS: usize = 1024;

/// The sampling's inverse distribution function at u = i / SEGMENTS (the sech² bump's, exact
/// at the nodes) and, per segment, the density of the piecewise-linear λ(u) between them.
/// Sampling then costs a multiply and a lerp instead of a logarithm and an exponential per
/// lane (measured: 8 % of a spectral Cornell-box render before).
struct InverseCdf {
    lambda: [f32; SEGMENTS + 1],
    pdf: [f32; SEGMENTS],
}

fn inverse_cdf() -> &'static InverseCdf {
    static TABLE: std::sync::OnceLock<InverseCdf> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let mut lambda = [0.0f32; SEGMENTS + 1];
        for (i, l) in lambda.iter_mut().enumerate() {
            *l = (sech2_sample(i as f64 / SEGMENTS as f64) as f32).clamp(LAMBDA_MIN, LAMBDA_MAX);
        }
        lambda[0] = LAMBDA_MIN;
        lambda[SEGMENTS] = LAMBDA_MAX;
        let mut pdf = [0.0f32; SEGMENTS];
        for i in 0..SEGMENTS {
            pdf[i] = 1.0 / (SEGMENTS as f32 * (lambda[i + 1] - lambda[i]));
        }
        InverseCdf { lambda, pdf }
    })
}

/// Density of the visible-wavelength sampling (per nm): piecewise constant, following the
/// sech² bump of [`sech2_pdf`]; zero outside [LAMBDA_MIN, LAMBDA_MAX].
pub fn visible_pdf(lambda: f32) -> f32 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    let t = inverse_cdf();
    let i = t
        .lambda
        .partition_point(|&l| l <= lambda)
        .clamp(1, SEGMENTS)
        - 1;
    t.pdf[i]
}

/// A wavelength (nm) for `u` in [0, 1) and its density.
#[inline]
pub fn sample_visible(u: f32) -> (f32, f32) {
    let t = inverse_cdf();
    let x = (u * SEGMENTS as f32).clamp(0.0, SEGMENTS as f32 - 1e-3);
    let i = (x as usize).min(SEGMENTS - 1);
    let f = x - i as f32;
    (t.lambda[i] + (t.lambda[i + 1] - t.lambda[i]) * f, t.pdf[i])
}

impl Wavelengths {
    /// The wavelengths of a path whose primary sample is `u` in [0, 1).
    pub fn sample(u: f32) -> Self {
        let mut lambda = [0.0; HERO_LANES];
        let mut pdf = [0.0; HERO_LANES];
        for i in 0..HERO_LANES {
            let ui = (u + i as f32 / HERO_LANES as f32).fract();
            (lambda[i], pdf[i]) = sample_visible(ui);
        }
        Self {
            lambda,
            pdf,
            terminated: false,
            d65: lambda.map(d65),
        }
    }

    /// Fixed wavelengths with unit density (tests, and evaluating spectra at chosen lines).
    pub fn fixed(lambda: [f32; HERO_LANES]) -> Self {
        Self {
            lambda,
            pdf: [1.0; HERO_LANES],
            terminated: false,
            d65: lambda.map(d65),
        }
    }

    /// Illuminant D65 (luminance 1) at the lanes' wavelengths.
    #[inline]
    pub fn d65(&self) -> Vec3 {
        Vec3::from_array(self.d65)
    }

    /// The lanes' wavelengths mapped to [0, 1] over the sampled range (the sigmoid
    /// polynomials' parameter).
    #[inline]
    pub fn normalised(&self) -> Vec3 {
        (Vec3::from_array(self.lambda) - Vec3::splat(LAMBDA_MIN))
            * (1.0 / (LAMBDA_MAX - LAMBDA_MIN))
    }

    /// The hero wavelength.
    #[inline]
    pub fn hero(&self) -> f32 {
        self.lambda[0]
    }

    /// Stops the secondary lanes: from here on (and, since the decision belongs to the whole
    /// path, for what it gathered before) only the hero's estimate counts, with the weight of a
    /// single-wavelength estimator.
    #[inline]
    pub fn terminate_secondary(&mut self) {
        self.terminated = true;
    }

    /// Whether only the hero lane still counts.
    #[inline]
    pub fn is_terminated(&self) -> bool {
        self.terminated
    }

    /// The lanes that still count, as a 0/1 mask (throughput is multiplied by it at
    /// termination so secondary lanes stop doing work that would be thrown away).
    #[inline]
    pub fn live_mask(&self) -> Vec3 {
        if self.terminated {
            Vec3::X
        } else {
            Vec3::ONE
        }
    }

    /// Monte Carlo weight of each lane: 1 / (lanes · pdf), or 1 / pdf for a lone hero.
    #[inline]
    fn weights(&self) -> [f32; HERO_LANES] {
        let mut w = [0.0; HERO_LANES];
        if self.terminated {
            if self.pdf[0] > 0.0 {
                w[0] = 1.0 / self.pdf[0];
            }
        } else {
            for (w, &pdf) in w.iter_mut().zip(&self.pdf) {
                if pdf > 0.0 {
                    *w = 1.0 / (HERO_LANES as f32 * pdf);
                }
            }
        }
        w
    }

    /// Per lane, what its radiance adds to XYZ: the observer at its wavelength times its
    /// Monte Carlo weight, over the observer's normalisation.
    #[inline]
    fn xyz_weights(&self) -> [Vec3; HERO_LANES] {
        let w = self.weights();
        let mut out = [Vec3::ZERO; HERO_LANES];
        for i in 0..HERO_LANES {
            if w[i] != 0.0 {
                out[i] = xyz_bar(self.lambda[i]) * (w[i] / CIE_Y_INTEGRAL);
            }
        }
        out
    }

    /// CIE XYZ estimate of a path that carried radiance `l` (one value per lane).
    #[inline]
    pub fn to_xyz(&self, l: Vec3) -> Vec3 {
        let [a, b, c] = self.xyz_weights();
        a * l.x + b * l.y + c * l.z
    }

    /// Linear sRGB estimate of a path that carried radiance `l` (one value per lane).
    #[inline]
    pub fn to_rgb(&self, l: Vec3) -> Vec3 {
        XYZ_TO_SRGB * self.to_xyz(l)
    }

    /// [`Wavelengths::to_rgb`] of two radiances (a path's direct and indirect light), sharing
    /// the observer lookups.
    #[inline]
    pub fn to_rgb_pair(&self, l0: Vec3, l1: Vec3) -> (Vec3, Vec3) {
        let [a, b, c] = self.xyz_weights();
        let m = XYZ_TO_SRGB;
        (
            m * (a * l0.x + b * l0.y + c * l0.z),
            m * (a * l1.x + b * l1.y + c * l1.z),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cie::spectrum_to_xyz;

    #[test]
    fn visible_pdf_integrates_to_one_and_matches_its_sampler() {
        let n = 47_000;
        let dl = (LAMBDA_MAX - LAMBDA_MIN) / n as f32;
        let total: f64 = (0..n)
            .map(|i| visible_pdf(LAMBDA_MIN + (i as f32 + 0.5) * dl) as f64 * dl as f64)
            .sum();
        assert!((total - 1.0).abs() < 2e-3, "∫pdf = {total}");
        // The sampler's histogram follows the pdf: 47 bins of 10 nm, stratified u.
        let m = 200_000;
        let mut bins = [0u32; 47];
        for j in 0..m {
            let (l, pdf) = sample_visible((j as f32 + 0.5) / m as f32);
            assert_eq!(pdf, visible_pdf(l));
            bins[(((l - LAMBDA_MIN) / 10.0) as usize).min(46)] += 1;
        }
        for (b, &count) in bins.iter().enumerate() {
            let lo = LAMBDA_MIN + 10.0 * b as f32;
            let expect: f64 = (0..100)
                .map(|k| visible_pdf(lo + (k as f32 + 0.5) * 0.1) as f64 * 0.1)
                .sum::<f64>()
                * m as f64;
            let got = count as f64;
            assert!(
                (got - expect).abs() < 0.01 * expect + 3.0,
                "bin {lo} nm: {got} samples, expected {expect:.1}"
            );
        }
    }

    /// The tabulated density follows the sech² bump it is built from: within 1 % where most
    /// samples fall, 3 % in the tails (wider segments).
    #[test]
    fn tabulated_density_follows_the_bump() {
        for l in (365..=825).step_by(7) {
            let (a, b) = (visible_pdf(l as f32), sech2_pdf(l as f32));
            let tol = if (420..=700).contains(&l) { 0.01 } else { 0.03 };
            assert!((a / b - 1.0).abs() < tol, "{l} nm: {a} vs {b}");
        }
    }

    #[test]
    fn lanes_are_rotated_copies_of_the_hero() {
        let w = Wavelengths::sample(0.9);
        assert_eq!(w.lambda[0], sample_visible(0.9).0);
        assert_eq!(w.lambda[1], sample_visible((0.9f32 + 1.0 / 3.0).fract()).0);
        assert!(w
            .lambda
            .iter()
            .all(|l| (LAMBDA_MIN..=LAMBDA_MAX).contains(l)));
    }

    /// The estimator of a spectrum's XYZ averages to its integral, with and without termination.
    #[test]
    fn estimates_converge_to_the_integral() {
        let spd = |l: f32| 1.0 + 0.5 * ((l - 450.0) / 60.0).sin();
        let want = spectrum_to_xyz(spd);
        for terminate in [false, true] {
            let n = 100_000;
            let mut sum = glam::DVec3::ZERO;
            for j in 0..n {
                let mut w = Wavelengths::sample((j as f32 + 0.5) / n as f32);
                if terminate {
                    w.terminate_secondary();
                }
                let l = Vec3::from_array(w.lambda.map(spd));
                sum += w.to_xyz(l).as_dvec3();
            }
            let got = (sum / n as f64).as_vec3();
            assert!(
                (got - want).abs().max_element() < 2e-3 * want.max_element(),
                "terminate {terminate}: {got} vs {want}"
            );
        }
    }
}
