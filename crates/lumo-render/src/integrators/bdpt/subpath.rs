//! Camera and light subpaths: a start (the pinhole, or a particle leaving a light) and a
//! random walk through the scene with the path tracer's BSDF sampling and Russian roulette,
//! recording each vertex with its forward and reverse densities.

use glam::{Vec2, Vec3};

use super::diffuse_walk::{diffuse_steps, Walks};
use super::lanes::MIN_VECTOR_LANES;
use super::vertex::{
    area_density_along, bsdf_pdf, lambert_sample, light_origin_density, surface_local, Context,
    Kind, Vertex,
};
use crate::accel::packet::{RayPacket, LANES};
use crate::accel::Hit;
use crate::bsdf::TransportMode;
use crate::geometry::{offset_point, survival_probability};
use crate::integrators::light::{particle_direction, scatter_particle};
use crate::integrators::path::PathSettings;
use crate::sampler::PixelSampler;

/// Starts the camera subpath through film position `film` (pixels) in `path` (cleared
/// first): pushes the pinhole and returns the walk that leaves it (`None`: no scene vertex
/// can follow). [`random_walk`] or [`random_walks`] adds at most `max_vertices - 1` scene
/// vertices.
pub(super) fn camera_start(
    ctx: &Context,
    film: Vec2,
    max_vertices: usize,
    path: &mut Vec<Vertex>,
) -> Option<Walk> {
    path.clear();
    let origin = ctx.camera.origin();
    let mut camera = Vertex::new(Kind::Camera, origin, Vec3::ZERO, Vec3::ONE);
    camera.pdf_fwd = 1.0;
    path.push(camera);
    let dir = ctx.camera.direction(film);
    let pdf_dir = ctx.camera.direction_pdf(dir);
    if pdf_dir <= 0.0 || max_vertices < 2 {
        return None;
    }
    Some(Walk {
        origin,
        dir,
        beta: Vec3::ONE,
        pdf_dir,
        mode: TransportMode::Radiance,
        eta_scale: 1.0,
    })
}

/// Starts the light subpath of the particle the sampler's next numbers choose in `path`
/// (cleared first): pushes its light vertex and returns the walk that leaves it (`None`: no
/// scene vertex can follow). The walk adds at most `max_vertices - 1` scene vertices.
pub(super) fn light_start(
    ctx: &Context,
    sampler: &mut PixelSampler,
    max_vertices: usize,
    path: &mut Vec<Vertex>,
) -> Option<Walk> {
    path.clear();
    let u_choice = sampler.next_1d();
    let u_pos = sampler.next_2d();
    let u_dir = sampler.next_2d();
    if max_vertices == 0 {
        return None;
    }
    let e = ctx.rs.lights.sample_emission(u_choice, u_pos, u_dir)?;
    let normal = e.normal.unwrap_or(Vec3::ZERO);
    let kind = Kind::Light {
        light: e.light,
        delta_position: e.pdf.delta_position,
        directional: e.pdf.delta_direction,
    };
    let origin_pdf = light_origin_density(&ctx.rs.lights, &e.pdf);
    let mut light = Vertex::new(kind, e.p, normal, Vec3::splat(1.0 / origin_pdf));
    light.le = e.radiance;
    light.pdf_fwd = origin_pdf;
    light.set_offset(ctx.rs.ray_epsilon);
    path.push(light);
    if max_vertices < 2 || !e.weight.is_finite() || e.weight == Vec3::ZERO {
        return None;
    }
    let origin = match e.normal {
        Some(n) => offset_point(e.p.into(), n.into(), e.dir.into(), ctx.rs.ray_epsilon).into(),
        None => e.p,
    };
    let pdf_dir = if e.pdf.delta_direction {
        let r = ctx.rs.lights.scene_radius();
        1.0 / (std::f32::consts::PI * r * r)
    } else {
        e.pdf.solid_angle
    };
    Some(Walk {
        origin,
        dir: e.dir,
        beta: e.weight,
        pdf_dir,
        mode: TransportMode::Importance,
        eta_scale: 1.0,
    })
}

