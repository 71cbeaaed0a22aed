//! Microfacet normal distributions as Mitsuba 3 defines them — GGX (Trowbridge–Reitz) and
//! Beckmann, isotropic or anisotropic (α along the shading tangent and bitangent) — with
//! sampling of the normals visible from a direction, in the local frame (z = macro normal).

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

pub use lumo_scene::Distribution;

/// 1/√π.
const INV_SQRT_PI: f32 = 0.564_189_6;

/// A microfacet distribution with roughness α along x (tangent) and y (bitangent).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    /// Which normal distribution.
    pub distribution: Distribution,
    /// α along the tangent (x).
    pub alpha_u: f32,
    /// α along the bitangent (y).
    pub alpha_v: f32,
}

impl Microfacet {
    /// Isotropic GGX of roughness α.
    #[inline]
    pub const fn ggx(alpha: f32) -> Self {
        Self {
            distribution: Distribution::Ggx,
            alpha_u: alpha,
            alpha_v: alpha,
        }
    }

    /// A distribution of either kind and the same α on both axes.
    #[inline]
    pub const fn isotropic(distribution: Distribution, alpha: f32) -> Self {
        Self {
            distribution,
            alpha_u: alpha,
            alpha_v: alpha,
        }
    }

    /// The render-side distribution of a scene roughness. Like Mitsuba, a rough surface keeps
    /// α ≥ 1e-4 on each axis (one axis at 0 would divide by zero); negative or NaN α is smooth.
    /// A per-texel α is read at `uv` (`None`: its average, for what is set up once per
    /// material). Out of line, as it was before the material seam: inlined into every
    /// material's `at_hit` it grew the light tracer's path loop and cost it 2 % more
    /// instructions (callgrind).
    #[inline(never)]
    pub(crate) fn of_roughness(r: &lumo_scene::Roughness, uv: Option<Vec2>) -> Self {
        let clean = |a: f32| if a.is_finite() { a.max(0.0) } else { 0.0 };
        let (au, av) = match uv {
            Some(uv) => r.alpha_at(uv),
            None => (r.alpha_u, r.alpha_v),
        };
        let (mut au, mut av) = (clean(au), clean(av));
        if au.max(av) >= super::SMOOTH_ALPHA {
            (au, av) = (au.max(1e-4), av.max(1e-4));
        }
        Self {
            distribution: r.distribution,
            alpha_u: au,
            alpha_v: av,
        }
    }

    /// The larger α: below lumo's smoothness threshold on both axes the surface is a mirror.
    #[inline]
    pub fn max_alpha(&self) -> f32 {
        self.alpha_u.max(self.alpha_v)
    }

