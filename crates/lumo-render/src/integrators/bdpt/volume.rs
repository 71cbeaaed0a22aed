//! Bidirectional path tracing in scenes with participating media or null boundaries, one
//! sample at a time (docs/media.md).
//!
//! Both subpaths walk the media as the path and light tracers do ([`crate::media::walk`]):
//! each ray samples a free flight in the medium it travels through (one colour lane per
//! subpath samples chromatic media, with the lanes' path-space MIS record), a real
//! scattering becomes a medium vertex whose phase function is sampled next, and null
//! surfaces are crossed without a vertex, changing the medium where the shape has an
//! interface. Every strategy's shadow segment carries the transmittance of the media and
//! null boundaries on the way (ratio tracking in grids) instead of a visibility test.
//!
//! The weights are the surface BDPT's ([`super::mis`]) with medium vertices in them: no
//! cosine at a medium vertex (its area density is the solid-angle density over the squared
//! distance), the phase function as its direction density. As in pbrt-v3's volumetric BDPT,
//! the densities of the free-flight distances are left out of every strategy's density:
//! each segment a strategy samples would bring the same factor in either direction in a
//! homogeneous medium, so leaving it out changes only how the weights split a path between
//! strategies (they still sum to one), not the estimate's mean.

use glam::{Vec2, Vec3};

use super::connect::{finish, Contribution};
use super::subpath::{camera_start, first_segment_window, light_start, step, Walk};
use super::vertex::{area_density_along, Context, Kind, Vertex};
use super::{add, prepare_all, BdptScratch, BdptSettings};
use crate::bsdf::TransportMode;
use crate::integrators::light::LightSplat;
use crate::integrators::path::{PathRadiance, PathSettings};
use crate::media::walk::{medium_at, mesh_of, target, transmittance, LaneMis, MAX_CROSSINGS};
use crate::media::{free_flight, phase, Coefficients, Flight};
use crate::sampler::PixelSampler;

/// [`super::trace_bdpt_samples`] for a scene with media: each sample's subpaths walked
/// through the media, its strategies joined through them.
#[allow(clippy::too_many_arguments)]
pub(super) fn trace_samples(
    ctx: &Context,
    films: &[Vec2],
    samplers: &mut [(PixelSampler, PixelSampler)],
    settings: &BdptSettings,
    scratch: &mut BdptScratch,
    out: &mut [PathRadiance],
    splat: &mut impl FnMut(usize, LightSplat),
) {
    let rs = ctx.rs;
    let n = films.len().min(samplers.len()).min(out.len());
    let max_depth = settings.path.max_depth.max(1) as usize;
    if scratch.paths.len() < 2 {
        scratch.paths.resize_with(2, Vec::new);
    }
    let unweighted = settings.only.is_some();
    for k in 0..n {
        let (cam_sampler, light_sampler) = &mut samplers[k];
        let (cams, lights) = scratch.paths.split_at_mut(1);
        let (cam, light) = (&mut cams[0], &mut lights[0]);
        let mut rays = 0;
        let walk = camera_start(ctx, films[k], max_depth + 1, cam);
        let camera_medium = rs.scene.media.camera.map(|m| m as u32);
        cam[0].medium = camera_medium;
        rays += walk_media(
            ctx,
            walk,
            camera_medium,
            cam_sampler,
            &settings.path,
            max_depth + 1,
            cam,
        );
        let walk = light_start(ctx, light_sampler, max_depth, light);
        if let Some(q0) = light.first() {
            // The medium around the light, found from the camera (as the light tracer does):
            // on the side the particle leaves, or where it leaves none, the camera's side.
            let towards =
                walk.map_or_else(|| q0.origin_off(ctx.camera.origin() - q0.p), |w| w.origin);
            let m = medium_at(rs, ctx.camera.origin(), towards, &mut rays).map(|m| m as u32);
            light[0].medium = m;
            rays += walk_media(
                ctx,
                walk,
                m,
                light_sampler,
                &settings.path,
                max_depth,
                light,
            );
        }
        super::mis::set_camera_ratios(cam);
        super::mis::set_light_ratios(light);
        scratch.pending.clear();
        let (mut joins, mut nees, mut splats) = (Vec::new(), Vec::new(), Vec::new());
        let mut radiance = prepare_all(
            ctx,
            (k, light, cam),
            false,
            settings,
            &mut scratch.pending,
            (&mut joins, &mut nees, &mut splats),
        );
        for p in &scratch.pending {
            // The shadow segment starts at the camera side's vertex, or at the light vertex
            // that the camera sees (t = 1).
            let from = if p.t == 1 {
                &light[p.s - 1]
            } else {
                &cam[p.t - 1]
            };
            let medium = medium_towards(ctx, from, p.ray.dir);
            rays += 1;
            let tr = transmittance(
                rs,
                medium,
                p.ray.origin,
                p.ray.dir,
                p.ray.tmax,
                None,
                cam_sampler,
                &mut rays,
            );
            if tr == Vec3::ZERO {
                continue;
            }
            let c = match finish(ctx, light, cam, p, unweighted) {
                Contribution::Pixel(v) => Contribution::Pixel(v * tr),
                Contribution::Splat(film, v) => Contribution::Splat(film, v * tr),
            };
            add(&mut radiance, p.s + p.t - 1, c, &mut |s| splat(k, s));
        }
        radiance.rays += rays;
        out[k] = radiance;
    }
}

