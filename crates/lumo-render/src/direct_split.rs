//! The first hit's direct light split for temporal filtering, after the ratio estimator of
//! Heitz, Hill and McGuire (2018, "Combining analytic direct illumination and stochastic
//! shadows"): at a Lambertian first hit, the light of point, spot and directional lights is
//! exact (one shadow ray each), the unshadowed light of constant-radiance emissive triangles has
//! a closed form (`polygon_cosine_integral`), and only the *shadowing* of the latter stays
//! stochastic — one light sample whose shadowed and unshadowed values a filter averages over
//! space and time and divides. Where the light moves but the shadows do not, that ratio keeps
//! its history; the direct light itself would not.
//!
//! Everything else (other lights, non-Lambertian or emitting first hits, indirect light) is
//! left to the caller's noisy image.

use glam::{Vec2, Vec3};
use lumo_image::{luminance, Image};

use crate::camera::PinholeCamera;
use crate::geometry::shadow_segment;
use crate::lights::{polygon_cosine_integral, LightSample};
use crate::render::map_pixels;
use crate::render_scene::{RenderScene, Surface};
use crate::sampler::PixelSampler;

/// Emissive triangles above which the closed form is not used (it costs one polygon integral
/// per triangle and pixel): their light then stays in `rest`.
pub const MAX_ANALYTIC_TRIANGLES: usize = 64;

/// Decorrelates the split's light sample from the path tracer's (same pixel, same seed).
const SEED_SALT: u32 = 0x5bd1_e995;

/// The first hit's direct light, split (see the module documentation). Radiance planes are RGB
/// towards the camera; all are zero where `split` is false.
#[derive(Clone, Debug)]
pub struct DirectSplit {
    /// The pixel-centre ray's first hit is a plain Lambertian surface that emits nothing
    /// towards the camera: only there is the direct light split.
    pub split: Vec<bool>,
    /// Light of the point, spot and directional lights, shadowed, exact.
    pub exact: Image,
    /// Unshadowed light of the constant-radiance emissive triangles, exact.
    pub analytic: Image,
    /// One light sample of those triangles, shadowed (channel 0) and unshadowed (channel 1),
    /// each divided by `analytic`'s luminance: the ratio estimator's two halves, which a
    /// filter averages alike; channel 1's expectation is 1 wherever `analytic` is not 0.
    pub ratio: Image,
    /// One light sample of the other non-Dirac lights (environment, emissive shapes,
    /// textured triangles; all triangles past [`MAX_ANALYTIC_TRIANGLES`]), shadowed.
    pub rest: Image,
}

/// One pixel's share of a [`DirectSplit`].
#[derive(Clone, Copy, Debug, Default)]
struct PixelSplit {
    split: bool,
    exact: Vec3,
    analytic: Vec3,
    ratio: [f32; 2],
    rest: Vec3,
}

