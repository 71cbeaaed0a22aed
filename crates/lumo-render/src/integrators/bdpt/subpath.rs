//! Camera and light subpaths: a start (the pinhole, or a particle leaving a light) and a
//! random walk through the scene with the path tracer's BSDF sampling and Russian roulette,
//! recording each vertex with its forward and reverse densities.

use glam::{Vec2, Vec3};

use super::vertex::{light_origin_density, Context, Kind, Vertex};
use crate::bsdf::TransportMode;
use crate::geometry::{offset_point, survival_probability};
use crate::integrators::light::scatter_particle;
use crate::integrators::path::PathSettings;
use crate::sampler::PixelSampler;

/// Appends the camera subpath through film position `film` (pixels) to `path` (cleared
/// first): the pinhole, then at most `max_vertices - 1` scene vertices. Returns rays traced.
pub(super) fn camera_subpath(
    ctx: &Context,
    film: Vec2,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
    max_vertices: usize,
    path: &mut Vec<Vertex>,
) -> u32 {
    path.clear();
    let origin = ctx.camera.origin();
    let mut camera = Vertex::new(Kind::Camera, origin, Vec3::ZERO, Vec3::ONE);
    camera.pdf_fwd = 1.0;
    path.push(camera);
    let dir = ctx.camera.direction(film);
    let pdf_dir = ctx.camera.direction_pdf(dir);
    if pdf_dir <= 0.0 || max_vertices < 2 {
        return 0;
    }
    let walk = Walk {
        origin,
        dir,
        beta: Vec3::ONE,
        pdf_dir,
        mode: TransportMode::Radiance,
    };
    random_walk(ctx, walk, sampler, settings, max_vertices, path)
}

/// Appends the light subpath of the particle the sampler's next numbers choose to `path`
/// (cleared first): its light vertex, then at most `max_vertices - 1` scene vertices.
/// Returns rays traced.
pub(super) fn light_subpath(
    ctx: &Context,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
    max_vertices: usize,
    path: &mut Vec<Vertex>,
) -> u32 {
    path.clear();
    let u_choice = sampler.next_1d();
    let u_pos = sampler.next_2d();
    let u_dir = sampler.next_2d();
    if max_vertices == 0 {
        return 0;
    }
    let Some(e) = ctx.rs.lights.sample_emission(u_choice, u_pos, u_dir) else {
        return 0;
    };
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
    path.push(light);
    if max_vertices < 2 || !e.weight.is_finite() || e.weight == Vec3::ZERO {
        return 0;
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
    let walk = Walk {
        origin,
        dir: e.dir,
        beta: e.weight,
        pdf_dir,
        mode: TransportMode::Importance,
    };
    random_walk(ctx, walk, sampler, settings, max_vertices, path)
}

/// Where a random walk starts.
struct Walk {
    origin: Vec3,
    dir: Vec3,
    beta: Vec3,
    /// Density of `dir` at the last vertex of the path (solid angle; per unit area of the
    /// disk for a directional light).
    pdf_dir: f32,
    mode: TransportMode,
}

/// Extends `path` (whose last vertex the walk leaves) until it has `max_vertices` vertices,
/// a ray escapes, a BSDF absorbs or Russian roulette ends it. Returns rays traced.
fn random_walk(
    ctx: &Context,
    walk: Walk,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
    max_vertices: usize,
    path: &mut Vec<Vertex>,
) -> u32 {
    let rs = ctx.rs;
    let Walk {
        mut origin,
        mut dir,
        mut beta,
        mut pdf_dir,
        mode,
    } = walk;
    let mut rays = 0;
    let mut eta_scale = 1.0f32;
    while path.len() < max_vertices {
        rays += 1;
        let hit = rs.accel.intersect(origin, dir, 0.0, f32::INFINITY);
        let prev = path.len() - 1;
        let Some(hit) = hit else {
            if mode == TransportMode::Radiance {
                let mut v = Vertex::new(Kind::Environment { dir }, origin, Vec3::ZERO, beta);
                v.le = rs.lights.environment(dir);
                v.pdf_fwd = pdf_dir;
                path.push(v);
            }
            break;
        };
        let s = rs.surface(&hit, origin, dir);
        let bsdf = rs.bsdf(&s);
        let wo_local = s.frame.to_local(-dir);
        let black = wo_local.z <= 0.0 && rs.one_sided(s.material);
        let kind = Kind::Surface {
            s,
            bsdf,
            wo: -dir,
            black,
        };
        let mut v = Vertex::new(kind, s.p, s.ng, beta);
        v.pdf_fwd = match path[prev].kind {
            _ if path[prev].delta => 1.0,
            // Parallel rays: the disk's density projected onto the surface.
            Kind::Light {
                directional: true, ..
            } => pdf_dir * s.ng.dot(dir).abs(),
            _ => path[prev].area_density(pdf_dir, &v),
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
            break;
        }
        let (new_dir, bs) = if mode == TransportMode::Importance {
            // Veach's adjoint shading-normal correction: the arrival half here, the departure
            // half in the light tracer's scatter.
            let cos_ng_l = s.ng.dot(dir).abs();
            if cos_ng_l == 0.0 {
                break;
            }
            let Some((new_dir, bs, weight)) =
                scatter_particle(&bsdf, &s, -dir, wo_local, u_lobe, u_dir)
            else {
                break;
            };
            beta *= weight * (s.frame.n.dot(dir).abs() / cos_ng_l);
            (new_dir, bs)
        } else {
            let Some(bs) = bsdf.sample(wo_local, u_lobe, u_dir) else {
                break;
            };
            let new_dir = s.frame.to_world(bs.wi).normalize();
            // Shading normals can send a sample through the geometric surface; drop it.
            let reflect = bs.wi.z * wo_local.z > 0.0;
            if reflect != (new_dir.dot(s.ng) * (-dir).dot(s.ng) > 0.0) {
                break;
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
            let pdf = bsdf.pdf(bs.wi, wo_local);
            path[cur].area_density(pdf, &path[prev])
        };
        pdf_dir = if bs.delta { 1.0 } else { bs.pdf };
        origin = rs.offset(&s, new_dir);
        dir = new_dir;
        if (path.len() - 1) as u32 >= settings.rr_depth {
            let q = survival_probability(beta.max_element(), eta_scale);
            if u_rr >= q {
                break;
            }
            beta /= q;
        }
        if beta == Vec3::ZERO || !beta.is_finite() {
            break;
        }
    }
    rays
}
