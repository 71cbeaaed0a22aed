//! The strategies that join two Lambertian surface vertices (s, t ≥ 2), sixteen at a time in
//! vector lanes: the connection's value, its shadow ray and the four reverse densities next
//! to it that the weight needs. The counterpart of [`super::diffuse_walk`] for connections.
//!
//! Why: on the Cornell box most of a bidirectional sample's strategies are such joins, and
//! preparing them one at a time (two BSDF values, a square root and three divisions in
//! series, two ray offsets, the shadow segment) and weighing them (four densities with a
//! division each) was about a fifth of its time.
//!
//! Per lane it computes exactly what [`super::connect::prepare`] and the weight's densities
//! compute for two Lambertian vertices, the same operations in the same order, so a test
//! compares the two strategy by strategy, bit for bit. The weight's ratio sums stay scalar
//! ([`super::mis`]), fed with these densities.

// Lane loops index several arrays in lockstep by lane: the form the vectoriser turns into one
// vector operation per statement.
#![allow(clippy::needless_range_loop)]

use lumo_simd::multiversion;
#[cfg(test)]
use lumo_simd::Isa;

use super::connect::{Contribution, Pending};
use super::lanes::{
    arrival_cos, at, dot, is_lambertian, lambert_factor, lambert_pdf, ray_at, sel, vec3_at,
    NearLanes, Side,
};
use super::mis::{near_weight, Near};
use super::vertex::Vertex;
use crate::accel::packet::LANES;
use crate::geometry::shadow_segment;

const N: usize = LANES;

/// A join of two Lambertian vertices waiting for its value: strategy (`s`, `t`) of sample
/// `k`, whose entry in the pending list is `slot` (until then [`Pending::placeholder`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct DiffuseJoin {
    /// Index in the pending list.
    pub slot: u32,
    /// The sample in its group.
    pub k: u32,
    /// Light vertices.
    pub s: u32,
    /// Camera vertices.
    pub t: u32,
}

/// Whether strategy (s, t ≥ 2) joining camera vertex `pt` and light vertex `qs` is one that
/// [`diffuse_joins`] computes: both plain Lambertian surfaces, neither black.
#[inline(always)]
pub(super) fn is_diffuse_join(pt: &Vertex, qs: &Vertex) -> bool {
    is_lambertian(pt) && is_lambertian(qs)
}

/// Fills the pending entries of `joins` (every one a pair [`is_diffuse_join`] accepts, of
/// the camera subpaths `cams` and light subpaths `lights` of a group): the strategy, ready
/// for its shadow ray, or `s = 0` where its value is zero or not finite.
pub(super) fn diffuse_joins(
    eps: f32,
    cams: &[Vec<Vertex>],
    lights: &[Vec<Vertex>],
    joins: &[DiffuseJoin],
    pending: &mut [Pending],
) {
    for chunk in joins.chunks(N) {
        join_chunk(eps, cams, lights, chunk, pending);
    }
}