/// Splits the direct light at the first hit of every pixel-centre ray of `camera` (`w`×`h`),
/// with the light sample drawn from `seed` (a frame's own seed gives a new sample each frame).
pub fn direct_split(
    rs: &RenderScene,
    camera: &PinholeCamera,
    w: usize,
    h: usize,
    seed: u32,
) -> DirectSplit {
    let triangles: Vec<([Vec3; 3], Vec3)> = rs
        .lights
        .constant_triangles()
        .map(|(_, c, l)| (c, l))
        .collect();
    let analytic = triangles.len() <= MAX_ANALYTIC_TRIANGLES;
    let origin = camera.origin();
    let pixels = map_pixels(w, h, &|_| {}, |x, y| {
        let dir = camera.direction(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
        let mut sampler = PixelSampler::new(x as u32, y as u32, 0, seed ^ SEED_SALT);
        split_pixel(rs, origin, dir, &triangles, analytic, &mut sampler)
    });
    let mut out = DirectSplit {
        split: pixels.iter().map(|p| p.split).collect(),
        exact: Image::new(w, h, 3, 0.0),
        analytic: Image::new(w, h, 3, 0.0),
        ratio: Image::new(w, h, 2, 0.0),
        rest: Image::new(w, h, 3, 0.0),
    };
    for (i, p) in pixels.iter().enumerate() {
        out.exact.data[i * 3..i * 3 + 3].copy_from_slice(&p.exact.to_array());
        out.analytic.data[i * 3..i * 3 + 3].copy_from_slice(&p.analytic.to_array());
        out.rest.data[i * 3..i * 3 + 3].copy_from_slice(&p.rest.to_array());
        out.ratio.data[i * 2..i * 2 + 2].copy_from_slice(&p.ratio);
    }
    out
}

fn split_pixel(
    rs: &RenderScene,
    origin: Vec3,
    dir: Vec3,
    triangles: &[([Vec3; 3], Vec3)],
    analytic: bool,
    sampler: &mut PixelSampler,
) -> PixelSplit {
    let none = PixelSplit::default();
    let Some(hit) = rs.accel.intersect(origin, dir, 0.0, f32::INFINITY) else {
        return none;
    };
    let s = rs.surface(&hit, origin, dir);
    let Some(albedo) = rs.bsdf(&s).lambert() else {
        return none;
    };
    if rs.emission(&s, dir) != Vec3::ZERO || s.frame.to_local(-dir).z <= 0.0 {
        return none;
    }
    let n = s.frame.n;
    let brdf = albedo / std::f32::consts::PI;
    // Irradiance of a light sample if its shadow ray is clear (the path tracer's test).
    let lit = |ls: &LightSample| -> Option<(Vec3, bool)> {
        let cos = n.dot(ls.wi);
        if cos <= 0.0 {
            return None;
        }
        Some((ls.weight * cos, !occluded(rs, &s, ls)))
    };
    let mut out = PixelSplit {
        split: true,
        ..none
    };
    for ls in rs.lights.delta_samples(s.p) {
        if let Some((e, true)) = lit(&ls) {
            out.exact += brdf * e;
        }
    }
    if analytic {
        let e: Vec3 = triangles
            .iter()
            .map(|(c, l)| *l * polygon_cosine_integral(s.p, n, c))
            .sum();
        out.analytic = brdf * e;
    }
    let (u_choice, u) = (sampler.next_1d(), sampler.next_2d());
    if let Some(ls) = rs.lights.sample_non_delta(s.p, u_choice, u) {
        if let Some((e, clear)) = lit(&ls) {
            if analytic && rs.lights.is_constant_triangle(ls.light) {
                let a = luminance(out.analytic.to_array());
                if a > 0.0 {
                    let unshadowed = luminance((brdf * e).to_array()) / a;
                    out.ratio = [if clear { unshadowed } else { 0.0 }, unshadowed];
                }
            } else if clear {
                out.rest = brdf * e;
            }
        }
    }
    out
}

/// Whether the shadow ray from surface `s` towards light sample `ls` is blocked, tested as the
/// path tracer tests its own.
fn occluded(rs: &RenderScene, s: &Surface, ls: &LightSample) -> bool {
    let o = rs.offset(s, ls.wi);
    let (d, tmax) = if ls.distance.is_finite() {
        let (d, t) = shadow_segment(o.into(), ls.point.into(), ls.wi.into(), rs.ray_epsilon);
        (Vec3::from(d), t)
    } else {
        (ls.wi, f32::INFINITY)
    };
    rs.accel.occluded(o, d, 0.0, tmax)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{trace_path, PathSettings};
    use lumo_scene::{builtin_scene, Light};

    /// The Cornell box with a point light added beside its area light.
    fn cornell_with_point() -> RenderScene {
        let mut scene = builtin_scene("cornell").expect("built-in scene");
        let (lo, hi) = scene.bounds();
        let c = (lo + hi) * 0.5;
        scene.lights.push(Light::Point {
            position: Vec3::new(c.x + 0.2 * (hi.x - lo.x), c.y, c.z),
            intensity: Vec3::splat(2.0),
        });
        RenderScene::new(scene).expect("scene")
    }

    /// Averaged over many light samples, the split (exact + analytic × the mean shadowed half
    /// + the rest) carries the direct light the path tracer estimates (MIS-weighted light and
    /// BSDF samples) at the same pixels; the unshadowed half averages to 1, which ties the
    /// closed form to the light sampler; and a sample that reaches the light has equal halves.
    #[test]
    fn the_split_averages_to_the_path_tracers_direct_light() {
        let rs = cornell_with_point();
        let (w, h) = (20, 20);
        let camera = PinholeCamera::new(&rs.scene.camera, w, h);
        let n = 256;
        let mut s_sum = vec![0.0f64; w * h];
        let mut u_sum = vec![0.0f64; w * h];
        let mut rest = vec![Vec3::ZERO; w * h];
        let first = direct_split(&rs, &camera, w, h, 0);
        for seed in 0..n {
            let d = direct_split(&rs, &camera, w, h, seed);
            assert_eq!(d.split, first.split, "the mask does not depend on the seed");
            assert_eq!(d.exact.data, first.exact.data, "exact is exact");
            for i in 0..w * h {
                let (s, u) = (d.ratio.data[i * 2], d.ratio.data[i * 2 + 1]);
                assert!(
                    s == u || s == 0.0,
                    "shadowed half is the unshadowed one or 0"
                );
                s_sum[i] += s as f64;
                u_sum[i] += u as f64;
                rest[i] += Vec3::from_slice(&d.rest.data[i * 3..i * 3 + 3]);
            }
        }
        // The path tracer's direct light through the same pixel centres.
        let settings = PathSettings::default();
        let origin = camera.origin();
        let path_direct: Vec<Vec3> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let dir = camera.direction(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                (0..n)
                    .map(|k| {
                        let mut sampler = PixelSampler::new(x as u32, y as u32, k, 3);
                        trace_path(&rs, origin, dir, &mut sampler, &settings, None).direct
                    })
                    .sum::<Vec3>()
                    / n as f32
            })
            .collect();
        let (mut ours, mut path, mut u_all, mut count) = (0.0f64, 0.0f64, 0.0f64, 0usize);
        for i in 0..w * h {
            if !first.split[i] {
                continue;
            }
            let a = Vec3::from_slice(&first.analytic.data[i * 3..i * 3 + 3]);
            let e = Vec3::from_slice(&first.exact.data[i * 3..i * 3 + 3]);
            let v = e + a * (s_sum[i] / n as f64) as f32 + rest[i] / n as f32;
            ours += luminance(v.to_array()) as f64;
            path += luminance(path_direct[i].to_array()) as f64;
            if luminance(a.to_array()) > 0.0 {
                u_all += u_sum[i] / n as f64;
                count += 1;
            }
        }
        assert!(count > w * h / 2, "{count} pixels see the light");
        let u_mean = u_all / count as f64;
        assert!(
            (u_mean - 1.0).abs() < 0.01,
            "unshadowed half averages {u_mean}"
        );
        assert!(
            (ours / path - 1.0).abs() < 0.01,
            "split {ours} against the path tracer's {path}"
        );
        assert!(
            first.exact.data.iter().any(|&v| v > 0.0),
            "the point light lights"
        );
    }
}
