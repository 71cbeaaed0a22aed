//! Small geometric helpers: local shading frames and the standard sample warps.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI, TAU};

/// An orthonormal basis whose z axis is a given normal; BSDFs work in this frame.
#[derive(Clone, Copy, Debug)]
pub struct Basis {
    /// Tangent.
    pub s: Vec3,
    /// Bitangent.
    pub t: Vec3,
    /// Normal.
    pub n: Vec3,
}

impl Basis {
    /// A frame around unit vector `n` (Duff et al. 2017, branchless).
    #[inline]
    pub fn new(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Basis {
            s: Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            t: Vec3::new(b, sign + n.y * n.y * a, -n.y),
            n,
        }
    }

    /// World → local.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local → world.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// (cos φ, sin φ) for |φ| ≤ π/4 by truncated Taylor series: the first omitted terms are
/// below 3·10⁻⁷ there, under f32's resolution near 1. The concentric disk map only needs this
/// range, and libm's general `sincosf` with its range reduction took ~3 % of render time.
#[inline]
pub(crate) fn cos_sin_quarter(phi: f32) -> (f32, f32) {
    let x2 = phi * phi;
    let cos = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40320.0))));
    let sin = phi * (1.0 + x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0))));
    (cos, sin)
}

/// Uniform point on the unit disk (concentric mapping, low distortion for Sobol points).
#[inline]
pub fn square_to_disk(u: Vec2) -> Vec2 {
    let (x, y) = disk_map(u.x, u.y);
    Vec2::new(x, y)
}

/// The concentric square-to-disk map on plain numbers, written with selects rather than
/// branches: the one formula both [`square_to_disk`] and the vector bounce's lane loops use
/// (where the compiler turns it into vector instructions).
#[inline(always)]
pub(crate) fn disk_map(u0: f32, u1: f32) -> (f32, f32) {
    let (ox, oy) = (2.0 * u0 - 1.0, 2.0 * u1 - 1.0);
    let centre = ox == 0.0 && oy == 0.0;
    let major_x = ox.abs() > oy.abs();
    // Major x: θ = π/4 · (y/x). Major y: θ = π/2 − φ with φ = π/4 · (x/y), so cos θ = sin φ
    // and sin θ = cos φ. (At the centre the quotient is NaN; the select discards it.)
    let phi = std::f32::consts::FRAC_PI_4 * if major_x { oy / ox } else { ox / oy };
    let (c, s) = cos_sin_quarter(phi);
    let dx = if centre {
        0.0
    } else if major_x {
        ox * c
    } else {
        oy * s
    };
    let dy = if centre {
        0.0
    } else if major_x {
        ox * s
    } else {
        oy * c
    };
    (dx, dy)
}