    /// Normal distribution D(m) (projected area ∫ D(m) cos θm dm = 1).
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let (au, av) = (self.alpha_u, self.alpha_v);
        let auv = au * av;
        match self.distribution {
            Distribution::Ggx => {
                // With au == av this is the isotropic formula operation for operation, so
                // isotropic scenes render bit for bit as before anisotropy existed.
                let t = m.x * m.x / (au * au) + m.y * m.y / (av * av) + m.z * m.z;
                1.0 / (PI * auv * t * t)
            }
            Distribution::Beckmann => {
                let z2 = m.z * m.z;
                let e = -((m.x / au) * (m.x / au) + (m.y / av) * (m.y / av)) / z2;
                let d = e.exp() / (PI * auv * z2 * z2);
                // Mitsuba zeroes vanishing values (D·cos θ ≤ 1e-20) rather than keep denormals.
                if d * m.z > 1e-20 {
                    d
                } else {
                    0.0
                }
            }
        }
    }

    /// α² tan² θ of direction `w` along its azimuth (the projected roughness).
    #[inline]
    fn alpha2_tan2(&self, w: Vec3) -> f32 {
        let z2 = w.z * w.z;
        let (au, av) = (self.alpha_u, self.alpha_v);
        if au == av {
            // The isotropic expression as it always was (bit-identical images).
            au * au * ((w.x * w.x + w.y * w.y) / z2)
        } else {
            (au * au * w.x * w.x + av * av * w.y * w.y) / z2
        }
    }

    /// Smith Λ(w).
    #[inline]
    fn lambda(&self, w: Vec3) -> f32 {
        if w.z * w.z <= 0.0 {
            return f32::INFINITY;
        }
        let a2t2 = self.alpha2_tan2(w);
        match self.distribution {
            Distribution::Ggx => 0.5 * ((1.0 + a2t2).sqrt() - 1.0),
            Distribution::Beckmann => {
                if a2t2 <= 0.0 {
                    return 0.0;
                }
                // Exact Beckmann Λ with a = 1/(α tan θ). Mitsuba evaluates a rational fit of
                // it (< 0.35 % off); the exact form keeps eval, pdf and visible-normal
                // sampling consistent with one another.
                let a = 1.0 / a2t2.sqrt();
                if a >= 4.0 {
                    // Λ < 1e-8 here: erf(a) is 1 in f32 and the two terms cancel to noise.
                    return 0.0;
                }
                0.5 * (erf(a) - 1.0) + (-a * a).exp() * INV_SQRT_PI / (2.0 * a)
            }
        }
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

    /// Samples a microfacet normal visible from `w` (w.z > 0) with density
    /// [`Microfacet::pdf_visible`].
    #[inline]
    pub fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
        match self.distribution {
            Distribution::Ggx => self.sample_visible_ggx(w, u),
            Distribution::Beckmann => self.sample_visible_beckmann(w, u),
        }
    }

    /// GGX: Heitz 2018 — the stretched distribution is a hemisphere, whose visible part is a
    /// disk warped towards the viewer.
    #[inline]
    fn sample_visible_ggx(&self, w: Vec3, u: Vec2) -> Vec3 {
        let (au, av) = (self.alpha_u, self.alpha_v);
        let vh = Vec3::new(au * w.x, av * w.y, w.z).normalize();
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
        Vec3::new(au * nh.x, av * nh.y, nh.z.max(1e-6)).normalize()
    }

    /// Beckmann: Heitz & d'Eon 2014 — stretch to α = 1, sample the visible slopes there (the
    /// x slope by inverting its CDF numerically, the y slope is an independent Gaussian),
    /// rotate to the viewer's azimuth and unstretch.
    fn sample_visible_beckmann(&self, w: Vec3, u: Vec2) -> Vec3 {
        let (au, av) = (self.alpha_u, self.alpha_v);
        let ws = Vec3::new(au * w.x, av * w.y, w.z).normalize();
        let sin_theta = (1.0 - ws.z * ws.z).max(0.0).sqrt();
        let (cos_phi, sin_phi) = if sin_theta > 0.0 {
            let r = 1.0 / (ws.x * ws.x + ws.y * ws.y).sqrt();
            (ws.x * r, ws.y * r)
        } else {
            (1.0, 0.0)
        };
        let (sx, sy) = beckmann_visible_slopes_11(ws.z, sin_theta, u);
        let slope_x = (cos_phi * sx - sin_phi * sy) * au;
        let slope_y = (sin_phi * sx + cos_phi * sy) * av;
        Vec3::new(-slope_x, -slope_y, 1.0).normalize()
    }
}

/// Slopes of a Beckmann surface of α = 1 visible from a direction of elevation θ in the xz
/// plane (azimuth 0).
///
/// The x slope s has density ∝ (cos θ − s sin θ)⁺ e^{−s²}; in the variable x = erf(s) its
/// CDF is proportional to C(x) = 1 + x + tan θ e^{−s²}/√π on x ∈ [−1, erf(cot θ)], solved by
/// Newton's method safeguarded by bisection (C is increasing there), to convergence rather
/// than a fixed few steps so that samples follow the density lumo evaluates.
fn beckmann_visible_slopes_11(cos_theta: f32, sin_theta: f32, u: Vec2) -> (f32, f32) {
    let u = u.clamp(Vec2::splat(1e-6), Vec2::splat(1.0 - 1e-6));
    let sy = erfinv(2.0 * u.y - 1.0);
    if sin_theta <= 1e-4 {
        // Seen from straight above every normal is visible in proportion to D: the slopes
        // are two independent Gaussians of variance 1/2.
        return (erfinv(2.0 * u.x - 1.0), sy);
    }
    let tan_theta = sin_theta / cos_theta;
    let cot_theta = cos_theta / sin_theta;
    let x_max = erf(cot_theta);
    let c = |x: f32, s: f32| 1.0 + x + tan_theta * (-s * s).exp() * INV_SQRT_PI;
    // C(−1) = 0 and C(x_max) is the normalisation.
    let target = u.x * c(x_max, cot_theta);
    let (mut lo, mut hi) = (-1.0f32, x_max);
    // Start from the exact solution at grazing incidence, the most nonlinear case.
    let mut x = (x_max - (x_max + 1.0) * erf((-u.x.ln()).sqrt())).clamp(lo, hi);
    for _ in 0..40 {
        let s = erfinv(x);
        let value = c(x, s) - target;
        if value > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        if value.abs() <= 1e-7 * target.max(1e-3) || hi - lo <= 1e-7 {
            break;
        }
        let step = x - value / (1.0 - s * tan_theta);
        // Newton when it stays inside the bracket, bisection otherwise.
        x = if step > lo && step < hi && step.is_finite() {
            step
        } else {
            0.5 * (lo + hi)
        };
    }
    (erfinv(x), sy)
}

