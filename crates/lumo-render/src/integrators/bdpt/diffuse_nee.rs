//! Next-event estimation from Lambertian camera vertices (s = 1, t ≥ 2) towards emissive
//! triangles of constant radiance, sixteen strategies at a time in vector lanes: the point on
//! the triangle, the strategy's value and shadow ray, and for its weight the light vertex's
//! own density and the three reverse densities next to the connection.
//!
//! Why: every camera vertex runs this strategy, and one at a time it was a chain of square
//! roots and divisions (the light sample, the value, the shadow segment) followed, once the
//! shadow ray was clear, by three lookups of the light's emission density for the weight.
//!
//! Per lane it computes exactly what [`super::connect::prepare`] (through
//! [`crate::lights::Lights::sample`]) and the weight (through `light_vertex` and
//! `Vertex::pdf_onward`/`pdf_back`) compute, the same operations in the same order, so a test
//! compares the two strategy by strategy, bit for bit. The light is still chosen per lane in
//! scalar code (an alias-table lookup) before the strategy is listed; lanes that choose any
//! other light take the scalar strategy.

// Lane loops index several arrays in lockstep by lane: the form the vectoriser turns into one
// vector operation per statement.
#![allow(clippy::needless_range_loop)]

use lumo_simd::multiversion;
#[cfg(test)]
use lumo_simd::Isa;

use super::connect::{Contribution, Pending};
use super::lanes::{
    arrival_cos, at, dot, lambert_factor, lambert_pdf, ray_at, sel, vec3_at, NearLanes, Side, L, L3,
};
use super::mis::{near_weight, Near};
use super::vertex::{Context, Vertex};
use crate::accel::packet::LANES;
use crate::geometry::{shadow_segment, triangle_map};

const N: usize = LANES;

/// Next-event estimation from camera vertex `t − 1` of sample `k` towards light `light` (an
/// emissive triangle of constant radiance, chosen with probability `pick`), waiting for its
/// value in entry `slot` of the pending list.
#[derive(Clone, Copy, Debug)]
pub(super) struct NeeJob {
    /// Index in the pending list.
    pub slot: u32,
    /// The sample in its group.
    pub k: u32,
    /// Camera vertices of the strategy.
    pub t: u32,
    /// The chosen light.
    pub light: u32,
    /// The probability of choosing it.
    pub pick: f32,
}

/// Fills the pending entries of `jobs` (each camera vertex a Lambertian surface that is not
/// black, each light an untextured emissive triangle) from the camera subpaths `cams` of a
/// group: the strategy, ready for its shadow ray, or `s = 0` where it adds nothing.
pub(super) fn diffuse_nees(
    ctx: &Context,
    cams: &[Vec<Vertex>],
    jobs: &[NeeJob],
    pending: &mut [Pending],
) {
    for chunk in jobs.chunks(N) {
        nee_chunk(ctx, cams, chunk, pending);
    }
}

