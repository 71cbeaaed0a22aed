//! Exact spheres, disks and cylinders with Mitsuba 3's conventions (`src/shapes/sphere.cpp`,
//! `disk.cpp`, `cylinder.cpp`): ray intersection in the shape's object space, the surface at
//! a hit (re-projected onto the shape, as Mitsuba does, so secondary rays start on it),
//! uniform area sampling and, for spheres, sampling of the visible cone by solid angle.
//!
//! Each shape is a leaf of the instance tree ([`crate::accel`]); the ray is carried into the
//! unit shape by the inverse of its placement without renormalising the direction, so the
//! ray parameter stays the world one. Roots are solved in f64: a sphere's near root behind an
//! offset origin is then rejected by its sign rather than by rounding luck.

use std::f32::consts::{PI, TAU};

use glam::{DVec3, Mat3, Mat4, Vec2, Vec3};
use lumo_scene::{Analytic, AnalyticKind};

use crate::geometry::{cos_sin_turn, square_to_disk, square_to_uniform_sphere};

/// An exact shape placed in the world.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Shape {
    /// Which shape.
    pub kind: AnalyticKind,
    /// Unit shape → world.
    pub to_world: Mat4,
    /// World → unit shape.
    pub to_local: Mat4,
    /// Unit-shape normals → world (inverse transpose).
    pub normal_to_world: Mat3,
    /// Normals point inwards.
    pub flip: bool,
    /// World-space centre of the unit shape's origin (the sphere's centre).
    pub center: Vec3,
    /// World-space radius (length of the transformed x axis; Mitsuba requires uniform scale).
    pub radius: f32,
    /// World-space surface area.
    pub area: f32,
}

/// A point on a shape's surface.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ShapePoint {
    /// World position, on the shape.
    pub p: Vec3,
    /// Unit normal (flipped with `flip_normals`).
    pub n: Vec3,
    /// Mitsuba's texture coordinates.
    pub uv: Vec2,
    /// World-space ∂p/∂u.
    pub dp_du: Vec3,
    /// World-space ∂p/∂v.
    pub dp_dv: Vec3,
}

/// A point on a shape's surface without its parametrisation: what light sampling needs
/// (the uv and tangents of [`ShapePoint`] cost an `atan2` and an `acos` per sample).
#[derive(Clone, Copy, Debug)]
pub(crate) struct SurfaceSample {
    /// World position, on the shape.
    pub p: Vec3,
    /// Unit normal (flipped with `flip_normals`).
    pub n: Vec3,
}

impl Shape {
    /// `a` placed by the instance transform `instance`.
    pub fn new(a: &Analytic, instance: Mat4) -> Self {
        let to_world = instance * a.to_mesh;
        let radius = to_world.transform_vector3(Vec3::X).length();
        let area = match a.kind {
            AnalyticKind::Sphere => 4.0 * PI * radius * radius,
            AnalyticKind::Disk => {
                PI * to_world
                    .transform_vector3(Vec3::X)
                    .cross(to_world.transform_vector3(Vec3::Y))
                    .length()
            }
            AnalyticKind::Cylinder => TAU * radius * to_world.transform_vector3(Vec3::Z).length(),
        };
        Shape {
            kind: a.kind,
            to_world,
            to_local: to_world.inverse(),
            normal_to_world: Mat3::from_mat4(to_world).inverse().transpose(),
            flip: a.flip_normals,
            center: to_world.transform_point3(Vec3::ZERO),
            radius,
            area,
        }
    }

