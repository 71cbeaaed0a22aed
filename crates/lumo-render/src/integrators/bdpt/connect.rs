//! The strategies of one bidirectional sample: for a camera subpath of `t` and a light
//! subpath of `s` vertices, the path they form when joined — the camera path hitting a
//! light (s = 0), next-event estimation from the camera path (s = 1), a light vertex seen by
//! the camera (t = 1, a splat on the film) and a shadow ray between two scene vertices.

use glam::{Vec2, Vec3};

use super::mis::{weight, Connection, Segment};
use super::vertex::{light_vertex, Context, Kind, Vertex};
use crate::geometry::shadow_segment;

/// What one strategy adds: radiance for the camera sample's pixel, or a splat elsewhere on
/// the film (t = 1).
#[derive(Clone, Copy, Debug)]
pub(super) enum Contribution {
    /// Radiance for the camera sample.
    Pixel(Vec3),
    /// Radiance (in the light tracer's units: summed per pixel and divided by the number of
    /// light subpaths) landing at a film position in pixels.
    Splat(Vec2, Vec3),
}

/// A shadow ray: origin (already offset), unit direction, largest parameter (negative: a
/// degenerate segment, which counts as unoccluded like [`shadow_segment`]'s callers do).
#[derive(Clone, Copy, Debug)]
pub(super) struct ShadowRay {
    /// Origin, offset off the surface.
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
    /// Largest accepted ray parameter.
    pub tmax: f32,
}

/// The segment from `a` (already offset) to the point `b`.
#[inline]
fn segment(ctx: &Context, a: Vec3, b: Vec3, w: Vec3) -> ShadowRay {
    let (dir, tmax) = shadow_segment(a.into(), b.into(), w.into(), ctx.rs.ray_epsilon);
    ShadowRay {
        origin: a,
        dir: dir.into(),
        tmax,
    }
}

/// A strategy whose unweighted value is known and whose shadow ray is still to be traced:
/// the caller traces the shadow rays of a sample together (one packet) and then weighs the
/// visible ones ([`finish`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct Pending {
    /// The unweighted contribution.
    pub contribution: Contribution,
    /// The segment that must be unoccluded.
    pub ray: ShadowRay,
    /// The strategy.
    pub s: usize,
    /// The strategy.
    pub t: usize,
    /// For `s = 1`, `t ≥ 2`: the light point next-event estimation chose (its vertex is
    /// built only if the shadow ray is unoccluded).
    pub nee: Option<NeePoint>,
    /// For `s, t ≥ 2`: the connection's geometry, for the weight.
    pub segment: Option<Segment>,
    /// The weight, where a lane loop computed it with the value (`nee` and `segment`, which
    /// only the weight reads, are then left out).
    pub weight: Option<f32>,
}

impl Pending {
    /// The entry of a strategy a lane loop computed whole: its value, shadow ray and weight
    /// (nothing that only the scalar weight reads).
    #[inline(always)]
    pub fn weighed(
        contribution: Contribution,
        ray: ShadowRay,
        (s, t): (usize, usize),
        weight: f32,
    ) -> Self {
        Pending {
            contribution,
            ray,
            s,
            t,
            nee: None,
            segment: None,
            weight: Some(weight),
        }
    }

    /// An entry that holds a strategy's place in the list until a lane loop fills it (`s = 0`
    /// marks one left with nothing to add, which no other pending strategy has: s = 0 needs
    /// no shadow ray).
    pub fn placeholder() -> Self {
        Pending {
            contribution: Contribution::Pixel(Vec3::ZERO),
            ray: ShadowRay {
                origin: Vec3::ZERO,
                dir: Vec3::ZERO,
                tmax: -1.0,
            },
            s: 0,
            t: 0,
            nee: None,
            segment: None,
            weight: None,
        }
    }
}

/// The light point of next-event estimation, as [`light_vertex`] takes it.
#[derive(Clone, Copy, Debug)]
pub(super) struct NeePoint {
    /// The light.
    pub light: u32,
    /// The point on it (on its disk for a directional light).
    pub point: Vec3,
    /// Its unit normal there (zero for lights without one).
    pub normal: Vec3,
    /// The unit direction from the point towards the shading point.
    pub towards: Vec3,
    /// For the environment: the direction towards it.
    pub environment: Option<Vec3>,
}

/// What [`prepare`] found for one strategy.
pub(super) enum Prepared {
    /// Nothing to add.
    Nothing,
    /// A weighted contribution that needs no shadow ray (s = 0).
    Done(Contribution),
    /// A contribution waiting for its shadow ray.
    Pending(Pending),
}

