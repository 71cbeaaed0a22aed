//! The rough dielectric coat of Mitsuba 3's `roughplastic`: how much light the coat lets
//! through to the diffuse base from each direction, and how much of the base's diffuse
//! light the coat sends back down. Both are integrals over the coat's microfacets, tabulated
//! once per material the way Mitsuba does (the same quadrature, nodes and table), so the
//! diffuse layer's brightness matches Mitsuba's.

use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

use glam::{Vec2, Vec3};

use super::fresnel::fresnel_dielectric;
use super::microfacet::Microfacet;
use crate::geometry::reflect;

/// Table size over cos θ ∈ [0, 1] (Mitsuba's `MI_ROUGH_TRANSMITTANCE_RES`).
const RES: usize = 64;

/// The tabulated coat of a rough plastic.
#[derive(Clone, Debug, PartialEq)]
pub struct RoughCoat {
    /// Fraction of light from outside at cos θ = max(1e-6, i/63) that reaches the base
    /// (through the coat and not shadowed on the way).
    transmittance: [f32; RES],
    /// Fraction of light from outside at the same cosines that the coat's own microfacet lobe
    /// reflects (single scattering, as `Plastic::eval`'s coat term): the coat's share of the
    /// G-buffer albedo.
    reflectance: [f32; RES],
    /// Fraction of the base's cosine-distributed light that the coat reflects back down.
    pub internal_reflectance: f32,
    /// Fraction of cosine-distributed light from outside that reaches the base, 2∫ t(μ) μ dμ
    /// (the same 64-cosine mean): with `internal_reflectance` it gives the base's directional
    /// albedo through the coat (`Plastic::albedo`).
    pub diffuse_transmittance: f32,
}

impl RoughCoat {
    /// Integrates the coat of microfacet distribution `mf` (isotropic) and relative index
    /// `eta` (coat over outside), as Mitsuba's roughplastic does when it is created.
    pub fn new(mf: Microfacet, eta: f32) -> Self {
        let mus: Vec<f32> = (0..RES)
            .map(|i| (i as f32 / (RES - 1) as f32).max(1e-6))
            .collect();
        let dir = |mu: f32| Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let mut transmittance = [0.0; RES];
        let mut reflectance = [0.0; RES];
        for ((t, r), &mu) in transmittance.iter_mut().zip(&mut reflectance).zip(&mus) {
            *t = coat_integral(mf, dir(mu), eta, false);
            *r = coat_integral(mf, dir(mu), eta, true);
        }
        // Mitsuba's estimate of 2∫ R_int(μ) μ dμ: the mean over the same 64 cosines.
        let internal_reflectance = mus
            .iter()
            .map(|&mu| coat_integral(mf, dir(mu), 1.0 / eta, true) * mu)
            .sum::<f32>()
            / RES as f32
            * 2.0;
        let diffuse_transmittance = transmittance
            .iter()
            .zip(&mus)
            .map(|(&t, &mu)| t * mu)
            .sum::<f32>()
            / RES as f32
            * 2.0;
        Self {
            transmittance,
            reflectance,
            internal_reflectance,
            diffuse_transmittance,
        }
    }

    /// The coat for (`mf`, `eta`), computed once per process and shared.
    ///
    /// Shading-point BSDFs are small `Copy` values, so they refer to the table rather than
    /// carry it; interning gives the reference a `'static` lifetime. Each distinct coat
    /// stays allocated (~260 bytes) for the life of the process — bounded by the distinct
    /// (distribution, α, η) triples ever loaded, each of which costs far more time to
    /// integrate than it keeps in memory.
    pub fn shared(mf: Microfacet, eta: f32) -> &'static RoughCoat {
        type Key = (u8, u32, u32);
        static CACHE: OnceLock<Mutex<HashMap<Key, &'static RoughCoat>>> = OnceLock::new();
        let key = (mf.distribution as u8, mf.alpha_u.to_bits(), eta.to_bits());
        let cache = CACHE.get_or_init(Default::default);
        // Held while integrating, so no coat is computed (and kept) twice. A poisoned lock
        // only means another thread panicked; the map holds finished values only.
        let mut map = cache.lock().unwrap_or_else(|e| e.into_inner());
        map.entry(key)
            .or_insert_with(|| Box::leak(Box::new(RoughCoat::new(mf, eta))))
    }

    /// Transmittance into the coat from cos θ = `cos` (linear interpolation in the table,
    /// as Mitsuba's `lerp_gather`).
    #[inline]
    pub fn transmittance(&self, cos: f32) -> f32 {
        lerp_table(&self.transmittance, cos)
    }

    /// The coat lobe's own reflectance at `cos` (linear in the table; for the G-buffer).
    pub fn reflectance(&self, cos: f32) -> f32 {
        lerp_table(&self.reflectance, cos)
    }
}

/// A table over cos θ ∈ [0, 1] at `cos`, linearly interpolated.
fn lerp_table(table: &[f32; RES], cos: f32) -> f32 {
    let x = cos * (RES - 1) as f32;
    // `as` saturates: negative and NaN cosines land on the first cell.
    let i = (x as usize).min(RES - 2);
    let f = x - i as f32;
    table[i] * (1.0 - f) + table[i + 1] * f
}