/// The medium a ray from vertex `v` in direction `w` starts in: across a surface with an
/// interface, the medium on `w`'s side; otherwise the one its subpath reached it through.
fn medium_towards(ctx: &Context, v: &Vertex, w: Vec3) -> Option<usize> {
    let media = &ctx.rs.scene.media;
    if let Kind::Surface { ref s, .. } = v.kind {
        let mesh = ctx.rs.scene.instances[s.instance as usize].mesh;
        if let Some(f) = media.boundary(mesh).interface {
            return target(f, s.ng, w);
        }
    }
    v.medium.map(|m| m as usize)
}

/// Extends `path` (whose last vertex the walk leaves, in `medium`) through the scene's media
/// until it has `max_vertices` vertices, a ray escapes, the path is absorbed or Russian
/// roulette ends it: surfaces by the surface BDPT's [`step`], medium vertices by
/// [`medium_step`], null surfaces crossed. Returns rays traced.
fn walk_media(
    ctx: &Context,
    walk: Option<Walk>,
    mut medium: Option<u32>,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
    max_vertices: usize,
    path: &mut Vec<Vertex>,
) -> u32 {
    let Some(mut walk) = walk else { return 0 };
    let rs = ctx.rs;
    let media = &rs.scene.media;
    // The lane whose exponentials sample chromatic homogeneous media (tracking.rs).
    let mut lanes = LaneMis::new(sampler.next_1d());
    // Russian roulette at medium vertices of light subpaths compares the throughput with the
    // particle's start (power units), as the light tracer does.
    let start = walk.beta.max_element();
    let mut rays = 0;
    let mut crossings = 0;
    while path.len() < max_vertices {
        rays += 1;
        let hit = rs
            .accel
            .intersect(walk.origin, walk.dir, 0.0, f32::INFINITY);
        if let Some(m) = medium {
            let med = &media.media[m as usize];
            let c = Coefficients::of(med, None);
            let tmax = hit.map_or(f32::INFINITY, |h| h.t);
            let flight = free_flight(
                med,
                &c,
                walk.origin,
                walk.dir,
                tmax,
                lanes.lane,
                walk.beta,
                sampler,
            );
            lanes.apply(&mut walk.beta, &flight);
            if let Flight::Scatter { t, .. } = flight {
                let scene_vertex = MediumStep {
                    medium: m,
                    t,
                    start,
                    max_vertices,
                };
                if !medium_step(ctx, &mut walk, scene_vertex, sampler, settings, path) {
                    break;
                }
                crossings = 0;
                continue;
            }
            if walk.beta == Vec3::ZERO {
                break;
            }
        }
        let boundary = hit.map(|h| media.boundary(mesh_of(rs, &h)));
        if let (Some(h), Some(b)) = (hit, boundary.filter(|b| b.null)) {
            // An invisible boundary: no vertex, only a change of medium.
            crossings += 1;
            if crossings > MAX_CROSSINGS {
                break;
            }
            let s = rs.surface(&h, walk.origin, walk.dir);
            if let Some(f) = b.interface {
                medium = target(f, s.ng, walk.dir).map(|m| m as u32);
            }
            walk.origin = rs.offset(&s, walk.dir);
            continue;
        }
        let before = path.len();
        let goes_on = step(ctx, &mut walk, hit, sampler, settings, max_vertices, path);
        if path.len() > before {
            if let Some(v) = path.last_mut() {
                v.medium = medium;
            }
        }
        if !goes_on {
            break;
        }
        if let (Some(f), Some(v)) = (boundary.and_then(|b| b.interface), path.last()) {
            medium = target(f, v.ng, walk.dir).map(|m| m as u32);
        }
        crossings = 0;
    }
    rays
}

