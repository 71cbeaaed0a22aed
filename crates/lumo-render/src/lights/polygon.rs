//! Unshadowed irradiance from a uniformly emitting polygon, in closed form (Lambert's polygon
//! formula): the noise-free half of the ratio estimator for direct light (Heitz et al. 2018),
//! which keeps only the shadowing stochastic.

use glam::{DVec3, Vec3};

/// ∫ cos θ dω over the part of the one-sided polygon `corners` that is above the plane through
/// `p` with unit normal `n` (θ measured from `n`): the irradiance at `p` per unit emitted
/// radiance. The polygon emits towards the side its counter-clockwise winding faces; seen from
/// behind it contributes 0. Computed in f64 because the edge angles of a small or distant
/// polygon are differences of nearly equal directions.
pub fn polygon_cosine_integral(p: Vec3, n: Vec3, corners: &[Vec3]) -> f32 {
    if corners.len() < 3 {
        return 0.0;
    }
    let (p, n) = (p.as_dvec3(), n.as_dvec3());
    let rel: Vec<DVec3> = corners.iter().map(|c| c.as_dvec3() - p).collect();
    // Seen from behind (or edge-on), a one-sided emitter sends nothing to p.
    let face = (rel[1] - rel[0]).cross(rel[2] - rel[0]);
    if face.dot(-rel[0]) <= 0.0 {
        return 0.0;
    }
    let clipped = clip_above(&rel, n);
    if clipped.len() < 3 {
        return 0.0;
    }
    let mut sum = 0.0f64;
    for (i, a) in clipped.iter().enumerate() {
        let b = clipped[(i + 1) % clipped.len()];
        let (a, b) = (a.normalize_or_zero(), b.normalize_or_zero());
        let c = a.cross(b);
        let s = c.length();
        if s <= 0.0 {
            continue;
        }
        // The edge's angle and the normal's share of its plane's normal.
        sum += s.atan2(a.dot(b)) * n.dot(c) / s;
    }
    // Counter-clockwise seen from p makes the sum negative; its magnitude is 2·∫cos dω.
    (0.5 * sum.abs()) as f32
}

/// The part of polygon `v` (relative to the shading point) where `n · x ≥ 0`
/// (Sutherland–Hodgman against one plane).
fn clip_above(v: &[DVec3], n: DVec3) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(v.len() + 1);
    for (i, &a) in v.iter().enumerate() {
        let b = v[(i + 1) % v.len()];
        let (da, db) = (n.dot(a), n.dot(b));
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            let t = da / (da - db);
            out.push(a + (b - a) * t);
        }
    }
    out
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
            let exact = polygon_cosine_integral(p, n, &tri) as f64;
            let mc = brute_force(p, n, tri);
            assert!(exact > 0.0);
            assert!(
                (exact - mc).abs() <= 2e-3 * mc + 1e-5,
                "{p} {n}: {exact} vs {mc}"
            );
        }
        // Behind the emitter, or the emitter behind the receiver's horizon.
        assert_eq!(
            polygon_cosine_integral(Vec3::new(0.0, 2.0, 0.0), -Vec3::Y, &tri),
            0.0
        );
        assert_eq!(polygon_cosine_integral(Vec3::ZERO, -Vec3::Y, &tri), 0.0);
    }

    /// A huge square right above covers the hemisphere: ∫cos dω → π.
    #[test]
    fn a_hemisphere_covering_square_integrates_to_pi() {
        let s = 1e4;
        let quad = [
            Vec3::new(-s, 1.0, -s),
            Vec3::new(-s, 1.0, s),
            Vec3::new(s, 1.0, s),
            Vec3::new(s, 1.0, -s),
        ];
        let v = polygon_cosine_integral(Vec3::ZERO, Vec3::Y, &quad);
        assert!((v - PI).abs() < 1e-3, "{v}");
    }
}
