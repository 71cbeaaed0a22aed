//! The strategies of one bidirectional sample: for a camera subpath of `t` and a light
//! subpath of `s` vertices, the path they form when joined — the camera path hitting a
//! light (s = 0), next-event estimation from the camera path (s = 1), a light vertex seen by
//! the camera (t = 1, a splat on the film) and a shadow ray between two scene vertices.

use glam::{Vec2, Vec3};

use super::mis::{weight, Connection};
use super::vertex::{light_vertex, Context, Kind, Vertex};
use crate::geometry::{offset_point, shadow_segment};

/// What one strategy adds: radiance for the camera sample's pixel, or a splat elsewhere on
/// the film (t = 1).
pub(super) enum Contribution {
    /// Radiance for the camera sample.
    Pixel(Vec3),
    /// Radiance (in the light tracer's units: summed per pixel and divided by the number of
    /// light subpaths) landing at a film position in pixels.
    Splat(Vec2, Vec3),
}

/// The unoccluded segment test between `a` (already offset) and the point `b`.
fn visible(ctx: &Context, a: Vec3, b: Vec3, w: Vec3) -> bool {
    let (dir, tmax) = shadow_segment(a.into(), b.into(), w.into(), ctx.rs.ray_epsilon);
    !ctx.rs.accel.occluded(a, dir.into(), 0.0, tmax)
}

/// A ray origin just off vertex `v` on the side of `w`.
fn origin_off(ctx: &Context, v: &Vertex, w: Vec3) -> Vec3 {
    match v.kind {
        Kind::Surface { s, .. } => ctx.rs.offset(&s, w),
        _ if v.ng != Vec3::ZERO => {
            offset_point(v.p.into(), v.ng.into(), w.into(), ctx.rs.ray_epsilon).into()
        }
        _ => v.p,
    }
}

/// Strategy (s, t) of `light[..s]` and `camera[..t]`, weighted by MIS unless `unweighted`.
/// Returns the contribution (if any) and the rays traced.
pub(super) fn connect(
    ctx: &Context,
    light: &[Vertex],
    camera: &[Vertex],
    (s, t): (usize, usize),
    unweighted: bool,
) -> (Option<Contribution>, u32) {
    // (s = 1 with t ≥ 2 samples its own light vertex: the light subpath may be empty.)
    let light = &light[..s.min(light.len())];
    let camera = &camera[..t];
    let mis = |light: &[Vertex], camera: &[Vertex]| {
        if unweighted {
            1.0
        } else {
            weight(ctx, &Connection { light, camera })
        }
    };
    let finite = |v: Vec3| v.is_finite() && v != Vec3::ZERO;
    if s == 0 {
        let pt = &camera[t - 1];
        let value = pt.beta * pt.le;
        if !finite(value) {
            return (None, 0);
        }
        let value = value * mis(light, camera);
        return (Some(Contribution::Pixel(value)), 0);
    }
    if t == 1 {
        let qs = &light[s - 1];
        if !qs.is_connectible() {
            return (None, 0);
        }
        let Some((film, cos_cam)) = ctx.camera.project_point(qs.p) else {
            return (None, 0);
        };
        let to_cam = ctx.camera.origin() - qs.p;
        let dist2 = to_cam.length_squared();
        let wc = to_cam / dist2.sqrt();
        let value = match qs.kind {
            Kind::Light { .. } if qs.ng.dot(wc) > 0.0 => qs.beta * qs.le * qs.ng.dot(wc),
            Kind::Surface { .. } => qs.beta * qs.scatter_towards(wc, true),
            _ => Vec3::ZERO,
        };
        // G·We of the pinhole: the surface cosine is in `value`.
        let value = value * ctx.camera.pixel_importance() / (dist2 * cos_cam.powi(3));
        if !finite(value) {
            return (None, 0);
        }
        let o = origin_off(ctx, qs, wc);
        if !visible(ctx, o, ctx.camera.origin(), wc) {
            return (None, 1);
        }
        let value = value * mis(light, camera);
        return (Some(Contribution::Splat(film, value)), 1);
    }
    let pt = &camera[t - 1];
    if !pt.is_connectible() {
        return (None, 0);
    }
    if s == 1 {
        // Next-event estimation: the light point comes from the lights' own sampler.
        let (u_choice, u_point) = pt.u_light;
        let Some(ls) = ctx.rs.lights.sample(pt.p, u_choice, u_point) else {
            return (None, 0);
        };
        let f = pt.scatter_towards(ls.wi, false);
        let value = pt.beta * f * ls.weight;
        if !finite(value) {
            return (None, 0);
        }
        let o = origin_off(ctx, pt, ls.wi);
        let unoccluded = if ls.distance.is_finite() {
            visible(ctx, o, ls.point, ls.wi)
        } else {
            !ctx.rs.accel.occluded(o, ls.wi, 0.0, f32::INFINITY)
        };
        if !unoccluded {
            return (None, 1);
        }
        let environment = ctx.rs.lights.is_environment(ls.light).then_some(ls.wi);
        // A directional light's vertex stands on its disk outside the scene, in line with
        // the shading point (the densities read the direction from the positions).
        let point = if ls.distance.is_finite() {
            ls.point
        } else {
            pt.p + ls.wi * (4.0 * ctx.rs.lights.scene_radius())
        };
        let qs = light_vertex(
            &ctx.rs.lights,
            ls.light,
            point,
            ls.normal,
            -ls.wi,
            environment,
        );
        let value = value * mis(std::slice::from_ref(&qs), camera);
        return (Some(Contribution::Pixel(value)), 1);
    }
    let qs = &light[s - 1];
    if !qs.is_connectible() {
        return (None, 0);
    }
    let (Kind::Surface { .. }, Kind::Surface { .. }) = (qs.kind, pt.kind) else {
        return (None, 0);
    };
    let d = qs.p - pt.p;
    let dist2 = d.length_squared();
    let w = d / dist2.sqrt();
    let value =
        pt.beta * pt.scatter_towards(w, false) * qs.scatter_towards(-w, true) * qs.beta / dist2;
    if !finite(value) {
        return (None, 0);
    }
    let (a, b) = (origin_off(ctx, pt, w), origin_off(ctx, qs, -w));
    if !visible(ctx, a, b, w) {
        return (None, 1);
    }
    let value = value * mis(light, camera);
    (Some(Contribution::Pixel(value)), 1)
}
