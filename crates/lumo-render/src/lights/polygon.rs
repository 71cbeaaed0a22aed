//! Unshadowed irradiance from a uniformly emitting triangle, in closed form (Lambert's polygon
//! formula): the noise-free half of the ratio estimator for direct light (Heitz et al. 2018),
//! which keeps only the shadowing stochastic.

use glam::{DVec3, Vec3};

/// ∫ cos θ dω over the part of the one-sided triangle `corners` that is above the plane
/// through `p` with unit normal `n` (θ measured from `n`): the irradiance at `p` per unit
/// emitted radiance. The triangle emits towards the side its counter-clockwise winding faces;
/// seen from behind it contributes 0. Computed in f64 because the edge angles of a small or
/// distant triangle are differences of nearly equal directions. For many points, build a
/// [`CosineTriangle`] once instead.
pub fn triangle_cosine_integral(p: Vec3, n: Vec3, corners: &[Vec3; 3]) -> f32 {
    CosineTriangle::new(corners).integral(p, n)
}

/// An emitting triangle prepared for [`triangle_cosine_integral`] at many points: its corners
/// in f64 and its face normal, which do not depend on the point (the direct-light split
/// evaluates every emitter at every pixel).
#[derive(Clone, Copy, Debug)]
pub struct CosineTriangle {
    corners: [DVec3; 3],
    /// (c1 − c0) × (c2 − c0): the side the triangle emits towards, unnormalised.
    face: DVec3,
}

impl CosineTriangle {
    /// Prepares the triangle `corners` (counter-clockwise seen from the side it lights).
    pub fn new(corners: &[Vec3; 3]) -> Self {
        let corners = corners.map(Vec3::as_dvec3);
        // The same product the per-point form took of the corners relative to the point:
        // differences of f32 values are exact in f64, so it is the same number.
        let face = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
        Self { corners, face }
    }

