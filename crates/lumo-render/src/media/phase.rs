//! Phase functions: density and sampling of the scattered direction given the direction of
//! travel. Each is sampled exactly, so a phase sample's weight is 1.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};
use lumo_scene::PhaseFunction;

use crate::geometry::Basis;

/// Below this |g| Henyey–Greenstein is sampled as isotropic (its inversion formula divides by
/// g).
const ISOTROPIC_G: f32 = 1e-3;

/// The density (per steradian) of scattering from travel direction `d` into `wi` (both unit).
#[inline]
pub fn eval(phase: PhaseFunction, d: Vec3, wi: Vec3) -> f32 {
    match phase {
        PhaseFunction::Isotropic => 0.25 / PI,
        PhaseFunction::HenyeyGreenstein { g } => hg(g, d.dot(wi)),
    }
}

/// Henyey–Greenstein's density at the cosine `cos` between travel and scattered directions.
#[inline]
pub fn hg(g: f32, cos: f32) -> f32 {
    let denom = (1.0 + g * g - 2.0 * g * cos).max(1e-12);
    (1.0 - g * g) / (4.0 * PI * denom * denom.sqrt())
}

/// A scattered direction for travel direction `d` from `u` in [0, 1)², and its density.
#[inline]
pub fn sample(phase: PhaseFunction, d: Vec3, u: Vec2) -> (Vec3, f32) {
    let g = match phase {
        PhaseFunction::Isotropic => 0.0,
        PhaseFunction::HenyeyGreenstein { g } => g,
    };
    let cos = if g.abs() < ISOTROPIC_G {
        1.0 - 2.0 * u.x
    } else {
        // Inverting the cumulative distribution of the cosine.
        let s = (1.0 - g * g) / (1.0 + g - 2.0 * g * u.x);
        ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
    };
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    let local = Vec3::new(sin * phi.cos(), sin * phi.sin(), cos);
    let wi = Basis::new(d).to_world(local).normalize();
    (wi, eval(phase, d, wi))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ p dω = 1, by midpoint quadrature over the cosine (the density depends on it alone).
    #[test]
    fn henyey_greenstein_integrates_to_one() {
        for g in [-0.9f32, -0.3, 0.0, 0.5, 0.9, 0.99] {
            let n = 200_000;
            let sum: f64 = (0..n)
                .map(|i| {
                    let cos = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                    2.0 * std::f64::consts::PI * hg(g, cos as f32) as f64 * 2.0 / n as f64
                })
                .sum();
            assert!((sum - 1.0).abs() < 2e-3, "g = {g}: ∫p = {sum}");
        }
    }

    /// χ² test of sampled cosines against the density's bins (20 bins of equal expected
    /// count would need the CDF; equal-width bins in cos with expected counts from quadrature).
    #[test]
    fn henyey_greenstein_sampling_matches_its_density_chi_square() {
        let d = Vec3::new(0.3, -0.5, 0.8).normalize();
        for g in [-0.7f32, 0.0, 0.4, 0.9] {
            let phase = PhaseFunction::HenyeyGreenstein { g };
            let bins = 40;
            let n = 400_000u32;
            let mut counts = vec![0u32; bins];
            let mut state = 0x2545_f491_4f6c_dd1du64;
            let mut rnd = || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 40) as f32 / (1u64 << 24) as f32
            };
            for _ in 0..n {
                let (wi, pdf) = sample(phase, d, Vec2::new(rnd(), rnd()));
                assert!((wi.length() - 1.0).abs() < 1e-4);
                assert!((pdf - eval(phase, d, wi)).abs() <= 1e-3 * pdf.max(1.0));
                let c = d.dot(wi).clamp(-1.0, 1.0);
                let b = (((c + 1.0) / 2.0 * bins as f32) as usize).min(bins - 1);
                counts[b] += 1;
            }
            let mut chi2 = 0.0f64;
            let mut dof = 0;
            for (b, &count) in counts.iter().enumerate() {
                let (lo, hi) = (
                    -1.0 + 2.0 * b as f64 / bins as f64,
                    -1.0 + 2.0 * (b + 1) as f64 / bins as f64,
                );
                let m = 400;
                let p: f64 = (0..m)
                    .map(|i| {
                        let c = lo + (hi - lo) * (i as f64 + 0.5) / m as f64;
                        2.0 * std::f64::consts::PI * hg(g, c as f32) as f64 * (hi - lo) / m as f64
                    })
                    .sum();
                let expected = p * n as f64;
                if expected > 5.0 {
                    chi2 += (count as f64 - expected).powi(2) / expected;
                    dof += 1;
                }
            }
            // 99.9th percentile of χ² with ~40 degrees of freedom is ~73.4.
            assert!(chi2 < 80.0, "g = {g}: χ² = {chi2} over {dof} bins");
        }
    }

    #[test]
    fn forward_scattering_for_positive_g() {
        let d = Vec3::Z;
        assert!(eval(PhaseFunction::HenyeyGreenstein { g: 0.9 }, d, d) > 10.0);
        assert!(eval(PhaseFunction::HenyeyGreenstein { g: 0.9 }, d, -d) < 0.01);
    }
}