    /// The unit shape's bounding box in object space.
    pub fn local_bounds(kind: AnalyticKind) -> (Vec3, Vec3) {
        match kind {
            AnalyticKind::Sphere => (Vec3::splat(-1.0), Vec3::ONE),
            AnalyticKind::Disk => (Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0)),
            AnalyticKind::Cylinder => (Vec3::new(-1.0, -1.0, 0.0), Vec3::ONE),
        }
    }

    /// The world normal of the unit-shape normal `local_n`, flipped as asked.
    #[inline]
    fn world_normal(&self, local_n: Vec3) -> Vec3 {
        let n = (self.normal_to_world * local_n).normalize_or_zero();
        if self.flip {
            -n
        } else {
            n
        }
    }

    /// The unit-shape normal at the unit-shape point `local` (already on the shape).
    #[inline]
    fn local_normal(&self, local: Vec3) -> Vec3 {
        match self.kind {
            AnalyticKind::Sphere => local,
            AnalyticKind::Disk => Vec3::Z,
            AnalyticKind::Cylinder => Vec3::new(local.x, local.y, 0.0),
        }
    }

    /// World position and normal at the unit-shape point `local` (already on the shape).
    #[inline]
    fn sample_at_local(&self, local: Vec3) -> SurfaceSample {
        SurfaceSample {
            p: self.to_world.transform_point3(local),
            n: self.world_normal(self.local_normal(local)),
        }
    }

    /// The surface at the unit-shape point `local` (already on the shape).
    pub fn point_at_local(&self, local: Vec3) -> ShapePoint {
        let t = &self.to_world;
        let (x, y, z) = (local.x, local.y, local.z);
        let azimuth = |x: f32, y: f32| {
            let phi = y.atan2(x);
            if phi < 0.0 {
                phi + TAU
            } else {
                phi
            }
        };
        let (uv, dp_du, dp_dv) = match self.kind {
            AnalyticKind::Sphere => {
                let phi = azimuth(x, y);
                let theta = z.clamp(-1.0, 1.0).acos();
                let rd = (x * x + y * y).sqrt();
                let dv = if rd == 0.0 {
                    Vec3::X
                } else {
                    Vec3::new(z * x / rd, z * y / rd, -rd)
                };
                (
                    Vec2::new(phi / TAU, theta / PI),
                    t.transform_vector3(Vec3::new(-y, x, 0.0) * TAU),
                    t.transform_vector3(dv * PI),
                )
            }
            AnalyticKind::Disk => {
                let r = (x * x + y * y).sqrt();
                let (c, s) = if r == 0.0 { (0.0, 0.0) } else { (x / r, y / r) };
                (
                    Vec2::new(r, azimuth(x, y) / TAU),
                    t.transform_vector3(Vec3::new(c, s, 0.0)),
                    t.transform_vector3(Vec3::new(-s, c, 0.0) * (TAU * r)),
                )
            }
            AnalyticKind::Cylinder => (
                Vec2::new(azimuth(x, y) / TAU, z),
                t.transform_vector3(Vec3::new(-y, x, 0.0) * TAU),
                t.transform_vector3(Vec3::Z),
            ),
        };
        let SurfaceSample { p, n } = self.sample_at_local(local);
        ShapePoint {
            p,
            n,
            uv,
            dp_du,
            dp_dv,
        }
    }

    /// The surface where a ray hit the shape at world point `p`: `p` re-projected onto the
    /// shape (Mitsuba's "re-project to improve accuracy"), with normal, uv and tangents.
    pub fn surface_at(&self, p: Vec3) -> ShapePoint {
        self.point_at_local(self.project_local(p))
    }

    /// The normal at the world point `p` on the shape (re-projected as in
    /// [`Shape::surface_at`]).
    pub fn normal_at(&self, p: Vec3) -> Vec3 {
        self.point_at(p).n
    }

    /// [`Shape::surface_at`]'s position and normal (the same bits) without the uv and
    /// tangents, for surfaces whose material reads none.
    pub fn point_at(&self, p: Vec3) -> SurfaceSample {
        self.sample_at_local(self.project_local(p))
    }

    /// The world point `p` in unit-shape space, projected onto the unit shape.
    #[inline]
    fn project_local(&self, p: Vec3) -> Vec3 {
        let mut local = self.to_local.transform_point3(p);
        match self.kind {
            AnalyticKind::Sphere => local = local.normalize_or(Vec3::Z),
            AnalyticKind::Disk => local.z = 0.0,
            AnalyticKind::Cylinder => {
                let r = (local.x * local.x + local.y * local.y).sqrt();
                if r > 0.0 {
                    local.x /= r;
                    local.y /= r;
                } else {
                    local.x = 1.0;
                }
            }
        }
        local
    }

    /// A point uniformly distributed over the surface (density 1/`area`).
    pub fn sample_area(&self, u: Vec2) -> SurfaceSample {
        let local = match self.kind {
            AnalyticKind::Sphere => square_to_uniform_sphere(u),
            AnalyticKind::Disk => square_to_disk(u).extend(0.0),
            AnalyticKind::Cylinder => {
                let phi = TAU * u.x;
                Vec3::new(phi.cos(), phi.sin(), u.y)
            }
        };
        self.sample_at_local(local)
    }

    /// Whether `from` sees the sphere from outside: then its visible cone is sampled.
    #[inline]
    pub(crate) fn sees_cone(&self, from: Vec3) -> bool {
        self.kind == AnalyticKind::Sphere
            && (self.center - from).length_squared() > self.radius * self.radius
    }

    /// sin²θ_max, cos θ_max and 1 − cos θ_max of the cone the sphere fills seen from `from`.
    #[inline]
    fn cone(&self, from: Vec3) -> (f32, f32, f32) {
        let (sin2, cos, one_minus_cos) =
            cone_angles(self.radius, (self.center - from).length_squared());
        (sin2, cos, one_minus_cos)
    }

    /// A point on the shape for a light sample seen from `from`, with its solid-angle density
    /// at `from`: the sphere's visible cone uniformly by solid angle from outside (Mitsuba's
    /// `sample_direction`, [`cone_point`]), otherwise uniform by area converted to solid
    /// angle. `None` where the density is zero.
    pub fn sample_direction(&self, from: Vec3, u: Vec2) -> Option<(SurfaceSample, f32)> {
        if self.sees_cone(from) {
            let (p, d, pdf) = cone_point(self.center.into(), self.radius, from.into(), [u.x, u.y]);
            let d = Vec3::from(d);
            let point = SurfaceSample {
                p: Vec3::from(p),
                n: if self.flip { -d } else { d },
            };
            return (pdf.is_finite() && pdf > 0.0).then_some((point, pdf));
        }
        let point = self.sample_area(u);
        let pdf = self.area_to_solid_angle(from, point.p, point.n);
        (pdf > 0.0).then_some((point, pdf))
    }

    /// Density (solid angle at `from`) with which [`Shape::sample_direction`] picks the
    /// surface point `p` with normal `n`.
    /// The normal is asked of `normal` only where the density depends on it (not for a
    /// sphere's cone, the common case of a light's MIS weight).
    pub fn pdf_direction(&self, from: Vec3, p: Vec3, normal: impl FnOnce() -> Vec3) -> f32 {
        if self.sees_cone(from) {
            let (_, _, one_minus_cos) = self.cone(from);
            let pdf = 1.0 / (TAU * one_minus_cos);
            return if pdf.is_finite() { pdf } else { 0.0 };
        }
        self.area_to_solid_angle(from, p, normal())
    }

    /// 1/area as a solid-angle density at `from`.
    #[inline]
    fn area_to_solid_angle(&self, from: Vec3, p: Vec3, n: Vec3) -> f32 {
        let d = p - from;
        let dist2 = d.length_squared();
        let cos = n.dot(d).abs() / dist2.sqrt();
        if cos <= 0.0 || self.area <= 0.0 || !dist2.is_finite() {
            0.0
        } else {
            dist2 / (self.area * cos)
        }
    }
}

