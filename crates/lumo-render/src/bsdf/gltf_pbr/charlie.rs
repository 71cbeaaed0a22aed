//! KHR_materials_sheen's lobe: the "Charlie" distribution of Conty Estevez and Kulla (2017),
//! D(h) = (2 + 1/α)·sin(θh)^(1/α) / 2π with α = sheenRoughness², and their fitted visibility
//! 1 / ((1 + Λ(ωo) + Λ(ωi))·4 cos θo cos θi), as the extension's implementation notes give them
//! (Fresnel = 1); and the lobe's directional albedo E, tabulated once over view cosine and
//! roughness for the extension's albedo scaling of the layers below.
//!
//! The fitted Λ underestimates the masking of smooth sheens at grazing angles, where E then
//! exceeds 1 (2.5 at roughness 0.07 and cos θo = 0.01, 1.15 at roughness 0.2; below 1 from
//! roughness 0.3): the sheen layer divides the lobe by max(1, E(ωo), E(ωi)).

use std::f32::consts::PI;
use std::sync::OnceLock;

use glam::{Vec2, Vec3};

use super::albedo_table::grid;

/// The smallest sheen roughness used: below it the fibres all lie in the tangent plane and the
/// lobe narrows beyond what the table resolves (at this roughness it reflects under 1 % of
/// the light at view cosines above 0.3, and only towards grazing views).
pub(super) const MIN_SHEEN_ROUGHNESS: f32 = 0.07;

/// View cosines (evenly in √cos θo) and roughnesses (from [`MIN_SHEEN_ROUGHNESS`] to 1, evenly
/// in the square root of the distance from it, as E changes fastest at small roughness)
/// tabulated.
const COS_STEPS: usize = 32;
const ROUGHNESS_STEPS: usize = 32;
/// Quadrature points over incident directions per table entry: cos θi = u² (denser at grazing
/// angles, where the lobe peaks) by azimuth over half the circle (the lobe is symmetric).
const U_STEPS: usize = 96;
const PHI_STEPS: usize = 96;

/// The Charlie microfibre distribution of α at half-vector cosine `cos_h`.
#[inline]
fn distribution(alpha: f32, cos_h: f32) -> f32 {
    let inv = 1.0 / alpha;
    let sin2 = (1.0 - cos_h * cos_h).max(0.0);
    (2.0 + inv) * sin2.powf(0.5 * inv) / (2.0 * PI)
}

/// Conty Estevez and Kulla's fit of ln Λ near grazing angles, blended in (1 − α)².
#[inline]
fn fit(x: f32, alpha: f32) -> f32 {
    let t = (1.0 - alpha) * (1.0 - alpha);
    let mix = |a: f32, b: f32| a + (b - a) * t;
    let a = mix(21.5473, 25.3245);
    let b = mix(3.82987, 3.32435);
    let c = mix(0.19823, 0.16801);
    let d = mix(-1.97760, -1.27393);
    let e = mix(-4.32054, -4.85967);
    a / (1.0 + b * x.powf(c)) + d * x + e
}

/// The masking term Λ of the sheen at direction cosine `cos` (mirrored about 0.5 so that it is
/// smooth at normal incidence, as the fit's authors define it).
#[inline]
fn lambda(cos: f32, alpha: f32) -> f32 {
    let cos = cos.abs().min(1.0);
    if cos < 0.5 {
        fit(cos, alpha).exp()
    } else {
        (2.0 * fit(0.5, alpha) - fit(1.0 - cos, alpha)).exp()
    }
}

/// α of a perceptual sheen roughness (clamped to [`MIN_SHEEN_ROUGHNESS`], 1]).
#[inline]
pub(super) fn alpha_of(roughness: f32) -> f32 {
    let r = roughness.clamp(MIN_SHEEN_ROUGHNESS, 1.0);
    r * r
}

/// f·cos θi of a white sheen of α, both directions above the surface:
/// D(h) / (4 cos θo (1 + Λ(ωo) + Λ(ωi))).
#[inline]
pub(super) fn lobe(alpha: f32, wo: Vec3, wi: Vec3) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let Some(h) = (wo + wi).try_normalize() else {
        return 0.0;
    };
    let shadowing = 1.0 + lambda(wo.z, alpha) + lambda(wi.z, alpha);
    distribution(alpha, h.z) / (4.0 * wo.z * shadowing)
}

/// The sheen lobe's directional albedo over view cosine and roughness.
pub(super) struct SheenAlbedoTable {
    /// E at √cos θo = i/(COS_STEPS − 1) and roughness step j, row-major by j.
    albedo: Vec<f32>,
}

/// The shared table, computed on first use (about nine million lobe evaluations).
pub(super) fn sheen_table() -> &'static SheenAlbedoTable {
    static TABLE: OnceLock<SheenAlbedoTable> = OnceLock::new();
    TABLE.get_or_init(SheenAlbedoTable::compute)
}

