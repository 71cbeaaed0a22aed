//! The camera side of photon mapping: a camera path follows delta (specular) bounces, and at
//! every vertex with a non-delta part it adds direct light by next-event estimation and
//! indirect light by a density estimate over the photons within the pass's radius.
//!
//! Emitters seen directly or through delta bounces count as in the path tracer (there is no
//! BSDF-sampled continuation from a gathering vertex to weigh them against, so next-event
//! estimation here is pure light sampling, MIS weight 1). A vertex whose BSDF mixes delta and
//! smooth lobes (smooth plastic) gathers for its smooth part and continues only when the
//! sampled lobe is a delta one: the continuation then estimates the delta lobes' share, the
//! gather the rest, and nothing is counted twice.

use std::f32::consts::PI;

use glam::Vec3;

use super::map::MapState;
use crate::geometry::shadow_segment;
use crate::integrators::path::{PathRadiance, PathSettings};
use crate::render_scene::RenderScene;
use crate::sampler::PixelSampler;

/// Photons whose surface normal is further than this (|cos|) from the gathering surface's are
/// skipped: a disc reaching round a corner onto a perpendicular wall would leak its light.
/// The test only changes the bias, which the shrinking radius removes anyway.
const NORMAL_COS: f32 = 0.8;

/// What one camera sample did, beyond its radiance.
#[derive(Clone, Copy, Debug, Default)]
pub struct GatherStats {
    /// Rays traced (closest-hit and shadow).
    pub rays: u32,
    /// Photons that contributed.
    pub photons: u32,
    /// Whether the path reached a vertex that gathers (a non-delta surface).
    pub gathered: bool,
}

/// Traces a camera path from `origin` along unit `dir` with the numbers of `sampler` and
/// gathers from `map` within `radius`. Returns its radiance (direct: emitters and NEE, depth
/// ≤ 2; indirect: photons) and what it did. A pure function of its arguments.
pub fn trace_ppm_path(
    rs: &RenderScene,
    map: &MapState,
    radius: f32,
    origin: Vec3,
    dir: Vec3,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
) -> (PathRadiance, GatherStats) {
    let mut out = PathRadiance::default();
    let mut stats = GatherStats::default();
    let (mut origin, mut dir) = (origin, dir);
    let mut throughput = Vec3::ONE;
    // Segments from the camera to the vertex about to be hit.
    let mut depth = 1u32;
    let area = PI * radius * radius;
    loop {
        stats.rays += 1;
        let Some(hit) = rs.accel.intersect(origin, dir, 0.0, f32::INFINITY) else {
            out.add(depth, throughput * rs.lights.environment(dir));
            break;
        };
        let s = rs.surface(&hit, origin, dir);
        let bsdf = rs.bsdf(&s);
        out.add(depth, throughput * rs.emission(&s, dir));
        if depth >= settings.max_depth {
            break;
        }
        let wo = s.frame.to_local(-dir);
        if wo.z <= 0.0 && rs.one_sided(s.material) {
            break;
        }
        // Always all numbers, in one order, whichever branches run.
        let u_light = sampler.next_1d();
        let u_point = sampler.next_2d();
        let u_lobe = sampler.next_1d();
        let u_dir = sampler.next_2d();
        if !bsdf.is_delta() {
            stats.gathered = true;
            if settings.nee {
                if let Some(ls) = rs.lights.sample(s.p, u_light, u_point) {
                    let f = bsdf.eval(wo, s.frame.to_local(ls.wi));
                    if f != Vec3::ZERO {
                        let o = rs.offset(&s, ls.wi);
                        let (d, tmax) = if ls.distance.is_finite() {
                            let (d, t) = shadow_segment(
                                o.into(),
                                ls.point.into(),
                                ls.wi.into(),
                                rs.ray_epsilon,
                            );
                            (Vec3::from(d), t)
                        } else {
                            (ls.wi, f32::INFINITY)
                        };
                        stats.rays += 1;
                        if !rs.accel.occluded(o, d, 0.0, tmax) {
                            out.add(depth + 1, throughput * f * ls.weight);
                        }
                    }
                }
            }
            if map.paths > 0 && depth + 2 <= settings.max_depth && area > 0.0 {
                let mut sum = Vec3::ZERO;
                let mut n = 0u32;
                map.tree.for_each_within(s.p, radius, |ph| {
                    if depth + ph.depth > settings.max_depth || ph.ng.dot(s.ng).abs() < NORMAL_COS {
                        return;
                    }
                    let cos_ng = ph.ng.dot(ph.wi).abs();
                    let f = bsdf.eval(wo, s.frame.to_local(ph.wi));
                    if f != Vec3::ZERO && cos_ng > 0.0 {
                        // f·|cos θ_shading| / |cos θ_geometric|: the arrival half of the
                        // adjoint correction (flux per geometric area → shading cosine).
                        sum += ph.power * f / cos_ng;
                        n += 1;
                    }
                });
                stats.photons += n;
                if n > 0 {
                    // Every photon has depth ≥ 2, so this is indirect light (depth ≥ 3).
                    out.add(depth + 2, throughput * sum / (map.paths as f32 * area));
                }
            }
        }
        let Some(bs) = bsdf.sample(wo, u_lobe, u_dir) else {
            break;
        };
        // A smooth lobe's share is what the gather just estimated.
        if !bs.delta {
            break;
        }
        let new_dir = s.frame.to_world(bs.wi).normalize();
        let reflect = bs.wi.z * wo.z > 0.0;
        if reflect != (new_dir.dot(s.ng) * (-dir).dot(s.ng) > 0.0) {
            break;
        }
        throughput *= bs.weight;
        if throughput == Vec3::ZERO || !throughput.is_finite() {
            break;
        }
        origin = rs.offset(&s, new_dir);
        dir = new_dir;
        depth += 1;
    }
    (out, stats)
}