/// A random walk between two vertices: the ray it traces next and what it carries.
#[derive(Clone, Copy, Debug)]
pub(super) struct Walk {
    /// Origin of the next ray (offset off the vertex it leaves).
    pub origin: Vec3,
    /// Its unit direction.
    pub dir: Vec3,
    /// Throughput of the subpath so far.
    pub beta: Vec3,
    /// Density of `dir` at the last vertex of the path (solid angle; per unit area of the
    /// disk for a directional light).
    pub pdf_dir: f32,
    /// Radiance for camera subpaths, importance for light subpaths.
    pub mode: TransportMode,
    /// Product of the squared relative indices crossed (Russian roulette's correction).
    pub eta_scale: f32,
}

/// The camera subpath through film position `film` traced alone (the tests' form of
/// [`camera_start`] and [`random_walks`]). Returns rays traced.
#[cfg(test)]
pub(super) fn camera_subpath(
    ctx: &Context,
    film: Vec2,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
    max_vertices: usize,
    path: &mut Vec<Vertex>,
) -> u32 {
    let walk = camera_start(ctx, film, max_vertices, path);
    random_walk(ctx, walk, sampler, settings, max_vertices, path)
}

/// Extends `path` (whose last vertex the walk leaves) until it has `max_vertices` vertices,
/// a ray escapes, a BSDF absorbs or Russian roulette ends it, one ray at a time. Returns
/// rays traced.
#[cfg(test)]
fn random_walk(
    ctx: &Context,
    walk: Option<Walk>,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
    max_vertices: usize,
    path: &mut Vec<Vertex>,
) -> u32 {
    let Some(mut walk) = walk else { return 0 };
    let mut rays = 0;
    while path.len() < max_vertices {
        rays += 1;
        let hit = ctx
            .rs
            .accel
            .intersect(walk.origin, walk.dir, 0.0, f32::INFINITY);
        if !step(ctx, &mut walk, hit, sampler, settings, max_vertices, path) {
            break;
        }
    }
    rays
}

/// [`random_walk`] for several subpaths at once, walk `k` with `samplers[k]` into `paths[k]`
/// up to `max_vertices[k]` vertices: each step traces a packet of the next (at most
/// [`LANES`]) live walks, taken in turn, whose hits are bit for bit the single rays'
/// ([`crate::accel::Accel::intersect_packet`]). Each walk's steps stay in its own order and
/// walks share nothing, so every subpath is exactly the one [`random_walk`] makes. Returns
/// rays traced.
pub(super) fn random_walks(
    ctx: &Context,
    walks: &mut [Option<Walk>],
    samplers: &mut [PixelSampler],
    settings: &PathSettings,
    max_vertices: &[usize],
    paths: &mut [Vec<Vertex>],
) -> u32 {
    let count = walks.len();
    let mut rays = 0;
    let mut hits: [Option<Hit>; LANES] = [None; LANES];
    let mut lanes = [0usize; LANES];
    // The walk the next packet starts its search at (`count` wraps to 0): after the last
    // one traced, so that every live walk gets a step before any gets two.
    let mut next = 0;
    loop {
        let mut packet = RayPacket::default();
        let mut n = 0;
        // (Wrapped by hand: `%` by a count unknown at compile time is a division.)
        let mut j = next;
        for _ in 0..count {
            if j == count {
                j = 0;
            }
            let k = j;
            j += 1;
            if let Some(w) = &walks[k] {
                if paths[k].len() < max_vertices[k] {
                    packet.set(n, w.origin, w.dir, 0.0, f32::INFINITY);
                    lanes[n] = k;
                    n += 1;
                    if n == LANES {
                        break;
                    }
                }
            }
        }
        if n == 0 {
            return rays;
        }
        next = lanes[n - 1] + 1;
        rays += n as u32;
        ctx.rs.accel.intersect_packet(&packet, &mut hits);
        // Hits on simple diffuse surfaces step together in vector lanes, the others one by
        // one (walks share nothing, so the order of their steps changes nothing); with too
        // few such hits for the lanes to pay, all step one by one (the same bits either way).
        let mut simple = [(0usize, Hit::default()); LANES];
        let mut is_simple = [false; LANES];
        let mut m = 0;
        for (lane, (&k, &hit)) in lanes[..n].iter().zip(&hits[..n]).enumerate() {
            // A first step from a light with a range takes the scalar step, which applies the
            // range's window (the lanes do not).
            let ranged = paths[k].len() == 1 && ranged_light(ctx, &paths[k][0]);
            if let Some(h) = hit.filter(|h| !ranged && ctx.rs.is_simple_diffuse(h.instance)) {
                simple[m] = (k, h);
                is_simple[lane] = true;
                m += 1;
            }
        }
        let vector = m >= MIN_VECTOR_LANES;
        for (lane, (&k, &hit)) in lanes[..n].iter().zip(&hits[..n]).enumerate() {
            if vector && is_simple[lane] {
                continue;
            }
            let Some(walk) = walks[k].as_mut() else {
                continue;
            };
            if !step(
                ctx,
                walk,
                hit,
                &mut samplers[k],
                settings,
                max_vertices[k],
                &mut paths[k],
            ) {
                walks[k] = None;
            }
        }
        if vector {
            let mut w = Walks {
                walks,
                samplers,
                max_vertices,
                paths,
            };
            diffuse_steps(ctx, settings, &simple[..m], &mut w);
        }
    }
}