/// sin²θ_max, cos θ_max and 1 − cos θ_max of the cone a sphere of radius `radius` fills seen
/// from a point at squared distance `dc2` from its centre (outside it).
#[inline(always)]
fn cone_angles(radius: f32, dc2: f32) -> (f32, f32, f32) {
    let sin2 = (radius * radius / dc2).min(1.0);
    let cos = (1.0 - sin2).max(0.0).sqrt();
    // 1 − cos without cancellation for small cones.
    (sin2, cos, sin2 / (1.0 + cos))
}

/// A point of the sphere (`center`, `radius`) seen from `from` outside it, uniform in the
/// solid angle of its visible cone (Mitsuba's `Sphere::sample_direction`): the point, the
/// unit direction from the centre to it (the outward normal) and the solid-angle density at
/// `from`, 1 / (2π (1 − cos θ_max)) (infinite for a cone too narrow for f32).
///
/// Plain floats, no branches but selects and no calls: [`Shape::sample_direction`] and the
/// vector bounce's lanes run this one formula, so both give the same bits, and in the lanes
/// the compiler turns its chain of square roots and divisions into vector instructions.
/// The sphere's placement is not consulted: a sphere is uniformly scaled (Mitsuba requires
/// it), so its surface is `center + radius · d` for unit `d`.
#[inline(always)]
pub(crate) fn cone_point(
    center: [f32; 3],
    radius: f32,
    from: [f32; 3],
    u: [f32; 2],
) -> ([f32; 3], [f32; 3], f32) {
    let dc = [
        center[0] - from[0],
        center[1] - from[1],
        center[2] - from[2],
    ];
    let dc2 = (dc[0] * dc[0]) + (dc[1] * dc[1]) + (dc[2] * dc[2]);
    let (sin2_max, cos_max, one_minus_cos) = cone_angles(radius, dc2);
    let inv_dc = 1.0 / dc2.sqrt();
    let sin_max = radius * inv_dc;
    // θ from the cone axis at `from`, uniform in solid angle (Taylor form for tiny cones).
    let c = (cos_max - 1.0) * u[0] + 1.0;
    let sin2 = if sin2_max > 0.000_685_23 {
        1.0 - c * c
    } else {
        sin2_max * u[0]
    };
    let cos_theta = (1.0 - sin2).max(0.0).sqrt();
    // The angle α at the centre between −axis and the point (Akalin's construction).
    let cos_alpha = sin2 / sin_max + cos_theta * (1.0 - sin2 / sin2_max).max(0.0).sqrt();
    let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
    let (cos_phi, sin_phi) = cos_sin_turn(u[1]);
    let local = [cos_phi * sin_alpha, sin_phi * sin_alpha, cos_alpha];
    // Basis::new(−axis).to_world(local), normalised.
    let n = [-dc[0] * inv_dc, -dc[1] * inv_dc, -dc[2] * inv_dc];
    let sign = 1.0f32.copysign(n[2]);
    let a = -1.0 / (sign + n[2]);
    let b = n[0] * n[1] * a;
    let s = [1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]];
    let t = [b, sign + n[1] * n[1] * a, -n[1]];
    let w = [
        s[0] * local[0] + t[0] * local[1] + n[0] * local[2],
        s[1] * local[0] + t[1] * local[1] + n[1] * local[2],
        s[2] * local[0] + t[2] * local[1] + n[2] * local[2],
    ];
    let rcp = 1.0 / ((w[0] * w[0]) + (w[1] * w[1]) + (w[2] * w[2])).sqrt();
    let d = [w[0] * rcp, w[1] * rcp, w[2] * rcp];
    let p = [
        center[0] + d[0] * radius,
        center[1] + d[1] * radius,
        center[2] + d[2] * radius,
    ];
    (p, d, 1.0 / (TAU * one_minus_cos))
}

