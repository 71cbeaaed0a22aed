//! The RGB → sigmoid-coefficient table (Jakob & Hanika 2019, §4), fitted by lumo itself the
//! first time spectral rendering needs it.
//!
//! The table is indexed by the largest RGB channel (three slabs), that channel's value `k`
//! (nodes denser near 0 and 1, where the coefficients change fastest) and the two other
//! channels relative to it. Each node is a fit of [`crate::fit`]; nodes are fitted along `k`
//! from the middle outwards, each starting from its neighbour's solution (the coefficients
//! are smooth in `k` except at the ends, so few iterations are needed). Lookups interpolate
//! the coefficients trilinearly.
//!
//! 64 nodes per axis keep the round trip RGB → spectrum → RGB within 1e-3 between nodes (32
//! measured 2.2e-3). Fitting all 786 432 nodes takes a few seconds on two cores (numbers in
//! docs/spectral.md), so the table is built lazily, once per process and only by spectral
//! renders, rather than committed (9 MB) or generated at compile time.

use std::sync::OnceLock;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::fit::Quadrature;
use crate::sigmoid::Sigmoid;

/// Nodes per axis.
pub const TABLE_RES: usize = 64;

/// RGB → coefficient table.
pub struct CoefficientTable {
    /// Node values of the largest channel.
    scale: Vec<f32>,
    /// Coefficients, indexed [slab][k][y][x].
    coeffs: Vec<[f32; 3]>,
    /// Largest RGB error of a node fit whose target a bounded spectrum can reach (all channels
    /// in [0.02, 0.98] relative to 1): how exactly the table reproduces its nodes.
    pub max_node_error: f64,
}

/// `smoothstep` on [0, 1].
fn smoothstep(x: f64) -> f64 {
    x * x * (3.0 - 2.0 * x)
}

impl CoefficientTable {
    /// Fits a table with `res` nodes per axis (rows in parallel).
    // The chains walk k up and down from the middle, indexing `scale` and the output by it.
    #[allow(clippy::needless_range_loop)]
    pub fn build(res: usize) -> Self {
        let res = res.max(4);
        let q = Quadrature::new();
        let scale: Vec<f32> = (0..res)
            .map(|i| smoothstep(smoothstep(i as f64 / (res - 1) as f64)) as f32)
            .collect();
        let start_k = res / 5;
        // One job per (slab, y, x): the chain of fits along k.
        let chains: Vec<(Vec<[f32; 3]>, f64)> = (0..3 * res * res)
            .into_par_iter()
            .map(|job| {
                let (slab, y, x) = (job / (res * res), (job / res) % res, job % res);
                let xf = x as f64 / (res - 1) as f64;
                let yf = y as f64 / (res - 1) as f64;
                let target = |k: f64| {
                    let mut rgb = [0.0; 3];
                    rgb[slab] = k;
                    rgb[(slab + 1) % 3] = xf * k;
                    rgb[(slab + 2) % 3] = yf * k;
                    DVec3::from_array(rgb)
                };
                let mut out = vec![[0.0f32; 3]; res];
                let mut worst = 0.0f64;
                let mut record = |k: usize, c: DVec3, err: f64, out: &mut Vec<[f32; 3]>| {
                    out[k] = c.as_vec3().to_array();
                    let t = target(scale[k] as f64);
                    let reachable = t.min_element() >= 0.02 && t.max_element() <= 0.98;
                    if reachable {
                        worst = worst.max(err);
                    }
                };
                let mut c = DVec3::ZERO;
                for k in start_k..res {
                    let (fit, err) = q.fit(target(scale[k] as f64), c);
                    c = fit;
                    record(k, c, err, &mut out);
                }
                c = DVec3::from_array(out[start_k].map(|v| v as f64));
                for k in (0..start_k).rev() {
                    let (fit, err) = q.fit(target(scale[k] as f64), c);
                    c = fit;
                    record(k, c, err, &mut out);
                }
                (out, worst)
            })
            .collect();
        let mut coeffs = vec![[0.0f32; 3]; 3 * res * res * res];
        let mut max_node_error = 0.0f64;
        for (job, (chain, worst)) in chains.into_iter().enumerate() {
            let (slab, y, x) = (job / (res * res), (job / res) % res, job % res);
            for (k, c) in chain.into_iter().enumerate() {
                coeffs[((slab * res + k) * res + y) * res + x] = c;
            }
            max_node_error = max_node_error.max(worst);
        }
        Self {
            scale,
            coeffs,
            max_node_error,
        }
    }

    /// Nodes per axis.
    pub fn resolution(&self) -> usize {
        self.scale.len()
    }

    /// The coefficients of reflectance `rgb` (clamped to [0, 1]).
    pub fn lookup(&self, rgb: Vec3) -> Sigmoid {
        let rgb = rgb.clamp(Vec3::ZERO, Vec3::ONE);
        if rgb.x == rgb.y && rgb.y == rgb.z {
            return Sigmoid::constant(rgb.x);
        }
        let a = rgb.to_array();
        let slab = if a[0] >= a[1] && a[0] >= a[2] {
            0
        } else if a[1] >= a[2] {
            1
        } else {
            2
        };
        let res = self.scale.len();
        let k = a[slab];
        let last = (res - 1) as f32;
        let x = (a[(slab + 1) % 3] / k * last).clamp(0.0, last);
        let y = (a[(slab + 2) % 3] / k * last).clamp(0.0, last);
        let (xi, yi) = ((x as usize).min(res - 2), (y as usize).min(res - 2));
        let (tx, ty) = (x - xi as f32, y - yi as f32);
        // The last node whose scale is ≤ k.
        let ki = self.scale.partition_point(|&s| s <= k).clamp(1, res - 1) - 1;
        let tk = ((k - self.scale[ki]) / (self.scale[ki + 1] - self.scale[ki])).clamp(0.0, 1.0);
        let at = |dk: usize, dy: usize, dx: usize| {
            Vec3::from_array(self.coeffs[((slab * res + ki + dk) * res + yi + dy) * res + xi + dx])
        };
        let lerp = |a: Vec3, b: Vec3, t: f32| a + (b - a) * t;
        let mut c = Vec3::ZERO;
        for dk in 0..2 {
            let plane = lerp(
                lerp(at(dk, 0, 0), at(dk, 0, 1), tx),
                lerp(at(dk, 1, 0), at(dk, 1, 1), tx),
                ty,
            );
            c += plane * if dk == 0 { 1.0 - tk } else { tk };
        }
        Sigmoid { c: c.to_array() }
    }
}

/// The process-wide table ([`TABLE_RES`] nodes per axis), fitted on first use.
pub fn coefficient_table() -> &'static CoefficientTable {
    static TABLE: OnceLock<CoefficientTable> = OnceLock::new();
    TABLE.get_or_init(|| CoefficientTable::build(TABLE_RES))
}

/// The sigmoid spectrum of reflectance `rgb` (clamped to [0, 1]) from the process-wide table.
#[inline]
pub fn coefficients(rgb: Vec3) -> Sigmoid {
    coefficient_table().lookup(rgb)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Nodes whose colour a bounded spectrum can reach are fitted exactly.
    #[test]
    fn reachable_nodes_are_fitted_exactly() {
        let t = std::time::Instant::now();
        let table = coefficient_table();
        eprintln!(
            "table {}³×3 built in {:.2} s (or earlier by another test); worst node error {:.2e}",
            table.resolution(),
            t.elapsed().as_secs_f64(),
            table.max_node_error
        );
        assert!(table.max_node_error < 2e-5, "{}", table.max_node_error);
    }
}