/// The roughness at table step `j`.
fn roughness_at(j: usize) -> f32 {
    let t = j as f32 / (ROUGHNESS_STEPS - 1) as f32;
    MIN_SHEEN_ROUGHNESS + (1.0 - MIN_SHEEN_ROUGHNESS) * t * t
}

impl SheenAlbedoTable {
    fn compute() -> Self {
        let mut albedo = Vec::with_capacity(COS_STEPS * ROUGHNESS_STEPS);
        for j in 0..ROUGHNESS_STEPS {
            let alpha = alpha_of(roughness_at(j));
            for i in 0..COS_STEPS {
                let cos = (i as f32 / (COS_STEPS - 1) as f32).powi(2).max(1e-4);
                albedo.push(directional_albedo(alpha, cos));
            }
        }
        Self { albedo }
    }

    /// E at view cosine `cos` (its magnitude) and perceptual roughness `r`, bilinearly
    /// interpolated.
    #[inline]
    pub(super) fn albedo(&self, cos: f32, r: f32) -> f32 {
        let (i, fi) = grid(cos.abs().min(1.0).sqrt(), COS_STEPS);
        let t = ((r.clamp(MIN_SHEEN_ROUGHNESS, 1.0) - MIN_SHEEN_ROUGHNESS)
            / (1.0 - MIN_SHEEN_ROUGHNESS))
            .sqrt();
        let (j, fj) = grid(t, ROUGHNESS_STEPS);
        let at = |i: usize, j: usize| self.albedo[j * COS_STEPS + i];
        let row = |j: usize| at(i, j) * (1.0 - fi) + at(i + 1, j) * fi;
        row(j) * (1.0 - fj) + row(j + 1) * fj
    }
}

/// ∫ lobe dωi from cosine `cos` by the midpoint rule in (u, φ), cos θi = u², dωi = 2u du dφ.
fn directional_albedo(alpha: f32, cos: f32) -> f32 {
    let wo = Vec3::new((1.0 - cos * cos).max(0.0).sqrt(), 0.0, cos);
    let mut sum = 0.0f64;
    for a in 0..U_STEPS {
        let u = (a as f32 + 0.5) / U_STEPS as f32;
        let cos_i = u * u;
        let sin_i = (1.0 - cos_i * cos_i).max(0.0).sqrt();
        let mut ring = 0.0f64;
        for b in 0..PHI_STEPS {
            let phi = PI * (b as f32 + 0.5) / PHI_STEPS as f32;
            let (s, c) = phi.sin_cos();
            let wi = Vec3::new(sin_i * c, sin_i * s, cos_i);
            ring += f64::from(lobe(alpha, wo, wi));
        }
        sum += ring * f64::from(2.0 * u);
    }
    // Δu·Δφ, doubled for the other half of the circle.
    let cell = 2.0 * PI as f64 / (U_STEPS * PHI_STEPS) as f64;
    (sum * cell) as f32
}

/// A direction on the upper hemisphere for the sheen lobe: cosine-weighted (the lobe is broad
/// and has no closed-form sampling of its visible fibres).
#[inline]
pub(super) fn sample(u: Vec2) -> Vec3 {
    crate::geometry::square_to_cosine_hemisphere(u)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Charlie distribution is normalised as a microfacet distribution:
    /// ∫ D(h) cos θh dωh = 1 over the hemisphere (midpoint rule in cos θh).
    #[test]
    fn the_distribution_projects_to_one() {
        for r in [MIN_SHEEN_ROUGHNESS, 0.3, 0.6, 1.0] {
            let alpha = alpha_of(r);
            let n = 200_000;
            let sum: f64 = (0..n)
                .map(|k| {
                    let c = (k as f32 + 0.5) / n as f32;
                    f64::from(distribution(alpha, c) * c)
                })
                .sum();
            let projected = sum * 2.0 * std::f64::consts::PI / f64::from(n);
            assert!((projected - 1.0).abs() < 2e-3, "r {r}: {projected}");
        }
    }

    /// Λ is continuous where the fit is mirrored (cos θ = 0.5), grows without bound towards
    /// grazing angles and is small at normal incidence.
    #[test]
    fn the_masking_fit_is_continuous_and_grazing() {
        for r in [MIN_SHEEN_ROUGHNESS, 0.5, 1.0] {
            let alpha = alpha_of(r);
            let (below, above) = (lambda(0.5 - 1e-4, alpha), lambda(0.5 + 1e-4, alpha));
            assert!(
                (below - above).abs() < 1e-2 * below,
                "r {r}: {below} {above}"
            );
            assert!(lambda(0.001, alpha) > 100.0 * lambda(1.0, alpha), "r {r}");
            assert!(lambda(1.0, alpha) < 0.1, "r {r}: {}", lambda(1.0, alpha));
        }
    }
}