/// Where a free flight scattered: in `medium` at ray parameter `t`; `start` is the subpath's
/// starting throughput (Russian roulette's scale for light subpaths), `max_vertices` its
/// vertex limit.
struct MediumStep {
    medium: u32,
    t: f32,
    start: f32,
    max_vertices: usize,
}

/// Records the medium vertex of a real scattering and samples the phase function for the
/// direction that leaves it (its weight is 1: phase functions are sampled exactly). Returns
/// whether the walk goes on.
fn medium_step(
    ctx: &Context,
    walk: &mut Walk,
    at: MediumStep,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
    path: &mut Vec<Vertex>,
) -> bool {
    let phase_fn = ctx.rs.scene.media.media[at.medium as usize].phase;
    let prev = path.len() - 1;
    let p = walk.origin + walk.dir * at.t;
    let d = p - path[prev].p;
    let d2 = d.length_squared();
    let w_in = if d2 == 0.0 { Vec3::ZERO } else { d / d2.sqrt() };
    first_segment_window(ctx, &path[prev], d2, &mut walk.beta);
    let mut v = Vertex::new(Kind::Medium { phase: phase_fn }, p, Vec3::ZERO, walk.beta);
    v.medium = Some(at.medium);
    v.w_prev = -w_in;
    v.d2_prev = d2;
    v.pdf_fwd = match path[prev].kind {
        _ if path[prev].delta => 1.0,
        // Parallel rays: the disk's density, with no cosine to project it by.
        Kind::Light {
            directional: true, ..
        } => walk.pdf_dir,
        _ => area_density_along(walk.pdf_dir, &v, w_in, d2),
    };
    let camera_side = walk.mode == TransportMode::Radiance;
    if camera_side {
        v.u_light = (sampler.next_1d(), sampler.next_2d());
    }
    let u_dir = sampler.next_2d();
    let u_rr = sampler.next_1d();
    path.push(v);
    if path.len() >= at.max_vertices {
        return false;
    }
    let (wi, pdf) = phase::sample(phase_fn, walk.dir, u_dir);
    if pdf.is_nan() || pdf <= 0.0 {
        return false;
    }
    // The density of scattering back towards the previous vertex for a walk arriving along
    // the new direction (what [`Vertex::pdf_back`] computes for a connection).
    let back = phase::eval(phase_fn, -wi, -w_in);
    path[prev].pdf_rev = area_density_along(back, &path[prev], -w_in, d2);
    walk.pdf_dir = pdf;
    walk.origin = p;
    walk.dir = wi;
    if (path.len() - 1) as u32 >= settings.rr_depth {
        // Without the surfaces' 0.95 cap (as in the path tracer): an albedo-1 medium keeps
        // its paths instead of growing a heavy tail of survivors.
        let q = if camera_side {
            (walk.beta.max_element() * walk.eta_scale).min(1.0)
        } else if at.start > 0.0 {
            (walk.beta.max_element() / at.start).min(1.0)
        } else {
            0.0
        };
        if u_rr >= q {
            return false;
        }
        walk.beta /= q;
    }
    walk.beta != Vec3::ZERO && walk.beta.is_finite()
}