/// The shading frame of a simple diffuse hit, on plain numbers with selects:
/// [`crate::RenderScene::surface`]'s shading normal (the corner normals `nv` interpolated at
/// barycentrics (`u`, `v`) and normalised where `interpolate`, else or where that fails the
/// geometric normal `ng`; turned to `ng`'s side) and [`Basis::new`]'s tangents around it.
/// The one formula of the lane loops that reconstruct hits (the path tracer's vector bounce,
/// the bidirectional walk steps). Returns (normal, tangent, bitangent).
#[inline(always)]
pub(crate) fn shading_frame_lane(
    nv: [[f32; 3]; 3],
    (u, v): (f32, f32),
    ng: [f32; 3],
    interpolate: bool,
) -> ([f32; 3], [f32; 3], [f32; 3]) {
    let dot = |a: [f32; 3], b: [f32; 3]| (a[0] * b[0]) + (a[1] * b[1]) + (a[2] * b[2]);
    let sel = |c: bool, x: f32, y: f32| if c { x } else { y };
    let w = 1.0 - u - v;
    let m = [
        nv[0][0] * w + nv[1][0] * u + nv[2][0] * v,
        nv[0][1] * w + nv[1][1] * u + nv[2][1] * v,
        nv[0][2] * w + nv[1][2] * u + nv[2][2] * v,
    ];
    let rcp = 1.0 / dot(m, m).sqrt();
    let unit = rcp.is_finite() && rcp > 0.0;
    let mn = [
        sel(unit, m[0] * rcp, 0.0),
        sel(unit, m[1] * rcp, 0.0),
        sel(unit, m[2] * rcp, 0.0),
    ];
    let usable = !(mn[0] == 0.0 && mn[1] == 0.0 && mn[2] == 0.0)
        && mn[0].is_finite()
        && mn[1].is_finite()
        && mn[2].is_finite();
    let take = interpolate && usable;
    let mut n = [
        sel(take, mn[0], ng[0]),
        sel(take, mn[1], ng[1]),
        sel(take, mn[2], ng[2]),
    ];
    let back = dot(n, ng) < 0.0;
    for c in &mut n {
        *c = sel(back, -*c, *c);
    }
    // Basis::new.
    let [nx, ny, nz] = n;
    let sign = 1.0f32.copysign(nz);
    let a = -1.0 / (sign + nz);
    let b = nx * ny * a;
    let s = [1.0 + sign * nx * nx * a, sign * b, -sign * nx];
    let t = [b, sign + ny * ny * a, -ny];
    (n, s, t)
}

/// The height over the unit disk's point (`x`, `y`) of the hemisphere above it: the z of
/// [`square_to_cosine_hemisphere`].
#[inline(always)]
pub(crate) fn hemisphere_z(x: f32, y: f32) -> f32 {
    (1.0 - (x * x + y * y)).max(0.0).sqrt()
}

/// Cosine-weighted direction on the +z hemisphere; pdf = cosθ/π.
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let (x, y) = disk_map(u.x, u.y);
    Vec3::new(x, y, hemisphere_z(x, y))
}

/// Density of [`square_to_cosine_hemisphere`].
#[inline]
pub fn cosine_hemisphere_pdf(v: Vec3) -> f32 {
    cosine_pdf(v.z)
}

/// [`cosine_hemisphere_pdf`] of a direction with z component `cos`.
#[inline(always)]
pub(crate) fn cosine_pdf(cos: f32) -> f32 {
    cos.max(0.0) * FRAC_1_PI
}

/// Uniform direction on the unit sphere; pdf = 1/(4π).
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.y;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = TAU * u.x;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// (cos 2πu, sin 2πu) for u in [0, 1], in plain floats and selects so that lane loops
/// vectorise it: the turn is split into quarters around 0, ¼, ½, ¾ and the remainder
/// (|φ| ≤ π/4) goes through a Taylor series one term longer than [`cos_sin_quarter`]'s
/// (first omitted terms below 2·10⁻⁹ there). libm's `sincosf` is a call per lane; this is
/// what the light samples that the vector bounce computes in its lanes use, and the scalar
/// samplers of the same lights too, so both give the same bits.
#[inline(always)]
pub(crate) fn cos_sin_turn(u: f32) -> (f32, f32) {
    // The nearest quarter: k in 0..=4 (4 is a full turn, as 0).
    let k = (u * 4.0 + 0.5).floor();
    let phi = (u - k * 0.25) * TAU;
    let x2 = phi * phi;
    let c = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40320.0))));
    let s = phi
        * (1.0
            + x2 * (-1.0 / 6.0
                + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0)))));
    // Rotate by k quarter turns: (c, s) → (−s, c) → (−c, −s) → (s, −c).
    let (odd, neg_c, neg_s) = (
        k == 1.0 || k == 3.0,
        k == 1.0 || k == 2.0,
        k == 2.0 || k == 3.0,
    );
    let (x, y) = if odd { (s, c) } else { (c, s) };
    (if neg_c { -x } else { x }, if neg_s { -y } else { y })
}

