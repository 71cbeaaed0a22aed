//! The first hit's direct light split for temporal filtering, after the ratio estimator of
//! Heitz, Hill and McGuire (2018, "Combining analytic direct illumination and stochastic
//! shadows"): at a first hit whose BSDF has only broad lobes, the light of point, spot and
//! directional lights is exact (one shadow ray each); the *unshadowed* light of the other
//! lights is computed without shadow rays — in closed form on Lambertian surfaces lit by
//! constant-radiance triangles (`triangle_cosine_integral`, through `CosineTriangle`), else as the mean of
//! [`UNSHADOWED_SAMPLES`] light samples — and only the *shadowing* stays stochastic: one light
//! sample whose shadowed and unshadowed values a filter averages over space and time and
//! divides. Where a light moves but the shadows stay, that ratio keeps its history; the direct
//! light itself would not.
//!
//! Everything else (non-smooth or emitting first hits, indirect light) is left to the caller's
//! noisy image.

use glam::Vec3;
use lumo_image::{luminance, Image};
use rayon::prelude::*;

use crate::accel::packet::{RayPacket, LANES};
use crate::accel::Hit;
use crate::camera::PinholeCamera;
use crate::camera_hits::{camera_hits, pixel_centre_ray};
use crate::geometry::shadow_segment;
use crate::lights::{CosineTriangle, LightSample};
use crate::render_scene::{RenderScene, Surface};
use crate::sampler::PixelSampler;

/// Emissive triangles above which the closed form is not used (it costs one polygon integral
/// per triangle and pixel).
pub const MAX_ANALYTIC_TRIANGLES: usize = 64;

/// Unshadowed light samples per pixel where there is no closed form (no rays: a BSDF and a
/// light evaluation each), stratified as the first points of the pixel's Sobol sequence; the
/// ratio sample's own unshadowed value joins them (so 5 in all). On
/// the animated tuning sequence 4 stratified samples beat 8 independent ones (FLIP 0.0460
/// against 0.0471; 8 stratified: 0.0454 at twice the cost).
pub const UNSHADOWED_SAMPLES: usize = 4;

/// Decorrelate the split's light samples from the path tracer's (same pixel, same seed) and
/// from each other.
const SEED_SALT: u32 = 0x5bd1_e995;
const UNSHADOWED_SALT: u32 = 0x27d4_eb2f;

/// The first hit's direct light, split (see the module documentation). Radiance planes are RGB
/// towards the camera; all are zero where `split` is false.
#[derive(Clone, Debug)]
pub struct DirectSplit {
    /// The pixel-centre ray's first hit has only broad lobes (Lambertian, or plastic under a
    /// rough coat: `ShadingBsdf::all_lobes_broad`) and emits nothing towards the camera: only
    /// there is the direct light split.
    pub split: Vec<bool>,
    /// Light of the point, spot and directional lights, shadowed, exact.
    pub exact: Image,
    /// Unshadowed light of the other lights: exact, or a mean of [`UNSHADOWED_SAMPLES`].
    pub unshadowed: Image,
    /// One light sample of those lights, shadowed (channel 0) and unshadowed (channel 1), each
    /// divided by `unshadowed`'s luminance: the ratio estimator's two halves, which a filter
    /// averages alike; channel 1's expectation is about 1 wherever `unshadowed` is not 0.
    pub ratio: Image,
}

/// One pixel's share of a [`DirectSplit`].
#[derive(Clone, Copy, Debug, Default)]
struct PixelSplit {
    split: bool,
    exact: Vec3,
    unshadowed: Vec3,
    ratio: [f32; 2],
}

impl Default for DirectSplit {
    /// An empty split (0×0), to be filled by [`direct_split_into`].
    fn default() -> Self {
        Self {
            split: Vec::new(),
            exact: Image::new(0, 0, 3, 0.0),
            unshadowed: Image::new(0, 0, 3, 0.0),
            ratio: Image::new(0, 0, 2, 0.0),
        }
    }
}

/// Splits the direct light at the first hit of every pixel-centre ray of `camera` (`w`×`h`),
/// with the light samples drawn from `seed` (a frame's own seed gives new samples each frame).
/// Rows in parallel; within a row, camera rays and shadow rays go through the BVH sixteen at
/// a time (the packet traversal gives the bits of one ray at a time).
pub fn direct_split(
    rs: &RenderScene,
    camera: &PinholeCamera,
    w: usize,
    h: usize,
    seed: u32,
) -> DirectSplit {
    let mut out = DirectSplit::default();
    direct_split_into(&mut out, rs, camera, w, h, seed);
    out
}