/// One step of a walk whose ray found `hit`: records the vertex and samples the direction
/// that leaves it. Returns whether the walk goes on.
pub(super) fn step(
    ctx: &Context,
    walk: &mut Walk,
    hit: Option<Hit>,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
    max_vertices: usize,
    path: &mut Vec<Vertex>,
) -> bool {
    let rs = ctx.rs;
    let Walk {
        origin,
        dir,
        mut beta,
        pdf_dir,
        mode,
        mut eta_scale,
    } = *walk;
    let prev = path.len() - 1;
    let Some(hit) = hit else {
        if mode == TransportMode::Radiance {
            let mut v = Vertex::new(Kind::Environment { dir }, origin, Vec3::ZERO, beta);
            v.le = rs.lights.environment(dir);
            v.pdf_fwd = pdf_dir;
            path.push(v);
        }
        return false;
    };
    let s = rs.surface(&hit, origin, dir);
    let bsdf = rs.bsdf(&s);
    let wo_local = s.frame.to_local(-dir);
    let black = wo_local.z <= 0.0 && rs.one_sided(s.material);
    // The segment from the previous vertex, computed once: its reverse (the same bits as
    // `towards` the other way: negation is exact) serves this vertex's reverse density and
    // the weights.
    let (w_in, d2) = {
        let d = s.p - path[prev].p;
        let d2 = d.length_squared();
        if d2 == 0.0 {
            (Vec3::ZERO, 0.0)
        } else {
            (d / d2.sqrt(), d2)
        }
    };
    first_segment_window(ctx, &path[prev], d2, &mut beta);
    let lambert = bsdf.lambert();
    let kind = Kind::Surface {
        s,
        bsdf,
        wo_local,
        cos_ng_wo: s.ng.dot(-dir).abs(),
        wp_local: surface_local(&s, lambert.is_some(), -w_in),
        lambert,
        black,
    };
    let mut v = Vertex::new(kind, s.p, s.ng, beta);
    v.set_offset(rs.ray_epsilon);
    v.w_prev = -w_in;
    v.d2_prev = d2;
    v.pdf_fwd = match path[prev].kind {
        _ if path[prev].delta => 1.0,
        // Parallel rays: the disk's density projected onto the surface.
        Kind::Light {
            directional: true, ..
        } => pdf_dir * s.ng.dot(dir).abs(),
        _ => area_density_along(pdf_dir, &v, w_in, d2),
    };
    if mode == TransportMode::Radiance {
        v.le = rs.emission(&s, dir);
        v.u_light = (sampler.next_1d(), sampler.next_2d());
    }
    let u_lobe = sampler.next_1d();
    let u_dir = sampler.next_2d();
    let u_rr = sampler.next_1d();
    path.push(v);
    let cur = path.len() - 1;
    if path.len() >= max_vertices || black {
        return false;
    }
    let (new_dir, bs) = if mode == TransportMode::Importance {
        // Veach's adjoint shading-normal correction: the arrival half here, the departure
        // half in the light tracer's scatter.
        let cos_ng_l = s.ng.dot(dir).abs();
        if cos_ng_l == 0.0 {
            return false;
        }
        // A Lambertian BSDF draws the same sample in both modes (no refraction to undo).
        let scattered = match lambert {
            Some(albedo) => lambert_sample(albedo, wo_local, u_dir)
                .and_then(|bs| particle_direction(bs, &s, -dir, wo_local)),
            None => scatter_particle(&bsdf, &s, -dir, wo_local, u_lobe, u_dir),
        };
        let Some((new_dir, bs, weight)) = scattered else {
            return false;
        };
        beta *= weight * (s.frame.n.dot(dir).abs() / cos_ng_l);
        (new_dir, bs)
    } else {
        let bs = match lambert {
            Some(albedo) => lambert_sample(albedo, wo_local, u_dir),
            None => bsdf.sample(wo_local, u_lobe, u_dir),
        };
        let Some(bs) = bs else {
            return false;
        };
        let new_dir = s.frame.to_world(bs.wi).normalize();
        // Shading normals can send a sample through the geometric surface; drop it.
        let reflect = bs.wi.z * wo_local.z > 0.0;
        if reflect != (new_dir.dot(s.ng) * (-dir).dot(s.ng) > 0.0) {
            return false;
        }
        if bs.eta != 1.0 {
            eta_scale *= bs.eta * bs.eta;
        }
        beta *= bs.weight;
        (new_dir, bs)
    };
    path[cur].delta = bs.delta;
    // The reverse density of the vertex before: sampled from here towards it, given the
    // new direction as the incoming one.
    path[prev].pdf_rev = if bs.delta {
        1.0
    } else {
        let pdf = bsdf_pdf(&bsdf, lambert, bs.wi, wo_local);
        area_density_along(pdf, &path[prev], -w_in, d2)
    };
    walk.pdf_dir = if bs.delta { 1.0 } else { bs.pdf };
    walk.origin = rs.offset(&s, new_dir);
    walk.dir = new_dir;
    if (path.len() - 1) as u32 >= settings.rr_depth {
        let q = survival_probability(beta.max_element(), eta_scale);
        if u_rr >= q {
            return false;
        }
        beta /= q;
    }
    if beta == Vec3::ZERO || !beta.is_finite() {
        return false;
    }
    walk.beta = beta;
    walk.eta_scale = eta_scale;
    true
}

/// Whether `v` is the vertex of a light with a range (glTF's `range`).
#[inline]
fn ranged_light(ctx: &Context, v: &Vertex) -> bool {
    matches!(v.kind, Kind::Light { light, .. } if ctx.rs.lights.range(light).is_some())
}

/// Where a segment of squared length `d2` leaves `prev`, a light with a range (the first
/// segment of a light subpath), multiplies the throughput `beta` by the range's window of its
/// length; every other segment leaves `beta` alone.
#[inline(always)]
pub(super) fn first_segment_window(ctx: &Context, prev: &Vertex, d2: f32, beta: &mut Vec3) {
    if let Kind::Light { light, .. } = prev.kind {
        if let Some(r) = ctx.rs.lights.range(light) {
            *beta *= lumo_scene::range_window(d2.sqrt(), r);
        }
    }
}