/// The nearest ray parameter in [tmin, tmax] where the object-space ray `o + t·d` meets the
/// unit shape `kind`.
#[inline]
pub(crate) fn intersect(kind: AnalyticKind, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<f32> {
    let (o, d) = (DVec3::from(o), DVec3::from(d));
    let accept = |t: f64| {
        let t = t as f32;
        (t >= tmin && t <= tmax).then_some(t)
    };
    match kind {
        AnalyticKind::Sphere => {
            let (t0, t1) = quadratic(d.length_squared(), o.dot(d), o.length_squared() - 1.0)?;
            accept(t0).or_else(|| accept(t1))
        }
        AnalyticKind::Disk => {
            if d.z == 0.0 {
                return None;
            }
            let t = -o.z / d.z;
            let p = o + d * t;
            if p.x * p.x + p.y * p.y > 1.0 {
                return None;
            }
            accept(t)
        }
        AnalyticKind::Cylinder => {
            let (t0, t1) = quadratic(
                d.x * d.x + d.y * d.y,
                o.x * d.x + o.y * d.y,
                o.x * o.x + o.y * o.y - 1.0,
            )?;
            let within = |t: f64| {
                let z = o.z + d.z * t;
                (0.0..=1.0).contains(&z)
            };
            [t0, t1].into_iter().filter(|&t| within(t)).find_map(accept)
        }
    }
}

/// The roots t0 ≤ t1 of a·t² + 2·b·t + c (with a > 0), in the cancellation-free form.
#[inline]
fn quadratic(a: f64, b: f64, c: f64) -> Option<(f64, f64)> {
    if a <= 0.0 {
        return None;
    }
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    let q = -(b + disc.sqrt().copysign(b));
    if q == 0.0 {
        return Some((0.0, 0.0));
    }
    let (x, y) = (q / a, c / q);
    Some(if x <= y { (x, y) } else { (y, x) })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadratic_roots() {
        // (t − 1)(t − 3) = t² − 4t + 3.
        assert_eq!(quadratic(1.0, -2.0, 3.0), Some((1.0, 3.0)));
        assert_eq!(quadratic(1.0, 0.0, 1.0), None);
    }
}