/// [`direct_split`] written into `out`, whose planes are reused when they already have the
/// size: a sequence that splits every frame then allocates (and page-faults) nothing per
/// frame. Every element is overwritten, so the result is [`direct_split`]'s, bit for bit.
pub fn direct_split_into(
    out: &mut DirectSplit,
    rs: &RenderScene,
    camera: &PinholeCamera,
    w: usize,
    h: usize,
    seed: u32,
) {
    let hits = camera_hits(rs, camera, w, h);
    direct_split_at(out, rs, camera, &hits, w, h, seed);
}

/// [`direct_split_into`] at the pixel-centre rays' first hits `hits` (row-major, `w`×`h`, as
/// [`camera_hits`] gives them), so that a frame's passes share one set of camera rays
/// (`lumo render --temporal` takes its instance ids from the same hits). With the hits of
/// `camera`'s rays the result is [`direct_split`]'s, bit for bit.
pub fn direct_split_at(
    out: &mut DirectSplit,
    rs: &RenderScene,
    camera: &PinholeCamera,
    hits: &[Option<Hit>],
    w: usize,
    h: usize,
    seed: u32,
) {
    assert_eq!(hits.len(), w * h, "one hit per pixel");
    // The closed form covers every non-Dirac light, or none is used.
    let only_triangles = rs.lights.only_constant_triangles();
    let triangles: Vec<(CosineTriangle, Vec3)> = if only_triangles {
        let t = rs.lights.constant_triangles();
        t.take(MAX_ANALYTIC_TRIANGLES + 1)
            .map(|(c, l)| (CosineTriangle::new(&c), l))
            .collect()
    } else {
        Vec::new()
    };
    let closed =
        (only_triangles && triangles.len() <= MAX_ANALYTIC_TRIANGLES).then_some(&triangles[..]);
    out.split.resize(w * h, false);
    for (img, c) in [
        (&mut out.exact, 3),
        (&mut out.unshadowed, 3),
        (&mut out.ratio, 2),
    ] {
        if (img.width, img.height, img.channels) != (w, h, c) {
            *img = Image::new(w, h, c, 0.0);
        }
    }
    if w == 0 {
        return;
    }
    out.split
        .par_chunks_mut(w)
        .zip(out.exact.data.par_chunks_mut(3 * w))
        .zip(out.unshadowed.data.par_chunks_mut(3 * w))
        .zip(out.ratio.data.par_chunks_mut(2 * w))
        .zip(hits.par_chunks(w))
        .enumerate()
        .for_each_init(
            || (Vec::new(), Vec::new()),
            |(row, shadows), (y, ((((split, exact), unshadowed), ratio), hits))| {
                split_row(rs, camera, hits, y, seed, closed, row, shadows);
                for (x, p) in row.iter().enumerate() {
                    split[x] = p.split;
                    exact[3 * x..3 * x + 3].copy_from_slice(&p.exact.to_array());
                    unshadowed[3 * x..3 * x + 3].copy_from_slice(&p.unshadowed.to_array());
                    ratio[2 * x..2 * x + 2].copy_from_slice(&p.ratio);
                }
            },
        );
}

/// What a shadow ray decides once traced.
#[derive(Clone, Copy, Debug)]
enum Pending {
    /// Add this radiance to the pixel's `exact` if clear.
    Exact(Vec3),
    /// The ratio sample's unshadowed half: the shadowed one is it if clear, else 0.
    Ratio(f32),
}

/// A shadow ray waiting for its packet: pixel, what it decides, origin, direction, length.
type Shadow = (usize, Pending, Vec3, Vec3, f32);