/// [`square_to_uniform_sphere`] on plain floats with [`cos_sin_turn`]: the same map (z from
/// `u1`, azimuth from `u0`) in the form lane loops vectorise; pdf = 1/(4π).
#[inline(always)]
pub(crate) fn uniform_sphere_map(u0: f32, u1: f32) -> [f32; 3] {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (c, s) = cos_sin_turn(u0);
    [r * c, r * s, z]
}

/// Density of [`square_to_uniform_sphere`].
pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform barycentrics (b1, b2) on a triangle (Heitz's low-distortion square-to-triangle map).
#[inline]
pub fn square_to_triangle(u: Vec2) -> Vec2 {
    let (b1, b2) = triangle_map(u.x, u.y);
    Vec2::new(b1, b2)
}

/// [`square_to_triangle`] on plain numbers with selects: the one formula the scalar code and
/// the vector bounce's lane loops share.
#[inline(always)]
pub(crate) fn triangle_map(u0: f32, u1: f32) -> (f32, f32) {
    let (b0, b1) = (u0 / 2.0, u1 / 2.0);
    let offset = b1 - b0;
    let up = offset > 0.0;
    let b1 = if up { b1 + offset } else { b1 };
    let b0 = if up { b0 } else { b0 - offset };
    (b1, 1.0 - b0 - b1)
}

/// The larger of `a` and `b` with x86 `maxps` semantics (the second operand when either is
/// NaN), one instruction: `f32::max` also orders NaNs, which cost three more per call in the
/// ray-offset rules below (~0.5 % of a render). The packet kernels' slab tests use it too, so
/// they compute the single-ray code's distances.
#[inline(always)]
pub(crate) fn vmax(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// The smaller of `a` and `b` with x86 `minps` semantics.
#[inline(always)]
pub(crate) fn vmin(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// The largest magnitude of `p`'s coordinates.
#[inline(always)]
pub(crate) fn max3_abs(p: [f32; 3]) -> f32 {
    vmax(p[0].abs(), vmax(p[1].abs(), p[2].abs()))
}

/// `p` moved off a surface with unit geometric normal `ng` to the side of direction `d`, by
/// `eps` relative to the point's magnitude: the one ray-origin rule of every integrator (the
/// scalar code through [`crate::RenderScene::offset`], the lane loops directly).
#[inline(always)]
pub(crate) fn offset_point(p: [f32; 3], ng: [f32; 3], d: [f32; 3], eps: f32) -> [f32; 3] {
    let along = (ng[0] * d[0]) + (ng[1] * d[1]) + (ng[2] * d[2]);
    let side = if along >= 0.0 { 1.0 } else { -1.0 };
    let m = max3_abs(p);
    let k = side * eps * (1.0 + m);
    [p[0] + ng[0] * k, p[1] + ng[1] * k, p[2] + ng[2] * k]
}

/// Russian roulette's survival probability for a path whose throughput's largest component is
/// `max`, with `eta_scale` undoing refraction's radiance scaling (1 for light paths): capped
/// at 0.95 so that no path is immortal. The one rule of every integrator and the lane loops.
#[inline(always)]
pub(crate) fn survival_probability(max: f32, eta_scale: f32) -> f32 {
    (max * eta_scale).min(0.95)
}

/// Mirror reflection of `v` about `n` (both pointing away from the surface).
#[inline]
pub fn reflect(v: Vec3, n: Vec3) -> Vec3 {
    2.0 * v.dot(n) * n - v
}

/// Power heuristic (β = 2) weight of strategy f against g.
#[inline]
pub fn power_heuristic(f: f32, g: f32) -> f32 {
    let (f2, g2) = (f * f, g * g);
    if f2 + g2 == 0.0 || !f2.is_finite() {
        if f2.is_infinite() {
            1.0
        } else {
            0.0
        }
    } else {
        f2 / (f2 + g2)
    }
}

/// The shadow ray from `o` — a shading point already moved off its surface — to the point `q`
/// on a light: its unit direction and the largest `t` it may test, short of the light's own
/// surface. `wi` is the light direction from the unmoved point, used where there is nothing
/// to test (then `t` is −1, so nothing can block it: the light is nearer than the ray offset,
/// or the offset moved the origin past it).
///
/// The length is measured from `o` itself. Subtracting the offset's length from the distance
/// of the unmoved point, as lumo once did, is right only where the offset points along the
/// ray: at grazing angles to a light parallel to the receiver the offset brings the origin
/// nearer the light by `offset / cos θ`, the shadow ray reached into the light and every
/// light sample counted as blocked (a panel 1.35 m below a ceiling lit it 20× too dark).
///
/// The stop-short margin is the larger of 1e-4 of the length and `eps · (1 + |q|∞)`, the
/// offset's own scale at the light, so intersection round-off at the light point never
/// counts the light as its own occluder. Arrays, not `Vec3`, so the vector bounce computes
/// the same bits lane by lane.
#[inline(always)]
pub(crate) fn shadow_segment(o: [f32; 3], q: [f32; 3], wi: [f32; 3], eps: f32) -> ([f32; 3], f32) {
    let d = [q[0] - o[0], q[1] - o[1], q[2] - o[2]];
    let len = ((d[0] * d[0]) + (d[1] * d[1]) + (d[2] * d[2])).sqrt();
    let ahead = (d[0] * wi[0]) + (d[1] * wi[1]) + (d[2] * wi[2]) > 0.0;
    let scale = max3_abs(q);
    let tmax = len - vmax(eps * (1.0 + scale), len * 1e-4);
    let clear = ahead && tmax > 0.0;
    let inv = 1.0 / len;
    let dir = [d[0] * inv, d[1] * inv, d[2] * inv];
    if clear {
        (dir, tmax)
    } else {
        (wi, -1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `cos_sin_turn` against f64's sine and cosine over the whole turn, quarter boundaries
    /// and both ends included.
    #[test]
    fn cos_sin_turn_matches_libm() {
        let mut worst = 0.0f64;
        for i in 0..=100_000u32 {
            let u = i as f32 / 100_000.0;
            for u in [u, f32::from_bits(u.to_bits().saturating_sub(1))] {
                let (c, s) = cos_sin_turn(u);
                let phi = u as f64 * std::f64::consts::TAU;
                worst = worst
                    .max((c as f64 - phi.cos()).abs())
                    .max((s as f64 - phi.sin()).abs());
            }
        }
        assert!(worst < 4e-7, "largest error {worst}");
        let d = uniform_sphere_map(0.3, 0.8);
        let v = square_to_uniform_sphere(Vec2::new(0.3, 0.8));
        assert!((Vec3::from(d) - v).length() < 1e-6, "{d:?} vs {v}");
    }

    #[test]
    fn frame_is_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.8).normalize(),
        ] {
            let f = Basis::new(n);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(f.n).abs() < 1e-5);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5);
            let v = Vec3::new(0.1, 0.7, -0.2);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn quarter_sincos_matches_libm() {
        for i in 0..=1000 {
            let phi = (i as f32 / 500.0 - 1.0) * std::f32::consts::FRAC_PI_4;
            let (c, s) = cos_sin_quarter(phi);
            assert!(
                (c - phi.cos()).abs() < 1e-6 && (s - phi.sin()).abs() < 1e-6,
                "{phi}"
            );
        }
        // The disk map still lands on the unit disk, on the boundary for the square's edge.
        for i in 0..=64 {
            let d = square_to_disk(Vec2::new(1.0, i as f32 / 64.0));
            assert!((d.length() - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn triangle_warp_stays_inside() {
        for i in 0..100 {
            for j in 0..100 {
                let b = square_to_triangle(Vec2::new(i as f32 / 100.0, j as f32 / 100.0));
                assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
            }
        }
    }
}