/// ∫ over the normals visible from `wi` of G1(wo, m)·F (reflection, `reflect`) or
/// G1(wo, m)·(1 − F) (refraction), with wo the scattered direction: the energy that leaves
/// the interface on that side. Gauss–Legendre in both sample dimensions, 32² nodes for
/// η > 1 and 128² otherwise (total internal reflection makes that integrand rougher).
fn coat_integral(mf: Microfacet, wi: Vec3, eta: f32, reflection: bool) -> f32 {
    let n = if eta > 1.0 { 32 } else { 128 };
    let (nodes, weights) = gauss_legendre(n);
    let mut sum = 0.0f64;
    for (&x, &wx) in nodes.iter().zip(&weights) {
        for (&y, &wy) in nodes.iter().zip(&weights) {
            let u = Vec2::new(0.5 * x as f32 + 0.5, 0.5 * y as f32 + 0.5);
            let m = mf.sample_visible(wi, u);
            let cos_im = wi.dot(m);
            let (f, cos_t, _, eta_ti) = fresnel_dielectric(cos_im, eta);
            let value = if reflection {
                let wo = reflect(wi, m);
                if wo.z <= 0.0 || wi.z <= 0.0 {
                    0.0
                } else {
                    mf.g1(wo, m) * f
                }
            } else {
                let wo = m * (cos_im * eta_ti + cos_t) - wi * eta_ti;
                if wo.z * wi.z >= 0.0 {
                    0.0
                } else {
                    mf.g1(wo, m) * (1.0 - f)
                }
            };
            sum += value as f64 * wx * wy * 0.25;
        }
    }
    sum as f32
}

/// Nodes and weights of the `n`-point Gauss–Legendre rule on [−1, 1] (Newton on the
/// Legendre polynomial from Chebyshev-like first guesses, in f64).
fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n {
        let mut x = -(std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            // P_n(x) and P_n'(x) by the three-term recurrence.
            let (mut p0, mut p1) = (1.0f64, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        nodes[i] = x;
        weights[i] = 2.0 / ((1.0 - x * x) * dp * dp);
    }
    (nodes, weights)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{fresnel_diffuse_reflectance, Distribution};

    #[test]
    fn gauss_legendre_integrates_polynomials() {
        let (x, w) = gauss_legendre(32);
        let s: f64 = w.iter().sum();
        assert!((s - 2.0).abs() < 1e-12, "{s}");
        // ∫ x^62 dx = 2/63, exact for 32 nodes (degree ≤ 63).
        let p: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(62)).sum();
        assert!((p - 2.0 / 63.0).abs() < 1e-12, "{p}");
    }

    #[test]
    fn nearly_smooth_coat_is_fresnel() {
        // At tiny α the coat is a smooth interface: transmittance 1 − F, internal
        // reflectance the diffuse Fresnel reflectance.
        let coat = RoughCoat::new(Microfacet::ggx(1e-3), 1.5);
        for mu in [0.2f32, 0.5, 0.9] {
            let t = coat.transmittance(mu);
            let f = 1.0 - fresnel_dielectric(mu, 1.5).0;
            assert!((t - f).abs() < 2e-3, "μ {mu}: {t} vs {f}");
        }
        let r = coat.internal_reflectance;
        let fdr = fresnel_diffuse_reflectance(1.0 / 1.5);
        // The table's 64-point mean is a coarse quadrature near the critical angle.
        assert!((r - fdr).abs() < 0.02, "{r} vs {fdr}");
    }

    #[test]
    fn quadrature_matches_monte_carlo() {
        // The tabulated integrals against a plain Monte Carlo estimate of the same integrand
        // (random visible normals): the Gauss–Legendre rule and its mapping to the sample
        // square are right. Rough coats (where the integrand is far from Fresnel's).
        for d in [Distribution::Ggx, Distribution::Beckmann] {
            let mf = Microfacet::isotropic(d, 0.4);
            let coat = RoughCoat::new(mf, 1.5);
            let mut state = 0x9e37_79b9_7f4a_7c15u64;
            let mut rnd = || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 40) as f32 / (1u64 << 24) as f32
            };
            for (i, eta, reflection) in [(21, 1.5, false), (40, 1.5, false), (50, 1.0 / 1.5, true)]
            {
                let mu = i as f32 / 63.0;
                let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                let n = 400_000;
                let mut sum = 0.0f64;
                for _ in 0..n {
                    let m = mf.sample_visible(wi, Vec2::new(rnd(), rnd()));
                    let (f, cos_t, _, eta_ti) = fresnel_dielectric(wi.dot(m), eta);
                    sum += if reflection {
                        let wo = reflect(wi, m);
                        if wo.z > 0.0 {
                            mf.g1(wo, m) * f
                        } else {
                            0.0
                        }
                    } else {
                        let wo = m * (wi.dot(m) * eta_ti + cos_t) - wi * eta_ti;
                        if wo.z < 0.0 {
                            mf.g1(wo, m) * (1.0 - f)
                        } else {
                            0.0
                        }
                    } as f64;
                }
                let mc = (sum / n as f64) as f32;
                let quad = if reflection {
                    coat_integral(mf, wi, eta, true)
                } else {
                    coat.transmittance(mu)
                };
                assert!(
                    (mc - quad).abs() < 3e-3,
                    "{d:?} μ {mu}: quadrature {quad}, MC {mc}"
                );
            }
            // Energy: what gets through plus what the coat reflects is at most everything.
            assert!(coat.transmittance(1.0) <= 1.0 - 0.04 + 1e-3);
            assert!(coat.internal_reflectance > 0.0 && coat.internal_reflectance < 1.0);
        }
    }
}