/// Row `y` of the split into `out`, at the row's camera-ray hits `hits`; `closed` holds the
/// emissive triangles when their closed form is used; `shadows` is working memory.
#[allow(clippy::too_many_arguments)]
fn split_row(
    rs: &RenderScene,
    camera: &PinholeCamera,
    hits: &[Option<Hit>],
    y: usize,
    seed: u32,
    closed: Option<&[(CosineTriangle, Vec3)]>,
    out: &mut Vec<PixelSplit>,
    shadows: &mut Vec<Shadow>,
) {
    let w = hits.len();
    out.clear();
    out.resize(w, PixelSplit::default());
    shadows.clear();
    for x0 in (0..w).step_by(LANES) {
        let n = LANES.min(w - x0);
        for (x, hit) in hits.iter().enumerate().skip(x0).take(n) {
            let Some(hit) = hit else { continue };
            let (origin, dir) = pixel_centre_ray(camera, x, y);
            let at = ((x as u32, y as u32), seed);
            out[x] = shade(rs, origin, dir, hit, closed, at, &mut |p, o, d, t| {
                shadows.push((x, p, o, d, t))
            });
        }
        // Shadow rays in packets once a packet's worth is waiting (and at the row's end).
        if shadows.len() >= LANES || x0 + n == w {
            for batch in shadows.chunks(LANES) {
                let mut rays = RayPacket::default();
                for (lane, &(_, _, o, d, t)) in batch.iter().enumerate() {
                    rays.set(lane, o, d, 0.0, t);
                }
                let blocked = rs.accel.occluded_packet(&rays);
                for (lane, &(x, pending, ..)) in batch.iter().enumerate() {
                    let clear = blocked & (1 << lane) == 0;
                    match pending {
                        Pending::Exact(v) if clear => out[x].exact += v,
                        Pending::Exact(_) => {}
                        Pending::Ratio(u) => out[x].ratio = [if clear { u } else { 0.0 }, u],
                    }
                }
            }
            shadows.clear();
        }
    }
}

/// One pixel's split at `hit` of the camera ray `origin + t·dir`, without its shadow rays:
/// those go to `shadow` (what they decide, origin, direction, length).
fn shade(
    rs: &RenderScene,
    origin: Vec3,
    dir: Vec3,
    hit: &crate::accel::Hit,
    closed: Option<&[(CosineTriangle, Vec3)]>,
    (pixel, seed): ((u32, u32), u32),
    shadow: &mut dyn FnMut(Pending, Vec3, Vec3, f32),
) -> PixelSplit {
    let none = PixelSplit::default();
    let s = rs.surface(hit, origin, dir);
    let bsdf = rs.bsdf(&s);
    let wo = s.frame.to_local(-dir);
    if !bsdf.all_lobes_broad() || rs.emission(&s, dir) != Vec3::ZERO || wo.z <= 0.0 {
        return none;
    }
    // Reflected radiance of a light sample, as the path tracer weighs it without MIS.
    let value = |ls: &LightSample| bsdf.eval(wo, s.frame.to_local(ls.wi)) * ls.weight;
    let mut ray = |pending: Pending, ls: &LightSample| {
        let (o, d, t) = shadow_ray(rs, &s, ls);
        shadow(pending, o, d, t);
    };
    for ls in rs.lights.delta_samples(s.p) {
        let v = value(&ls);
        if v != Vec3::ZERO {
            ray(Pending::Exact(v), &ls);
        }
    }
    // The ratio sample: its shadow ray decides the shadowed half.
    let mut sampler = PixelSampler::new(pixel.0, pixel.1, 0, seed ^ SEED_SALT);
    let (uc, u) = (sampler.next_1d(), sampler.next_2d());
    let ratio_sample = rs
        .lights
        .sample_non_delta(s.p, uc, u)
        .map(|ls| (value(&ls), ls));
    let unshadowed = match (closed, bsdf.lambert()) {
        (Some(triangles), Some(albedo)) => {
            let n = s.frame.n;
            let e: Vec3 = triangles.iter().map(|(c, l)| *l * c.integral(s.p, n)).sum();
            albedo / std::f32::consts::PI * e
        }
        _ => {
            // Samples 0..K of the pixel's own (Owen-scrambled Sobol) sequence, stratified over
            // the light choice and the point on the light, and the ratio sample itself: with
            // it the estimate is not 0 where the ratio sample found light, which would lose
            // that sample (all K can miss, e.g. uniform environment samples below the horizon).
            let mut sum = ratio_sample.as_ref().map_or(Vec3::ZERO, |(v, _)| *v);
            for i in 0..UNSHADOWED_SAMPLES as u32 {
                let mut sp = PixelSampler::new(pixel.0, pixel.1, i, seed ^ UNSHADOWED_SALT);
                let (uc, u) = (sp.next_1d(), sp.next_2d());
                if let Some(ls) = rs.lights.sample_non_delta(s.p, uc, u) {
                    sum += value(&ls);
                }
            }
            sum / (UNSHADOWED_SAMPLES + 1) as f32
        }
    };
    let a = luminance(unshadowed.to_array());
    if let Some((v, ls)) = ratio_sample {
        let v = luminance(v.to_array());
        if a > 0.0 && v > 0.0 {
            ray(Pending::Ratio(v / a), &ls);
        }
    }
    PixelSplit {
        split: true,
        unshadowed,
        ..none
    }
}

