//! A scalar voxel grid of densities with trilinear lookup and a coarse majorant grid, so that
//! free-flight sampling takes long steps where the grid is thin.

use glam::Vec3;

/// Voxels per majorant cell along each axis.
pub const MAJORANT_BLOCK: usize = 8;

/// The most voxels a grid may have (2²⁷: 512 MiB of densities), so that a header claiming a
/// huge grid is refused before anything is allocated.
pub const MAX_GRID_VOXELS: u64 = 1 << 27;

/// Densities on a regular grid over the unit cube, voxel centres at (i + ½)/res (Mitsuba's
/// `gridvolume` with trilinear filtering and clamped lookups).
#[derive(Clone, Debug)]
pub struct DensityGrid {
    res: [usize; 3],
    data: Vec<f32>,
    max: f32,
    /// Resolution of the majorant grid.
    cells: [usize; 3],
    /// Per cell of [`MAJORANT_BLOCK`]³ voxels, the largest density a trilinear lookup inside
    /// it can return.
    majorant: Vec<f32>,
}

impl DensityGrid {
    /// A grid of `res` voxels, x fastest then y then z. Errors (as text, for the caller to
    /// place) when the size does not match or a density is negative or not finite.
    pub fn new(res: [usize; 3], data: Vec<f32>) -> Result<DensityGrid, String> {
        let n = res.iter().try_fold(1usize, |a, &r| a.checked_mul(r));
        if res.contains(&0) || n != Some(data.len()) {
            return Err(format!(
                "the grid is {}×{}×{} voxels but holds {} values",
                res[0],
                res[1],
                res[2],
                data.len()
            ));
        }
        if let Some(i) = data.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
            let (x, y, z) = (i % res[0], i / res[0] % res[1], i / (res[0] * res[1]));
            return Err(format!(
                "voxel ({x}, {y}, {z}) has density {}; densities must be finite and ≥ 0",
                data[i]
            ));
        }
        let max = data.iter().fold(0.0f32, |a, &v| a.max(v));
        let cells = res.map(|r| r.div_ceil(MAJORANT_BLOCK));
        let mut majorant = vec![0.0f32; cells[0] * cells[1] * cells[2]];
        for cz in 0..cells[2] {
            for cy in 0..cells[1] {
                for cx in 0..cells[0] {
                    // A lookup inside the cell blends voxels up to one beyond its edges.
                    let range = |c: usize, r: usize| {
                        let lo = (c * MAJORANT_BLOCK).saturating_sub(1);
                        let hi = ((c + 1) * MAJORANT_BLOCK + 1).min(r);
                        lo..hi
                    };
                    let mut m = 0.0f32;
                    for z in range(cz, res[2]) {
                        for y in range(cy, res[1]) {
                            let row = (z * res[1] + y) * res[0];
                            for x in range(cx, res[0]) {
                                m = m.max(data[row + x]);
                            }
                        }
                    }
                    majorant[(cz * cells[1] + cy) * cells[0] + cx] = m;
                }
            }
        }
        Ok(DensityGrid {
            res,
            data,
            max,
            cells,
            majorant,
        })
    }

    /// Voxels along x, y, z.
    pub fn resolution(&self) -> [usize; 3] {
        self.res
    }

    /// The largest density.
    pub fn max(&self) -> f32 {
        self.max
    }

    /// Majorant cells along x, y, z.
    pub fn majorant_resolution(&self) -> [usize; 3] {
        self.cells
    }

    /// The majorant of cell (x, y, z) (in range).
    #[inline]
    pub fn majorant(&self, x: usize, y: usize, z: usize) -> f32 {
        self.majorant[(z * self.cells[1] + y) * self.cells[0] + x]
    }

    /// The trilinearly interpolated density at `p` in the unit cube (coordinates clamped to
    /// the outermost voxel centres); 0 outside the cube.
    #[inline]
    pub fn density(&self, p: Vec3) -> f32 {
        if !(p.cmpge(Vec3::ZERO).all() && p.cmple(Vec3::ONE).all()) {
            return 0.0;
        }
        let mut i0 = [0usize; 3];
        let mut i1 = [0usize; 3];
        let mut f = [0.0f32; 3];
        for a in 0..3 {
            let r = self.res[a];
            let u = (p[a] * r as f32 - 0.5).clamp(0.0, (r - 1) as f32);
            let lo = (u as usize).min(r - 1);
            i0[a] = lo;
            i1[a] = (lo + 1).min(r - 1);
            f[a] = u - lo as f32;
        }
        let at = |x: usize, y: usize, z: usize| self.data[(z * self.res[1] + y) * self.res[0] + x];
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let c00 = lerp(at(i0[0], i0[1], i0[2]), at(i1[0], i0[1], i0[2]), f[0]);
        let c10 = lerp(at(i0[0], i1[1], i0[2]), at(i1[0], i1[1], i0[2]), f[0]);
        let c01 = lerp(at(i0[0], i0[1], i1[2]), at(i1[0], i0[1], i1[2]), f[0]);
        let c11 = lerp(at(i0[0], i1[1], i1[2]), at(i1[0], i1[1], i1[2]), f[0]);
        lerp(lerp(c00, c10, f[1]), lerp(c01, c11, f[1]), f[2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn majorants_bound_every_lookup() {
        let res = [13, 9, 17];
        let data: Vec<f32> = (0..13 * 9 * 17)
            .map(|i| ((i as f32 * 0.618).fract() * 3.0).powi(3))
            .collect();
        let g = DensityGrid::new(res, data).unwrap();
        let mut s = 0.1234f32;
        for _ in 0..20000 {
            let mut p = Vec3::ZERO;
            for a in 0..3 {
                s = (s * 997.0 + 0.123).fract();
                p[a] = s;
            }
            let c = [0, 1, 2]
                .map(|a| ((p[a] * res[a] as f32) as usize / MAJORANT_BLOCK).min(g.cells[a] - 1));
            assert!(g.density(p) <= g.majorant(c[0], c[1], c[2]) * (1.0 + 1e-6));
        }
    }

    #[test]
    fn lookups_interpolate_between_voxel_centres() {
        let g = DensityGrid::new([2, 1, 1], vec![1.0, 3.0]).unwrap();
        assert_eq!(g.density(Vec3::new(0.25, 0.5, 0.5)), 1.0);
        assert_eq!(g.density(Vec3::new(0.75, 0.5, 0.5)), 3.0);
        assert_eq!(g.density(Vec3::new(0.5, 0.5, 0.5)), 2.0);
        assert_eq!(g.density(Vec3::new(0.1, 0.5, 0.5)), 1.0);
        assert_eq!(g.density(Vec3::new(1.1, 0.5, 0.5)), 0.0);
    }

    #[test]
    fn bad_grids_are_refused() {
        assert!(DensityGrid::new([2, 2, 1], vec![1.0; 3]).is_err());
        assert!(DensityGrid::new([2, 1, 1], vec![1.0, f32::NAN]).is_err());
        assert!(DensityGrid::new([2, 1, 1], vec![1.0, -1.0]).is_err());
        assert!(DensityGrid::new([0, 1, 1], vec![]).is_err());
    }
}
