//! The unidirectional path tracer: next-event estimation with multiple importance sampling
//! (power heuristic), Russian roulette, and separate direct and indirect estimates.
//!
//! Depth follows Mitsuba: a path of `k` segments has depth `k`; `max_depth = 1` shows emitters
//! only, `2` adds direct light, `3` one indirect bounce. "Direct" is everything of depth ≤ 2.

use glam::Vec3;

use crate::geometry::power_heuristic;
use crate::render_scene::RenderScene;
use crate::sampler::PixelSampler;

/// Integrator parameters.
#[derive(Clone, Copy, Debug)]
pub struct PathSettings {
    /// Longest path depth (Mitsuba convention).
    pub max_depth: u32,
    /// Depth from which Russian roulette may end paths.
    pub rr_depth: u32,
    /// Light sampling (next-event estimation) on.
    pub nee: bool,
    /// BSDF-sampled hits of emitters count (off: NEE only, for tests).
    pub bsdf_emission: bool,
}

impl Default for PathSettings {
    fn default() -> Self {
        Self {
            max_depth: 8,
            rr_depth: 5,
            nee: true,
            bsdf_emission: true,
        }
    }
}

/// What the first hit of a camera ray looks like, for the G-buffer.
#[derive(Clone, Copy, Debug, Default)]
pub struct FirstHit {
    /// Shading normal facing the camera (zero on a miss).
    pub normal: Vec3,
    /// World position (zero on a miss).
    pub position: Vec3,
    /// Distance from the camera (infinite on a miss).
    pub depth: f32,
    /// Reflectance used for demodulation (zero on a miss).
    pub albedo: Vec3,
    /// Radiance emitted towards the camera at the hit (the environment's on a miss): pipelines
    /// keep emitters out of the filters, which would otherwise smear them over their neighbours.
    pub emitted: Vec3,
}

/// Radiance carried by one camera path, split by depth.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathRadiance {
    /// Emitted light seen directly plus direct illumination (depth ≤ 2).
    pub direct: Vec3,
    /// Everything of depth ≥ 3.
    pub indirect: Vec3,
    /// Rays traced (closest-hit and shadow).
    pub rays: u32,
}

impl PathRadiance {
    #[inline]
    fn add(&mut self, depth: u32, value: Vec3) {
        // A NaN from a degenerate configuration must not poison the pixel.
        if !value.is_finite() {
            return;
        }
        if depth <= 2 {
            self.direct += value;
        } else {
            self.indirect += value;
        }
    }
}

/// Traces one path starting with the ray `origin + t·dir` (unit `dir`).
pub fn trace_path(
    rs: &RenderScene,
    origin: Vec3,
    dir: Vec3,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
    mut first_hit: Option<&mut FirstHit>,
) -> PathRadiance {
    let mut out = PathRadiance::default();
    let mut throughput = Vec3::ONE;
    let (mut origin, mut dir) = (origin, dir);
    // Density of the BSDF sample that produced the current ray; None for camera rays and
    // delta lobes (no MIS against light sampling).
    let mut prev_pdf: Option<f32> = None;
    let mut prev_point = origin;
    let mut eta_scale = 1.0f32;
    let mut depth = 1u32;
    loop {
        out.rays += 1;
        let Some(hit) = rs.accel.intersect(origin, dir, 0.0, f32::INFINITY) else {
            if depth == 1 || settings.bsdf_emission || prev_pdf.is_none() {
                let le = rs.lights.environment(dir);
                if le != Vec3::ZERO {
                    let w = match prev_pdf {
                        Some(pdf) if settings.nee => {
                            power_heuristic(pdf, rs.lights.environment_pdf(dir))
                        }
                        _ => 1.0,
                    };
                    out.add(depth, throughput * le * w);
                }
            }
            if let Some(fh) = first_hit.take() {
                *fh = FirstHit {
                    depth: f32::INFINITY,
                    emitted: rs.lights.environment(dir),
                    ..Default::default()
                };
            }
            break;
        };
        let s = rs.surface(&hit, origin, dir);
        let bsdf = rs.bsdf(&s);
        let le = rs.emission(&s, dir);
        if let Some(fh) = first_hit.take() {
            let n = s.frame.n;
            *fh = FirstHit {
                normal: if n.dot(dir) > 0.0 { -n } else { n },
                position: s.p,
                depth: hit.t,
                albedo: bsdf.albedo(),
                emitted: le,
            };
        }
        if le != Vec3::ZERO && (depth == 1 || settings.bsdf_emission || prev_pdf.is_none()) {
            let w = match prev_pdf {
                Some(pdf) if settings.nee => power_heuristic(
                    pdf,
                    rs.lights
                        .triangle_pdf(s.instance, s.triangle, prev_point, s.p),
                ),
                _ => 1.0,
            };
            out.add(depth, throughput * le * w);
        }
        if depth >= settings.max_depth {
            break;
        }
        let wo = s.frame.to_local(-dir);
        // Next-event estimation.
        let u_light = sampler.next_1d();
        let u_light2 = sampler.next_2d();
        if settings.nee && !bsdf.is_delta() {
            if let Some(ls) = rs.lights.sample(s.p, u_light, u_light2) {
                let wi = s.frame.to_local(ls.wi);
                // Reject light from below the geometric surface unless the BSDF transmits.
                let f = bsdf.eval(wo, wi);
                if f != Vec3::ZERO {
                    let o = rs.offset(&s, ls.wi);
                    let tmax = if ls.distance.is_finite() {
                        (ls.distance - (o - s.p).length()) * (1.0 - 1e-4)
                    } else {
                        f32::INFINITY
                    };
                    out.rays += 1;
                    if !rs.accel.occluded(o, ls.wi, 0.0, tmax) {
                        let w = if ls.pdf > 0.0 && settings.bsdf_emission {
                            power_heuristic(ls.pdf, bsdf.pdf(wo, wi))
                        } else {
                            1.0
                        };
                        out.add(depth + 1, throughput * f * ls.weight * w);
                    }
                }
            }
        }
        // Continue the path by sampling the BSDF.
        let u_lobe = sampler.next_1d();
        let u_dir = sampler.next_2d();
        let u_rr = sampler.next_1d();
        let Some(bs) = bsdf.sample(wo, u_lobe, u_dir) else {
            break;
        };
        let new_dir = s.frame.to_world(bs.wi).normalize();
        // Shading normals can send a sample through the geometric surface; drop it.
        let reflect = bs.wi.z * wo.z > 0.0;
        if reflect != (new_dir.dot(s.ng) * (-dir).dot(s.ng) > 0.0) {
            break;
        }
        throughput *= bs.weight;
        if bs.eta != 1.0 {
            eta_scale *= bs.eta * bs.eta;
        }
        prev_pdf = if bs.delta { None } else { Some(bs.pdf) };
        prev_point = s.p;
        origin = rs.offset(&s, new_dir);
        dir = new_dir;
        if depth >= settings.rr_depth {
            // Roulette on throughput without the 1/η² radiance scaling (as Mitsuba does), so
            // paths inside glass are not killed for a change of units.
            let q = (throughput.max_element() * eta_scale).min(0.95);
            if u_rr >= q {
                break;
            }
            throughput /= q;
        }
        if throughput == Vec3::ZERO {
            break;
        }
        depth += 1;
    }
    out
}