multiversion! {
    /// Fills the pending entries of up to sixteen `jobs` (see [`diffuse_nees`]).
    fn nee_chunk(
        ctx: &Context,
        cams: &[Vec<Vertex>],
        jobs: &[NeeJob],
        pending: &mut [Pending],
    ) as nee_lanes, at nee_chunk_at {
        let n = jobs.len().min(N);
        let lights = &ctx.rs.lights;
        let eps = ctx.rs.ray_epsilon;
        let mut cam = Side::default();
        let mut cam_near = NearLanes::default();
        let (mut p0, mut e1, mut e2, mut tn, mut radiance): (L3, L3, L3, L3, L3) = Default::default();
        let (mut area, mut pick, mut pick_e): (L, L, L) = Default::default();
        let (mut u0, mut u1): (L, L) = Default::default();
        for (i, j) in jobs.iter().enumerate().take(n) {
            let c = &cams[j.k as usize];
            let t = j.t as usize;
            let pt = &c[t - 1];
            cam.load(i, pt, &c[t - 2]);
            cam_near.set(i, Near::camera(c, t - 1));
            let Some(tri) = lights.untextured_triangle(j.light) else {
                continue;
            };
            for a in 0..3 {
                p0[a][i] = tri.p0[a];
                e1[a][i] = tri.e1[a];
                e2[a][i] = tri.e2[a];
                tn[a][i] = tri.normal[a];
                radiance[a][i] = tri.radiance[a];
            }
            area[i] = tri.area;
            pick[i] = j.pick;
            pick_e[i] = lights.emission_pick(j.light);
            (u0[i], u1[i]) = (pt.u_light.1.x, pt.u_light.1.y);
        }

        let (mut value, mut origin, mut dir): (L3, L3, L3) = Default::default();
        let (mut tmax, mut origin_pdf): (L, L) = Default::default();
        let mut rev: [L; 3] = Default::default();
        let mut ok = [false; N];
        for i in 0..N {
            let pp = at(&cam.p, i);
            let ng_l = at(&tn, i);
            // `Lights::sample` of a triangle.
            let (bx, by) = triangle_map(u0[i], u1[i]);
            let q = [
                p0[0][i] + e1[0][i] * bx + e2[0][i] * by,
                p0[1][i] + e1[1][i] * bx + e2[1][i] * by,
                p0[2][i] + e1[2][i] * bx + e2[2][i] * by,
            ];
            let d = [q[0] - pp[0], q[1] - pp[1], q[2] - pp[2]];
            let dist2 = dot(d, d);
            let distance = dist2.sqrt();
            let inv = 1.0 / distance;
            let wi = [d[0] * inv, d[1] * inv, d[2] * inv];
            let towards = [-wi[0], -wi[1], -wi[2]];
            let cos = dot(ng_l, towards);
            let sampled = !(cos <= 0.0 || area[i] <= 0.0);
            let (num, den) = (pick[i] * dist2, area[i] * cos);
            let r = den / num;
            // The camera side's value towards the light (`Vertex::scatter_towards`).
            let (front, f) = lambert_factor(cam.wo_z[i], dot(wi, at(&cam.n, i)));
            let mut v = [0.0f32; 3];
            let mut finite = true;
            for a in 0..3 {
                let fa = sel(front, cam.albedo[a][i] * f, 0.0);
                v[a] = cam.beta[a][i] * fa * (radiance[a][i] * r);
                finite &= v[a].is_finite();
            }
            ok[i] = sampled && finite && !(v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0);
            let o = cam.origin_off(i, wi);
            let (sd, st) = shadow_segment(o, q, wi, eps);
            // The light vertex's own density (`light_vertex`: `emission_pdf_of` towards the
            // shading point, the chance of the triangle over its area).
            let density = |dir: [f32; 3]| {
                let a = pick_e[i] / area[i];
                let solid = dot(ng_l, dir) / std::f32::consts::PI;
                // (`emission_pdf_of` rejects `pick <= 0`: written as its test is.)
                let rejected = pick_e[i] <= 0.0;
                let valid = !rejected && a > 0.0 && a.is_finite() && solid > 0.0;
                (valid, a, solid)
            };
            let (valid, a, _) = density(towards);
            origin_pdf[i] = sel(valid, a, 0.0);
            // The weight's connection geometry (`Vertex::towards`: the same offset and distance
            // as the light sample's, but a division where the sample multiplies by 1/distance).
            let none = dist2 == 0.0;
            let w = [
                sel(none, 0.0, d[0] / distance),
                sel(none, 0.0, d[1] / distance),
                sel(none, 0.0, d[2] / distance),
            ];
            let nw = [-w[0], -w[1], -w[2]];
            let w_pt = dot(w, at(&cam.n, i));
            // `pt_rev`: the light emitting towards the camera vertex, in its area.
            let (valid, _, solid) = density(nw);
            let emit = sel(valid, solid, 0.0);
            rev[0][i] = sel(none, 0.0, emit * arrival_cos(at(&cam.ng, i), nw) / dist2);
            // `pt_minus_rev`: the camera vertex scattering back to its predecessor.
            rev[1][i] = sel(
                cam.d2_prev[i] == 0.0,
                0.0,
                lambert_pdf(w_pt, cam.wp_z[i]) * arrival_cos(at(&cam.prev_ng, i), at(&cam.w_prev, i))
                    / cam.d2_prev[i],
            );
            // `qs_rev`: the camera vertex scattering to the light point, in its area.
            rev[2][i] = sel(
                none,
                0.0,
                lambert_pdf(cam.wp_z[i], w_pt) * arrival_cos(ng_l, w) / dist2,
            );
            for c in 0..3 {
                value[c][i] = v[c];
                origin[c][i] = o[c];
                dir[c][i] = sd[c];
            }
            tmax[i] = st;
        }

        // The weights (`mis::weight` with the light point as a subpath of its own: a triangle,
        // no Dirac delta), in a loop of their own.
        let mut weight = [0.0f32; N];
        for i in 0..N {
            let light_side = Near::light_origin(origin_pdf[i], false);
            let rev_i = [rev[0][i], rev[1][i], rev[2][i], 0.0];
            weight[i] = near_weight(&cam_near.at(i), &light_side, rev_i);
        }

        for (i, j) in jobs.iter().enumerate().take(n) {
            let entry = &mut pending[j.slot as usize];
            if !ok[i] {
                entry.s = 0;
                continue;
            }
            *entry = Pending::weighed(
                Contribution::Pixel(vec3_at(&value, i)),
                ray_at(&origin, &dir, &tmax, i),
                (1, j.t as usize),
                weight[i],
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::bdpt::connect::prepare;
    use crate::integrators::bdpt::lanes::is_lambertian;
    use crate::integrators::bdpt::tests::{
        assert_same_strategy, assert_scalar_made_covered, for_each_lane_case, scalar_made,
        walked_group, LANE_TEST_SETTINGS,
    };

    /// Every next-event strategy from a Lambertian camera vertex to an emissive triangle gets
    /// from the lanes exactly the pending entry `connect::prepare` makes (or none where it
    /// makes none), and its weighted contribution (`connect::finish`, with the lanes' light
    /// density and reverse densities) is the scalar one, bit for bit, at every compiled
    /// level, on the lane test scenes (`tests::lane_test_scenes`).
    #[test]
    fn vector_next_events_equal_scalar_ones() {
        for_each_lane_case(check_level);
    }

    fn check_level(ctx: &Context, level: Isa) {
        let rs = ctx.rs;
        let (mut visible, mut jobs_seen, mut scalar_side) = (0usize, 0usize, 0usize);
        for y in 0..32u32 {
            let paths = walked_group(ctx, &LANE_TEST_SETTINGS, y);
            let (cams, lights) = paths.split_at(8);
            let (mut jobs, mut want, mut pending) = (vec![], vec![], vec![]);
            for (k, cam) in cams.iter().enumerate() {
                for t in 2..=cam.len() {
                    let pt = &cam[t - 1];
                    if !is_lambertian(pt) {
                        continue;
                    }
                    let Some((pick, _, light)) = rs.lights.choose_triangle(pt.u_light.0) else {
                        continue;
                    };
                    jobs.push(NeeJob {
                        slot: pending.len() as u32,
                        k: k as u32,
                        t: t as u32,
                        light,
                        pick,
                    });
                    pending.push(Pending::placeholder());
                    want.push(prepare(ctx, &lights[k][..0], cam, (1, t), false));
                }
            }
            for chunk in jobs.chunks(N) {
                nee_chunk_at(level, ctx, cams, chunk, &mut pending);
            }
            for (j, want) in jobs.iter().zip(want) {
                let (k, t) = (j.k as usize, j.t as usize);
                let at = format!("{} {level:?} row {y} sample {k} t = {t}", rs.scene.name);
                let pair = (&lights[k][..], &cams[k][..]);
                let adds = assert_same_strategy(ctx, pair, pending[j.slot as usize], want, &at);
                visible += usize::from(adds);
                scalar_side += usize::from(adds && scalar_made(rs, &cams[k][t - 1]));
                jobs_seen += 1;
            }
        }
        assert_scalar_made_covered(ctx, scalar_side, "next-event strategies");
        // Some strategies add nothing (the light's back, a black BSDF value).
        assert!(
            visible > 50 && jobs_seen > visible,
            "{} {level:?}: {visible} of {jobs_seen} strategies add something",
            rs.scene.name
        );
    }
}