multiversion! {
    /// Fills the pending entries of up to sixteen `joins` (see [`diffuse_joins`]).
    fn join_chunk(
        eps: f32,
        cams: &[Vec<Vertex>],
        lights: &[Vec<Vertex>],
        joins: &[DiffuseJoin],
        pending: &mut [Pending],
    ) as join_lanes, at join_chunk_at {
        let n = joins.len().min(N);
        let (mut cam, mut light) = (Side::default(), Side::default());
        let (mut cam_near, mut light_near) = (NearLanes::default(), NearLanes::default());
        for (i, j) in joins.iter().enumerate().take(n) {
            let (c, l) = (&cams[j.k as usize], &lights[j.k as usize]);
            let (s, t) = (j.s as usize, j.t as usize);
            cam.load(i, &c[t - 1], &c[t - 2]);
            light.load(i, &l[s - 1], &l[s - 2]);
            cam_near.set(i, Near::camera(c, t - 1));
            light_near.set(i, Near::light(l, s - 1));
        }

        // `connect::prepare` for s, t ≥ 2, and the four reverse densities of `mis::weight`.
        let (mut value, mut origin, mut dir) = ([[0.0f32; N]; 3], [[0.0f32; N]; 3], [[0.0f32; N]; 3]);
        let (mut tmax, mut ok) = ([0.0f32; N], [false; N]);
        let mut rev = [[0.0f32; N]; 4];
        for i in 0..N {
            let (pp, qp) = (at(&cam.p, i), at(&light.p, i));
            let d = [qp[0] - pp[0], qp[1] - pp[1], qp[2] - pp[2]];
            let dist2 = dot(d, d);
            let len = dist2.sqrt();
            let w = [d[0] / len, d[1] / len, d[2] / len];
            let nw = [-w[0], -w[1], -w[2]];
            // The shading-frame cosines of the connection (`Vertex::local`).
            let w_pt = dot(w, at(&cam.n, i));
            let w_q = dot(nw, at(&light.n, i));
            // The camera side's value, f(wo, w)·|cos|, and the light side's adjoint one with the
            // shading-normal correction (`Vertex::scatter_local`).
            let (front_pt, f_pt) = lambert_factor(cam.wo_z[i], w_pt);
            let (front_q, f_q) = lambert_factor(w_q, light.wo_z[i]);
            let cos_ng_w = dot(at(&light.ng, i), nw).abs();
            let q_live = !(light.wo_z[i] == 0.0 || light.cos_ng_wo[i] == 0.0);
            let mut v = [0.0f32; 3];
            let mut finite = true;
            for a in 0..3 {
                let fp = sel(front_pt, cam.albedo[a][i] * f_pt, 0.0);
                let fq = sel(front_q, light.albedo[a][i] * f_q, 0.0);
                let fq = sel(q_live, fq / light.cos_ng_wo[i] * cos_ng_w, 0.0);
                v[a] = cam.beta[a][i] * fp * fq * light.beta[a][i] / dist2;
                finite &= v[a].is_finite();
            }
            ok[i] = finite && !(v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0);
            let a = cam.origin_off(i, w);
            let b = light.origin_off(i, nw);
            let (sd, st) = shadow_segment(a, b, w, eps);
            // The reverse densities next to the connection (`Vertex::pdf_onward`, `pdf_back`).
            let area = |pdf: f32, ng: [f32; 3], w: [f32; 3], d2: f32| {
                sel(d2 == 0.0, 0.0, pdf * arrival_cos(ng, w) / d2)
            };
            rev[0][i] = area(lambert_pdf(light.wp_z[i], w_q), at(&cam.ng, i), nw, dist2);
            rev[1][i] = area(
                lambert_pdf(w_pt, cam.wp_z[i]),
                at(&cam.prev_ng, i),
                at(&cam.w_prev, i),
                cam.d2_prev[i],
            );
            rev[2][i] = area(lambert_pdf(cam.wp_z[i], w_pt), at(&light.ng, i), w, dist2);
            rev[3][i] = area(
                lambert_pdf(w_q, light.wp_z[i]),
                at(&light.prev_ng, i),
                at(&light.w_prev, i),
                light.d2_prev[i],
            );
            for c in 0..3 {
                value[c][i] = v[c];
                origin[c][i] = a[c];
                dir[c][i] = sd[c];
            }
            tmax[i] = st;
        }

        // The weights (`mis::weight` from these densities), in a loop of their own.
        let mut weight = [0.0f32; N];
        for i in 0..N {
            let rev_i = [rev[0][i], rev[1][i], rev[2][i], rev[3][i]];
            weight[i] = near_weight(&cam_near.at(i), &light_near.at(i), rev_i);
        }

        // Scatter into the pending entries.
        for (i, j) in joins.iter().enumerate().take(n) {
            let entry = &mut pending[j.slot as usize];
            if !ok[i] {
                entry.s = 0;
                continue;
            }
            *entry = Pending::weighed(
                Contribution::Pixel(vec3_at(&value, i)),
                ray_at(&origin, &dir, &tmax, i),
                (j.s as usize, j.t as usize),
                weight[i],
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::bdpt::connect::prepare;
    use crate::integrators::bdpt::tests::{
        assert_same_strategy, assert_scalar_made_covered, for_each_lane_case, scalar_made,
        walked_group, LANE_TEST_SETTINGS,
    };
    use crate::integrators::bdpt::vertex::Context;

    /// Every join of two Lambertian vertices gets from the lanes exactly the pending entry
    /// `connect::prepare` makes (or none where it makes none), and the weight from the lanes'
    /// densities is the weight from the scalar densities, bit for bit, at every compiled
    /// level, on the lane test scenes (`tests::lane_test_scenes`).
    #[test]
    fn vector_joins_equal_scalar_joins() {
        for_each_lane_case(check_level);
    }

    fn check_level(ctx: &Context, level: Isa) {
        let rs = ctx.rs;
        let (mut joined, mut scalar_side) = (0usize, 0usize);
        for y in 0..16u32 {
            let paths = walked_group(ctx, &LANE_TEST_SETTINGS, y);
            let (cams, lights) = paths.split_at(8);
            let (mut joins, mut want) = (vec![], vec![]);
            let mut pending = vec![];
            for k in 0..8 {
                let (cam, light) = (&cams[k], &lights[k]);
                for t in 2..=cam.len() {
                    for s in 2..=light.len() {
                        if !is_diffuse_join(&cam[t - 1], &light[s - 1]) {
                            continue;
                        }
                        joins.push(DiffuseJoin {
                            slot: pending.len() as u32,
                            k: k as u32,
                            s: s as u32,
                            t: t as u32,
                        });
                        pending.push(Pending::placeholder());
                        want.push(prepare(ctx, light, cam, (s, t), false));
                    }
                }
            }
            for chunk in joins.chunks(N) {
                join_chunk_at(level, rs.ray_epsilon, cams, lights, chunk, &mut pending);
            }
            for (j, want) in joins.iter().zip(want) {
                let (k, s, t) = (j.k as usize, j.s as usize, j.t as usize);
                let at = format!("{} {level:?} row {y} sample {k} ({s}, {t})", rs.scene.name);
                let pair = (&lights[k][..s], &cams[k][..t]);
                let adds = assert_same_strategy(ctx, pair, pending[j.slot as usize], want, &at);
                joined += usize::from(adds);
                let scalar = scalar_made(rs, &cams[k][t - 1]) || scalar_made(rs, &lights[k][s - 1]);
                scalar_side += usize::from(adds && scalar);
            }
        }
        assert_scalar_made_covered(ctx, scalar_side, "joins");
        assert!(
            joined > 100,
            "{} {level:?}: {joined} joins checked",
            rs.scene.name
        );
    }
}