    /// [`triangle_cosine_integral`] at `p` with unit normal `n`.
    pub fn integral(&self, p: Vec3, n: Vec3) -> f32 {
        let (p, n) = (p.as_dvec3(), n.as_dvec3());
        let rel = self.corners.map(|c| c - p);
        // Seen from behind (or edge-on), a one-sided emitter sends nothing to p.
        if self.face.dot(-rel[0]) <= 0.0 {
            return 0.0;
        }
        // Clipped to the upper half-space (Sutherland–Hodgman against one plane): a triangle
        // keeps at most four corners.
        let mut clipped = [DVec3::ZERO; 4];
        let mut len = 0;
        for (i, &a) in rel.iter().enumerate() {
            let b = rel[(i + 1) % 3];
            let (da, db) = (n.dot(a), n.dot(b));
            if da >= 0.0 {
                clipped[len] = a;
                len += 1;
            }
            if (da >= 0.0) != (db >= 0.0) {
                clipped[len] = a + (b - a) * (da / (da - db));
                len += 1;
            }
        }
        if len < 3 {
            return 0.0;
        }
        let mut unit = [DVec3::ZERO; 4];
        for (u, c) in unit.iter_mut().zip(&clipped).take(len) {
            *u = c.normalize_or_zero();
        }
        let mut sum = 0.0f64;
        for i in 0..len {
            let (a, b) = (unit[i], unit[(i + 1) % len]);
            let c = a.cross(b);
            let s = c.length();
            if s > 0.0 {
                // The edge's angle and the normal's share of its plane's normal.
                // (The angle in f32: its inputs are f64-exact, and libm's f64 atan2 was 4 % of
                // a temporal frame.)
                sum += f64::from((s as f32).atan2(a.dot(b) as f32)) * n.dot(c) / s;
            }
        }
        // Counter-clockwise seen from p makes the sum negative; its magnitude is 2·∫cos dω.
        (0.5 * sum.abs()) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    /// Monte Carlo ∫cos dω of a one-sided triangle: uniform area samples weighted by the
    /// solid-angle Jacobian, on a fixed low-discrepancy grid.
    fn brute_force(p: Vec3, n: Vec3, t: [Vec3; 3]) -> f64 {
        let ng = (t[1] - t[0]).cross(t[2] - t[0]);
        let area = 0.5 * ng.length() as f64;
        let ng = ng.normalize();
        let k = 400;
        let mut sum = 0.0f64;
        for i in 0..k {
            for j in 0..k {
                let (mut u, mut v) = ((i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64);
                if u + v > 1.0 {
                    (u, v) = (1.0 - u, 1.0 - v);
                }
                let q =
                    t[0].as_dvec3() + (t[1] - t[0]).as_dvec3() * u + (t[2] - t[0]).as_dvec3() * v;
                let d = q - p.as_dvec3();
                let r2 = d.length_squared();
                let w = d / r2.sqrt();
                let cos_l = ng.as_dvec3().dot(-w);
                let cos_s = n.as_dvec3().dot(w);
                if cos_l > 0.0 && cos_s > 0.0 {
                    sum += cos_s * cos_l / r2;
                }
            }
        }
        sum * area / (k * k) as f64
    }

    /// Against brute-force integration for triangles fully above, across and below the
    /// horizon, tilted receivers, and one seen from behind.
    #[test]
    fn matches_brute_force_integration_with_and_without_horizon_clipping() {
        // Facing down (-y), 1 above the origin.
        let tri = [
            Vec3::new(-0.5, 1.0, -0.3),
            Vec3::new(0.6, 1.0, -0.4),
            Vec3::new(0.1, 1.0, 0.7),
        ];
        let cases = [
            (Vec3::ZERO, Vec3::Y),
            (
                Vec3::new(0.3, 0.2, 0.1),
                Vec3::new(0.3, 1.0, -0.2).normalize(),
            ),
            // Receiver whose horizon cuts the triangle.
            (
                Vec3::new(0.0, 0.5, 0.0),
                Vec3::new(1.0, 0.2, 0.0).normalize(),
            ),
            (Vec3::new(2.0, 0.9, 0.0), Vec3::new(-1.0, 0.0, 0.0)),
        ];
        for (p, n) in cases {
            let exact = triangle_cosine_integral(p, n, &tri) as f64;
            let mc = brute_force(p, n, tri);
            assert!(exact > 0.0);
            assert!(
                (exact - mc).abs() <= 2e-3 * mc + 1e-5,
                "{p} {n}: {exact} vs {mc}"
            );
        }
        // Behind the emitter, or the emitter behind the receiver's horizon.
        assert_eq!(
            triangle_cosine_integral(Vec3::new(0.0, 2.0, 0.0), -Vec3::Y, &tri),
            0.0
        );
        assert_eq!(triangle_cosine_integral(Vec3::ZERO, -Vec3::Y, &tri), 0.0);
    }

    /// A small, distant triangle (solid angle ~1e-6, where the edge terms nearly cancel)
    /// matches the point-source limit A·cos·cos/r² to 0.1 %.
    #[test]
    fn a_small_distant_triangle_matches_the_point_source_limit() {
        let h = 0.01;
        let tri = [
            Vec3::new(0.0, 10.0, 0.0),
            Vec3::new(h, 10.0, 0.0),
            Vec3::new(0.0, 10.0, h),
        ];
        let p = Vec3::new(3.0, 0.0, 1.0);
        let n = Vec3::new(0.2, 1.0, 0.1).normalize();
        let c = (tri[0] + tri[1] + tri[2]) / 3.0;
        let d = c - p;
        let (r2, w) = (d.length_squared(), d.normalize());
        let limit = 0.5 * h * h * n.dot(w) * (-Vec3::Y).dot(-w).abs() / r2;
        let v = triangle_cosine_integral(p, n, &tri);
        assert!((v / limit - 1.0).abs() < 1e-3, "{v} vs {limit}");
    }

    /// A huge square (two triangles) right above covers the hemisphere: ∫cos dω → π.
    #[test]
    fn a_hemisphere_covering_square_integrates_to_pi() {
        let s = 1e4;
        let [a, b, c, d] = [
            Vec3::new(-s, 1.0, -s),
            Vec3::new(-s, 1.0, s),
            Vec3::new(s, 1.0, s),
            Vec3::new(s, 1.0, -s),
        ];
        let v = triangle_cosine_integral(Vec3::ZERO, Vec3::Y, &[a, c, b])
            + triangle_cosine_integral(Vec3::ZERO, Vec3::Y, &[a, d, c]);
        assert!((v - PI).abs() < 1e-3, "{v}");
    }
}
