//! The dielectric specular layer's directional albedo, tabulated over view cosine and
//! roughness. Schlick's Fresnel is linear in F0 (F = F0·(1 − c) + c, c = (1 − cos)⁵), so the
//! albedo is too: E(F0) = F0·A + B, with A and B the albedo of the two terms. Tabulating A and
//! B once serves every F0 that KHR_materials_ior and KHR_materials_specular can give.

use std::sync::OnceLock;

use glam::{Vec2, Vec3};

use super::super::{Microfacet, SMOOTH_ALPHA};
use crate::geometry::reflect;

/// View cosines and roughnesses tabulated (the cosines evenly in √cos θo, as E changes fastest
/// at grazing views).
const COS_STEPS: usize = 32;
const ROUGHNESS_STEPS: usize = 24;
/// Visible normals per table entry (a stratified grid of this size squared).
const STRATA: usize = 48;

/// The two parts (A, B) of the specular layer's directional albedo E = F0·A + B (GGX with
/// separable Smith masking) and their cosine-weighted means.
pub struct GltfAlbedoTable {
    /// (A, B) at √cos θo = i/(COS_STEPS − 1) and roughness j/(ROUGHNESS_STEPS − 1),
    /// row-major by j.
    albedo: Vec<Vec2>,
    /// 2∫(A, B)(μ)μ dμ per roughness step (of the interpolated table, so the diffuse weights
    /// integrate exactly).
    average: Vec<Vec2>,
}

/// The shared table, computed on first use (about a million microfacet samples).
pub(super) fn table() -> &'static GltfAlbedoTable {
    static TABLE: OnceLock<GltfAlbedoTable> = OnceLock::new();
    TABLE.get_or_init(GltfAlbedoTable::compute)
}

/// GGX of perceptual roughness `r` (α = r²) as the glTF BSDF builds it.
pub(super) fn ggx_of_roughness(r: f32) -> Microfacet {
    let alpha = r * r;
    Microfacet::ggx(if alpha < SMOOTH_ALPHA {
        0.0
    } else {
        alpha.max(1e-4)
    })
}

impl GltfAlbedoTable {
    fn compute() -> Self {
        let mut albedo = Vec::with_capacity(COS_STEPS * ROUGHNESS_STEPS);
        for j in 0..ROUGHNESS_STEPS {
            let mf = ggx_of_roughness(j as f32 / (ROUGHNESS_STEPS - 1) as f32);
            for i in 0..COS_STEPS {
                let cos = (i as f32 / (COS_STEPS - 1) as f32).powi(2).max(1e-4);
                albedo.push(if mf.max_alpha() < SMOOTH_ALPHA {
                    let c = schlick_weight(cos);
                    Vec2::new(1.0 - c, c)
                } else {
                    specular_albedo(mf, cos)
                });
            }
        }
        let mut t = Self {
            albedo,
            average: vec![Vec2::ZERO; ROUGHNESS_STEPS],
        };
        const N: usize = 1024;
        for j in 0..ROUGHNESS_STEPS {
            let r = j as f32 / (ROUGHNESS_STEPS - 1) as f32;
            let sum: Vec2 = (0..N)
                .map(|k| {
                    let mu = (k as f32 + 0.5) / N as f32;
                    t.parts(mu, r) * mu
                })
                .sum();
            t.average[j] = 2.0 * sum / N as f32;
        }
        t
    }

    /// (A, B) at view cosine `cos` and roughness `r`, bilinearly interpolated.
    #[inline]
    fn parts(&self, cos: f32, r: f32) -> Vec2 {
        let (i, fi) = grid(cos.max(0.0).sqrt(), COS_STEPS);
        let (j, fj) = grid(r, ROUGHNESS_STEPS);
        let at = |i: usize, j: usize| self.albedo[j * COS_STEPS + i];
        let row = |j: usize| at(i, j) * (1.0 - fi) + at(i + 1, j) * fi;
        row(j) * (1.0 - fj) + row(j + 1) * fj
    }

    /// E at view cosine `cos` and roughness `r` for a (scalar) normal-incidence reflectance
    /// `f0`.
    #[inline]
    pub(super) fn albedo(&self, cos: f32, r: f32, f0: f32) -> f32 {
        let ab = self.parts(cos, r);
        f0 * ab.x + ab.y
    }

    /// E per channel of a coloured `f0`.
    #[inline]
    pub(super) fn albedo_rgb(&self, cos: f32, r: f32, f0: Vec3) -> Vec3 {
        let ab = self.parts(cos, r);
        f0 * ab.x + Vec3::splat(ab.y)
    }

    /// E_avg (the cosine-weighted mean of E) at roughness `r` for `f0`, linearly interpolated.
    #[inline]
    pub(super) fn average(&self, r: f32, f0: f32) -> f32 {
        let (j, fj) = grid(r, ROUGHNESS_STEPS);
        let ab = self.average[j] * (1.0 - fj) + self.average[j + 1] * fj;
        f0 * ab.x + ab.y
    }
}

/// Schlick's (1 − cos)⁵.
#[inline]
pub(super) fn schlick_weight(cos: f32) -> f32 {
    (1.0 - cos.clamp(0.0, 1.0)).powi(5)
}

/// The cell of `x` ∈ [0, 1] on a grid of `n` points and the fraction into it (shared with
/// the sheen's table, `charlie.rs`).
#[inline]
pub(super) fn grid(x: f32, n: usize) -> (usize, f32) {
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    } * (n - 1) as f32;
    let i = (x as usize).min(n - 2);
    (i, x - i as f32)
}

/// (A, B) seen from cosine `cos`: the mean, over visible normals on a stratified grid, of the
/// sampled reflection's weight G1(ωi, m) times (1 − c) and c, c = (1 − ωo·m)⁵.
fn specular_albedo(mf: Microfacet, cos: f32) -> Vec2 {
    let wo = Vec3::new((1.0 - cos * cos).max(0.0).sqrt(), 0.0, cos);
    let (mut a, mut b) = (0.0f64, 0.0f64);
    for i in 0..STRATA {
        for k in 0..STRATA {
            let u = Vec2::new(
                (i as f32 + 0.5) / STRATA as f32,
                (k as f32 + 0.5) / STRATA as f32,
            );
            let m = mf.sample_visible(wo, u);
            let wi = reflect(wo, m);
            if wi.z > 0.0 {
                let c = schlick_weight(wo.dot(m));
                let g = f64::from(mf.g1(wi, m));
                a += f64::from(1.0 - c) * g;
                b += f64::from(c) * g;
            }
        }
    }
    let n = (STRATA * STRATA) as f64;
    Vec2::new((a / n) as f32, (b / n) as f32)
}