/// The shadow ray from surface `s` towards light sample `ls` (origin, direction, length), as
/// the path tracer builds its own.
pub(crate) fn shadow_ray(rs: &RenderScene, s: &Surface, ls: &LightSample) -> (Vec3, Vec3, f32) {
    let o = rs.offset(s, ls.wi);
    if ls.distance.is_finite() {
        let (d, t) = shadow_segment(o.into(), ls.point.into(), ls.wi.into(), rs.ray_epsilon);
        (o, Vec3::from(d), t)
    } else {
        (o, ls.wi, f32::INFINITY)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{trace_path, PathSettings};
    use glam::Vec2;
    use lumo_scene::{builtin_scene, BsdfSpec, Light, Roughness, Scene};

    /// How far one pixel's 256-sample mean may stray from the path tracer's, as a share of
    /// the image's mean direct light (both are noisy means; a wrong pixel is off by more).
    const PER_PIXEL: f64 = 0.35;

    /// The Cornell box with a point light added beside its area light.
    fn cornell_with_point() -> Scene {
        let mut scene = builtin_scene("cornell").expect("built-in scene");
        let (lo, hi) = scene.bounds();
        let c = (lo + hi) * 0.5;
        scene.lights.push(Light::Point {
            position: Vec3::new(c.x + 0.2 * (hi.x - lo.x), c.y, c.z),
            intensity: Vec3::splat(2.0),
            range: None,
        });
        scene
    }

    /// Per pixel, the mean over `n` seeds of the split's estimate (exact + unshadowed ×
    /// shadowed half) and of its unshadowed half, and the path tracer's direct light through
    /// the same pixel centre (MIS-weighted light and BSDF samples), `n` paths; and the mask.
    struct Means {
        split: Vec<f64>,
        half: Vec<f64>,
        path: Vec<f64>,
        mask: Vec<bool>,
        /// The unshadowed light is not 0 (the split's first seed).
        lit: Vec<bool>,
    }

    fn means(rs: &RenderScene, w: usize, h: usize, n: u32) -> Means {
        let camera = PinholeCamera::new(&rs.scene.camera, w, h);
        let first = direct_split(rs, &camera, w, h, 0);
        let (mut split, mut half) = (vec![0.0f64; w * h], vec![0.0f64; w * h]);
        for seed in 0..n {
            let d = direct_split(rs, &camera, w, h, seed);
            assert_eq!(d.split, first.split, "the mask does not depend on the seed");
            assert_eq!(d.exact.data, first.exact.data, "Dirac lights are exact");
            for i in 0..w * h {
                let (s, u) = (d.ratio.data[i * 2], d.ratio.data[i * 2 + 1]);
                assert!(
                    s == u || s == 0.0,
                    "the shadowed half is the unshadowed one or 0"
                );
                let px = |img: &Image| Vec3::from_slice(&img.data[i * 3..i * 3 + 3]);
                let v = px(&d.exact) + px(&d.unshadowed) * s;
                split[i] += luminance(v.to_array()) as f64 / n as f64;
                half[i] += u as f64 / n as f64;
            }
        }
        let settings = PathSettings::default();
        let origin = camera.origin();
        let path = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let dir = camera.direction(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                (0..n)
                    .map(|k| {
                        let mut sampler = PixelSampler::new(x as u32, y as u32, k, 3);
                        let d = trace_path(rs, origin, dir, &mut sampler, &settings, None).direct;
                        luminance(d.to_array()) as f64
                    })
                    .sum::<f64>()
                    / n as f64
            })
            .collect();
        let lit = first
            .unshadowed
            .data
            .chunks_exact(3)
            .map(|c| luminance([c[0], c[1], c[2]]) > 0.0)
            .collect();
        Means {
            split,
            half,
            path,
            mask: first.split,
            lit,
        }
    }

    /// Checks that most pixels are split, that none strays from the path tracer by more than
    /// [`PER_PIXEL`] of the mean (a sum alone would let errors cancel), and that the sums
    /// over the split pixels agree within 1 %.
    fn agrees_with_the_path_tracer(m: &Means) {
        let on: Vec<usize> = (0..m.mask.len()).filter(|&i| m.mask[i]).collect();
        assert!(on.len() > m.mask.len() / 2, "{} pixels split", on.len());
        let mean = on.iter().map(|&i| m.path[i]).sum::<f64>() / on.len() as f64;
        let worst = on
            .iter()
            .map(|&i| (m.split[i] - m.path[i]).abs() / mean)
            .fold(0.0, f64::max);
        assert!(worst < PER_PIXEL, "a pixel is off by {worst} of the mean");
        let (ours, theirs) = on
            .iter()
            .fold((0.0, 0.0), |(a, b), &i| (a + m.split[i], b + m.path[i]));
        assert!(
            (ours / theirs - 1.0).abs() < 0.01,
            "split {ours}, path tracer {theirs}"
        );
    }

    /// Written over a split of another size and of another seed (stale values everywhere),
    /// [`direct_split_into`] gives [`direct_split`]'s planes bit for bit: nothing of the old
    /// frame survives in the reused memory.
    #[test]
    fn a_reused_split_equals_a_fresh_one() {
        let rs = RenderScene::new(cornell_with_point()).expect("scene");
        let (w, h) = (23, 17);
        let camera = PinholeCamera::new(&rs.scene.camera, w, h);
        let fresh = direct_split(&rs, &camera, w, h, 5);
        for (ow, oh) in [(w, h), (31, 9)] {
            let mut reused = direct_split(
                &rs,
                &PinholeCamera::new(&rs.scene.camera, ow, oh),
                ow,
                oh,
                9,
            );
            reused.ratio.data.fill(7.0);
            reused.exact.data.fill(7.0);
            reused.unshadowed.data.fill(7.0);
            reused.split.fill(true);
            direct_split_into(&mut reused, &rs, &camera, w, h, 5);
            assert_eq!(reused.split, fresh.split);
            for (a, b) in [
                (&reused.exact, &fresh.exact),
                (&reused.unshadowed, &fresh.unshadowed),
                (&reused.ratio, &fresh.ratio),
            ] {
                assert_eq!(
                    (a.width, a.height, a.channels),
                    (b.width, b.height, b.channels)
                );
                let bits = |i: &Image| i.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(a), bits(b));
            }
        }
    }

    /// Averaged over many light samples, the split carries the direct light the path tracer
    /// estimates at the same pixels; where the closed form is used, the unshadowed half
    /// averages to 1 over the split pixels where the closed form is not 0 (which ties the
    /// closed form to the light sampler).
    #[test]
    fn the_closed_form_split_averages_to_the_path_tracers_direct_light() {
        let rs = RenderScene::new(cornell_with_point()).expect("scene");
        let m = means(&rs, 20, 20, 256);
        agrees_with_the_path_tracer(&m);
        let lit: Vec<f64> = (0..m.mask.len())
            .filter(|&i| m.mask[i] && m.lit[i])
            .map(|i| m.half[i])
            .collect();
        let u_mean = lit.iter().sum::<f64>() / lit.len() as f64;
        assert!(
            (u_mean - 1.0).abs() < 0.01,
            "unshadowed half averages {u_mean}"
        );
    }

    /// The same with every material a plastic under a rough coat: no closed form, so the
    /// unshadowed light is a mean of light samples through the BSDF.
    #[test]
    fn the_sampled_split_averages_to_the_path_tracers_direct_light_on_rough_plastic() {
        let mut scene = cornell_with_point();
        for m in &mut scene.materials {
            if let BsdfSpec::Diffuse { reflectance } = &m.bsdf {
                m.bsdf = BsdfSpec::Plastic {
                    diffuse: reflectance.clone(),
                    ior: 1.5,
                    roughness: Roughness::ggx(0.3),
                    nonlinear: false,
                    exact_rough_coat: false,
                };
            }
        }
        let rs = RenderScene::new(scene).expect("scene");
        agrees_with_the_path_tracer(&means(&rs, 20, 20, 256));
    }

    /// The same with a point, a spot, a sun and a constant environment beside the area light
    /// (the environment has no closed form, so the unshadowed light is sampled).
    #[test]
    fn the_split_averages_to_the_path_tracers_direct_light_under_every_light_kind() {
        let mut scene = builtin_scene("cornell").expect("built-in scene");
        scene
            .lights
            .extend(crate::test_lights::every_other_light_kind());
        let rs = RenderScene::new(scene).expect("scene");
        agrees_with_the_path_tracer(&means(&rs, 20, 20, 256));
    }
}
