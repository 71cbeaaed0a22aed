//! The GGX (Trowbridge–Reitz) microfacet distribution with visible-normal sampling
//! (Heitz 2018), isotropic, in the local frame (z = macro normal).

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// An isotropic GGX distribution of roughness α.
#[derive(Clone, Copy, Debug)]
pub struct Ggx {
    /// GGX α (≈ perceptual roughness squared).
    pub alpha: f32,
}

impl Ggx {
    /// Normal distribution D(m).
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let t = m.x * m.x / a2 + m.y * m.y / a2 + m.z * m.z;
        1.0 / (PI * a2 * t * t)
    }

    /// Smith Λ.
    #[inline]
    fn lambda(&self, w: Vec3) -> f32 {
        let z2 = w.z * w.z;
        if z2 <= 0.0 {
            return f32::INFINITY;
        }
        let tan2 = (w.x * w.x + w.y * w.y) / z2;
        0.5 * ((1.0 + self.alpha * self.alpha * tan2).sqrt() - 1.0)
    }

    /// Smith masking G1(w, m), zero when w sees the back of m.
    #[inline]
    pub fn g1(&self, w: Vec3, m: Vec3) -> f32 {
        if w.dot(m) * w.z <= 0.0 {
            return 0.0;
        }
        1.0 / (1.0 + self.lambda(w))
    }

    /// Density of visible normals seen from `w` (w.z > 0): G1(w)·max(0, w·m)·D(m)/w.z.
    #[inline]
    pub fn pdf_visible(&self, w: Vec3, m: Vec3) -> f32 {
        if w.z <= 0.0 {
            return 0.0;
        }
        self.g1(w, m) * w.dot(m).max(0.0) * self.d(m) / w.z
    }

    /// Samples a microfacet normal visible from `w` (w.z > 0).
    #[inline]
    pub fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
        let a = self.alpha;
        let vh = Vec3::new(a * w.x, a * w.y, w.z).normalize();
        let lensq = vh.x * vh.x + vh.y * vh.y;
        let t1 = if lensq > 0.0 {
            Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
        } else {
            Vec3::X
        };
        let t2 = vh.cross(t1);
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let p1 = r * phi.cos();
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
        let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
        Vec3::new(a * nh.x, a * nh.y, nh.z.max(1e-6)).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projected_area_is_one() {
        // ∫ D(m) cos θm dm = 1, by midpoint quadrature over the hemisphere.
        for alpha in [0.1f32, 0.3, 0.8] {
            let g = Ggx { alpha };
            let (nt, np) = (4000, 64);
            let mut sum = 0.0f64;
            for i in 0..nt {
                let theta = (i as f32 + 0.5) / nt as f32 * PI / 2.0;
                for j in 0..np {
                    let phi = (j as f32 + 0.5) / np as f32 * 2.0 * PI;
                    let m = Vec3::new(
                        theta.sin() * phi.cos(),
                        theta.sin() * phi.sin(),
                        theta.cos(),
                    );
                    sum += (g.d(m) * m.z * theta.sin()) as f64;
                }
            }
            sum *= (PI as f64 / 2.0 / nt as f64) * (2.0 * PI as f64 / np as f64);
            assert!((sum - 1.0).abs() < 5e-3, "alpha {alpha}: {sum}");
        }
    }
}
