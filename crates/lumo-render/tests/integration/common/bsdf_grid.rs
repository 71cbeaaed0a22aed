//! Directional albedo of a BSDF by deterministic sampling, shared by the glTF BSDF tests.

use glam::{Vec2, Vec3};
use lumo_render::bsdf::{Bsdf, BsdfSample};

/// A direction at cosine `c` from the normal and azimuth `phi`.
pub fn dir(c: f32, phi: f32) -> Vec3 {
    let s = (1.0 - c * c).max(0.0).sqrt();
    Vec3::new(s * phi.cos(), s * phi.sin(), c)
}

/// Calls `f` with every sample `b` draws from `wo` over a stratified `n`×`n` grid, each lobe
/// choice from a golden-ratio sequence (uncorrelated with the direction's point).
fn for_grid_samples(b: &Bsdf, wo: Vec3, n: usize, mut f: impl FnMut(&BsdfSample)) {
    for i in 0..n {
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let u_lobe = ((i * n + j) as f32 * 0.618_034).fract();
            if let Some(s) = b.sample(wo, u_lobe, u) {
                f(&s);
            }
        }
    }
}

/// The directional albedo from `wo` (both sides summed): the mean sample weight over the grid.
pub fn albedo(b: &Bsdf, wo: Vec3, n: usize) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for_grid_samples(b, wo, n, |s| sum += s.weight);
    sum / (n * n) as f32
}

/// Reflected and transmitted albedo from `wo`: the mean sample weights over the grid, split
/// by the side the sampled direction leaves to.
pub fn albedo_split(b: &Bsdf, wo: Vec3, n: usize) -> (Vec3, Vec3) {
    let (mut r, mut t) = (Vec3::ZERO, Vec3::ZERO);
    for_grid_samples(b, wo, n, |s| {
        if s.wi.z * wo.z > 0.0 {
            r += s.weight;
        } else {
            t += s.weight;
        }
    });
    let k = (n * n) as f32;
    (r / k, t / k)
}