/// The error function, |error| < 1.5e-7 (Abramowitz & Stegun 7.1.26).
#[inline]
pub(crate) fn erf(x: f32) -> f32 {
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let poly = t
        * (0.254_829_6
            + t * (-0.284_496_74 + t * (1.421_413_7 + t * (-1.453_152_1 + t * 1.061_405_4))));
    let y = 1.0 - poly * (-x * x).exp();
    y.copysign(x)
}

/// The inverse error function on (−1, 1) (Giles 2010, single precision: a few ulp).
#[inline]
pub(crate) fn erfinv(x: f32) -> f32 {
    let x = x.clamp(-1.0 + 1e-7, 1.0 - 1e-7);
    let mut w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        w -= 2.5;
        let mut p = 2.810_226_4e-8;
        for c in [
            3.432_739_4e-7,
            -3.523_387_7e-6,
            -4.391_506_5e-6,
            0.000_218_580_87,
            -0.001_253_725,
            -0.004_177_681_6,
            0.246_640_73,
            1.501_409_4,
        ] {
            p = c + p * w;
        }
        p
    } else {
        w = w.sqrt() - 3.0;
        let mut p = -0.000_200_214_26;
        for c in [
            0.000_100_950_56,
            0.001_349_343_2,
            -0.003_673_428_4,
            0.005_739_507_7,
            -0.007_622_461,
            0.009_438_870_5,
            1.001_674,
            2.832_976_8,
        ] {
            p = c + p * w;
        }
        p
    };
    p * x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ f(θ, φ) sin θ dθ dφ over the upper hemisphere, midpoint rule.
    fn hemisphere(f: impl Fn(Vec3) -> f64) -> f64 {
        let (nt, np) = (2000, 128);
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
                sum += f(m) * theta.sin() as f64;
            }
        }
        sum * (PI as f64 / 2.0 / nt as f64) * (2.0 * PI as f64 / np as f64)
    }

    fn cases() -> Vec<Microfacet> {
        let mut v = vec![];
        for distribution in [Distribution::Ggx, Distribution::Beckmann] {
            for (au, av) in [(0.1, 0.1), (0.3, 0.3), (0.8, 0.8), (0.1, 0.4), (0.6, 0.2)] {
                v.push(Microfacet {
                    distribution,
                    alpha_u: au,
                    alpha_v: av,
                });
            }
        }
        v
    }

    #[test]
    fn projected_area_is_one() {
        // ∫ D(m) cos θm dm = 1.
        for mf in cases() {
            let sum = hemisphere(|m| (mf.d(m) * m.z) as f64);
            assert!((sum - 1.0).abs() < 5e-3, "{mf:?}: {sum}");
        }
    }

    #[test]
    fn visible_normals_are_normalised() {
        // ∫ G1(w) max(0, w·m) D(m) / w.z dm = 1 (Smith's Λ is consistent with D): checks Λ.
        for mf in cases() {
            for w in [
                Vec3::new(0.6, 0.0, 0.8),
                Vec3::new(-0.5, 0.7, 0.2).normalize(),
            ] {
                let sum = hemisphere(|m| mf.pdf_visible(w, m) as f64);
                assert!((sum - 1.0).abs() < 5e-3, "{mf:?} w {w}: {sum}");
            }
        }
    }

    #[test]
    fn erf_and_erfinv_invert() {
        for i in 1..200 {
            let x = -1.0 + i as f32 / 100.0;
            let y = erfinv(x);
            assert!((erf(y) - x).abs() < 5e-7, "{x}: erf(erfinv) = {}", erf(y));
        }
        // Known value: erf(0.5) = 0.5204998778.
        assert!((erf(0.5) - 0.520_499_9).abs() < 3e-7);
    }
}