/// Strategy (s, t) of `light[..s]` and `camera[..t]` up to its shadow ray: the unweighted
/// value and the segment to test, or (s = 0) the value weighted by MIS unless `unweighted`.
#[inline(always)]
pub(super) fn prepare(
    ctx: &Context,
    light: &[Vertex],
    camera: &[Vertex],
    (s, t): (usize, usize),
    unweighted: bool,
) -> Prepared {
    // (s = 1 with t ≥ 2 samples its own light vertex: the light subpath may be empty.)
    let light = &light[..s.min(light.len())];
    let camera = &camera[..t];
    let finite = |v: Vec3| v.is_finite() && v != Vec3::ZERO;
    let pending = |contribution, ray, nee, segment| {
        Prepared::Pending(Pending {
            contribution,
            ray,
            s,
            t,
            nee,
            segment,
            weight: None,
        })
    };
    if s == 0 {
        let pt = &camera[t - 1];
        let value = pt.beta * pt.le;
        if !finite(value) {
            return Prepared::Nothing;
        }
        let w = if unweighted {
            1.0
        } else {
            weight(
                ctx,
                &Connection {
                    light,
                    camera,
                    segment: None,
                },
            )
        };
        return Prepared::Done(Contribution::Pixel(value * w));
    }
    if t == 1 {
        let qs = &light[s - 1];
        if !qs.is_connectible() {
            return Prepared::Nothing;
        }
        let Some((film, cos_cam)) = ctx.camera.project_point(qs.p) else {
            return Prepared::Nothing;
        };
        let to_cam = ctx.camera.origin() - qs.p;
        let dist2 = to_cam.length_squared();
        let wc = to_cam / dist2.sqrt();
        let value = match qs.kind {
            Kind::Light { .. } if qs.ng.dot(wc) > 0.0 => qs.beta * qs.le * qs.ng.dot(wc),
            Kind::Surface { .. } | Kind::Medium { .. } => qs.beta * qs.scatter_towards(wc, true),
            _ => Vec3::ZERO,
        };
        // G·We of the pinhole: the surface cosine is in `value`.
        let value = value * ctx.camera.pixel_importance() / (dist2 * cos_cam.powi(3));
        if !finite(value) {
            return Prepared::Nothing;
        }
        let o = qs.origin_off(wc);
        let ray = segment(ctx, o, ctx.camera.origin(), wc);
        return pending(Contribution::Splat(film, value), ray, None, None);
    }
    let pt = &camera[t - 1];
    if !pt.is_connectible() {
        return Prepared::Nothing;
    }
    if s == 1 {
        // Next-event estimation: the light point comes from the lights' own sampler.
        let (u_choice, u_point) = pt.u_light;
        let Some(ls) = ctx.rs.lights.sample(pt.p, u_choice, u_point) else {
            return Prepared::Nothing;
        };
        let f = pt.scatter_towards(ls.wi, false);
        let value = pt.beta * f * ls.weight;
        if !finite(value) {
            return Prepared::Nothing;
        }
        let o = pt.origin_off(ls.wi);
        let ray = if ls.distance.is_finite() {
            segment(ctx, o, ls.point, ls.wi)
        } else {
            ShadowRay {
                origin: o,
                dir: ls.wi,
                tmax: f32::INFINITY,
            }
        };
        let environment = ctx.rs.lights.is_environment(ls.light).then_some(ls.wi);
        // A directional light's vertex stands on its disk outside the scene, in line with
        // the shading point (the densities read the direction from the positions).
        let point = if ls.distance.is_finite() {
            ls.point
        } else {
            pt.p + ls.wi * (4.0 * ctx.rs.lights.scene_radius())
        };
        let nee = NeePoint {
            light: ls.light,
            point,
            normal: ls.normal,
            towards: -ls.wi,
            environment,
        };
        return pending(Contribution::Pixel(value), ray, Some(nee), None);
    }
    let qs = &light[s - 1];
    if !qs.is_connectible() {
        return Prepared::Nothing;
    }
    let scatters = |v: &Vertex| matches!(v.kind, Kind::Surface { .. } | Kind::Medium { .. });
    if !scatters(qs) || !scatters(pt) {
        return Prepared::Nothing;
    }
    let d = qs.p - pt.p;
    let dist2 = d.length_squared();
    let w = d / dist2.sqrt();
    // The shading-frame forms of the connection, shared with the weight's densities.
    let (w_pt, w_q) = (pt.local(w), qs.local(-w));
    let value =
        pt.beta * pt.scatter_local(w, w_pt, false) * qs.scatter_local(-w, w_q, true) * qs.beta
            / dist2;
    if !finite(value) {
        return Prepared::Nothing;
    }
    let (a, b) = (pt.origin_off(w), qs.origin_off(-w));
    pending(
        Contribution::Pixel(value),
        segment(ctx, a, b, w),
        None,
        Some(Segment {
            w,
            dist2,
            w_pt,
            w_q,
        }),
    )
}

/// The contribution of a pending strategy whose shadow ray was unoccluded, weighted by MIS
/// unless `unweighted`.
#[inline]
pub(super) fn finish(
    ctx: &Context,
    light: &[Vertex],
    camera: &[Vertex],
    p: &Pending,
    unweighted: bool,
) -> Contribution {
    if unweighted {
        return p.contribution;
    }
    let w = match p.weight {
        Some(w) => w,
        None => weight_of(ctx, light, camera, p),
    };
    match p.contribution {
        Contribution::Pixel(v) => Contribution::Pixel(v * w),
        Contribution::Splat(film, v) => Contribution::Splat(film, v * w),
    }
}

/// The weight of a pending strategy that came without one (from [`prepare`]); out of line,
/// so that [`finish`] stays small enough to inline for the lane strategies, which come
/// weighted.
#[inline(never)]
fn weight_of(ctx: &Context, light: &[Vertex], camera: &[Vertex], p: &Pending) -> f32 {
    let camera = &camera[..p.t];
    let nee = p.nee.map(|n| {
        light_vertex(
            &ctx.rs.lights,
            n.light,
            n.point,
            n.normal,
            n.towards,
            n.environment,
        )
    });
    let light = match &nee {
        Some(v) => std::slice::from_ref(v),
        None => &light[..p.s],
    };
    weight(
        ctx,
        &Connection {
            light,
            camera,
            segment: p.segment,
        },
    )
}
