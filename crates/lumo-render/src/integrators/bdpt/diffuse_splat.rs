//! The strategies that connect a Lambertian light-subpath vertex to the pinhole (t = 1, s ≥ 2:
//! a splat on the film), sixteen at a time in vector lanes: the value and shadow ray, and the
//! reverse densities its weight needs (the film position comes with the job: vertices off
//! the film are dropped before any lane work, as the scalar strategy drops them first).
//!
//! Why: every scattering vertex of a light subpath runs this strategy, and one at a time it
//! was the projection onto the film, the light side's BSDF value, the shadow segment, and for
//! the weight the camera's direction density, each with its own divisions in series.
//!
//! Per lane it computes exactly what [`super::connect::prepare`] and the weight (with
//! `PinholeCamera::direction_pdf`) compute, the same operations in the same order, so a test
//! compares the two strategy by strategy, bit for bit.

// Lane loops index several arrays in lockstep by lane: the form the vectoriser turns into one
// vector operation per statement.
#![allow(clippy::needless_range_loop)]

use glam::Vec2;
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
use crate::geometry::shadow_segment;

const N: usize = LANES;

/// Light vertex `s − 1` of sample `k` seen by the camera, waiting for its value in entry
/// `slot` of the pending list.
#[derive(Clone, Copy, Debug)]
pub(super) struct SplatJob {
    /// Index in the pending list.
    pub slot: u32,
    /// The sample in its group.
    pub k: u32,
    /// Light vertices of the strategy (at least 2: the vertex is a surface).
    pub s: u32,
    /// Where the vertex lands on the film and the cosine to the view axis
    /// ([`crate::camera::PinholeCamera::project_point`], run when the strategy is listed:
    /// vertices off the film are dropped there, before any lane work).
    pub film: Vec2,
    /// See `film`.
    pub cos_cam: f32,
}

/// Fills the pending entries of `jobs` (each light vertex a Lambertian surface that is not
/// black) from the light subpaths `lights` of a group: the strategy, ready for its shadow
/// ray, or `s = 0` where it adds nothing.
pub(super) fn diffuse_splats(
    ctx: &Context,
    lights: &[Vec<Vertex>],
    jobs: &[SplatJob],
    pending: &mut [Pending],
) {
    for chunk in jobs.chunks(N) {
        splat_chunk(ctx, lights, chunk, pending);
    }
}

/// Where direction `d` from the eye crosses the film at distance 1 and its depth
/// (`PinholeCamera::on_film`), with whether it is in front and on the film.
#[inline(always)]
fn on_film(ctx: &Context, d: [f32; 3]) -> (bool, f32, f32, f32) {
    let c = ctx.camera;
    let z = dot(d, c.forward.into());
    let sx = dot(d, c.right.into()) / (z * c.half.x);
    let sy = dot(d, c.up.into()) / (z * c.half.y);
    let inside = (-1.0..1.0).contains(&sx) && (-1.0..1.0).contains(&sy);
    let behind = z <= 0.0;
    (!behind && inside, sx, sy, z)
}

multiversion! {
    /// Fills the pending entries of up to sixteen `jobs` (see [`diffuse_splats`]).
    fn splat_chunk(
        ctx: &Context,
        lights: &[Vec<Vertex>],
        jobs: &[SplatJob],
        pending: &mut [Pending],
    ) as splat_lanes, at splat_chunk_at {
        let n = jobs.len().min(N);
        let eps = ctx.rs.ray_epsilon;
        let cam = ctx.camera;
        let eye: [f32; 3] = cam.origin.into();
        let mut q = Side::default();
        let mut q_near = NearLanes::default();
        let mut cos_cams: L = [0.0; N];
        for (i, j) in jobs.iter().enumerate().take(n) {
            let l = &lights[j.k as usize];
            let s = j.s as usize;
            q.load(i, &l[s - 1], &l[s - 2]);
            q_near.set(i, Near::light(l, s - 1));
            cos_cams[i] = j.cos_cam;
        }

        let (mut value, mut origin, mut dir): (L3, L3, L3) = Default::default();
        let mut tmax: L = Default::default();
        let mut rev: [L; 3] = Default::default();
        let mut ok = [false; N];
        for i in 0..N {
            let qp = at(&q.p, i);
            let d = [qp[0] - eye[0], qp[1] - eye[1], qp[2] - eye[2]];
            let cos_cam = cos_cams[i];
            // Towards the eye.
            let to_cam = [eye[0] - qp[0], eye[1] - qp[1], eye[2] - qp[2]];
            let dist2 = dot(to_cam, to_cam);
            let len = dist2.sqrt();
            let wc = [to_cam[0] / len, to_cam[1] / len, to_cam[2] / len];
            // The light side's adjoint value towards the eye (`Vertex::scatter_local`).
            let wc_z = dot(wc, at(&q.n, i));
            let (front, f) = lambert_factor(wc_z, q.wo_z[i]);
            let cos_ng_w = dot(at(&q.ng, i), wc).abs();
            let live = !(q.wo_z[i] == 0.0 || q.cos_ng_wo[i] == 0.0);
            // G·We of the pinhole (`powi(3)` is two multiplications in this order).
            let scale = dist2 * (cos_cam * cos_cam * cos_cam);
            let importance = cam.pixel_importance();
            let mut v = [0.0f32; 3];
            let mut finite = true;
            for a in 0..3 {
                let fa = sel(front, q.albedo[a][i] * f, 0.0);
                let fa = sel(live, fa / q.cos_ng_wo[i] * cos_ng_w, 0.0);
                v[a] = q.beta[a][i] * fa * importance / scale;
                finite &= v[a].is_finite();
            }
            ok[i] = finite && !(v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0);
            let o = q.origin_off(i, wc);
            let (sd, st) = shadow_segment(o, eye, wc, eps);
            // The weight's geometry from the eye to the vertex (`Vertex::towards`: the offset
            // is `-to_cam`, component by component the exact negation, so its squared length is
            // `dist2`) and the three reverse densities next to the connection (the eye has no
            // predecessor).
            let none = dist2 == 0.0;
            let w = [
                sel(none, 0.0, d[0] / len),
                sel(none, 0.0, d[1] / len),
                sel(none, 0.0, d[2] / len),
            ];
            let nw = [-w[0], -w[1], -w[2]];
            let w_q = dot(nw, at(&q.n, i));
            // `pt_rev`: the vertex scattering towards the eye (no normal: its arrival cosine is 1).
            rev[0][i] = sel(none, 0.0, lambert_pdf(q.wp_z[i], w_q) / dist2);
            // `qs_rev`: the camera's direction density, in the vertex's area.
            let (in_view, _, _, cz) = on_film(ctx, w);
            let film_area = 4.0 * cam.half.x * cam.half.y;
            let pdf_dir = sel(in_view, 1.0 / (film_area * cz * cz * cz), 0.0);
            rev[1][i] = sel(none, 0.0, pdf_dir * arrival_cos(at(&q.ng, i), w) / dist2);
            // `qs_minus_rev`: the vertex scattering back to its predecessor.
            rev[2][i] = sel(
                q.d2_prev[i] == 0.0,
                0.0,
                lambert_pdf(w_q, q.wp_z[i]) * arrival_cos(at(&q.prev_ng, i), at(&q.w_prev, i))
                    / q.d2_prev[i],
            );
            for c in 0..3 {
                value[c][i] = v[c];
                origin[c][i] = o[c];
                dir[c][i] = sd[c];
            }
            tmax[i] = st;
        }

        // The weights (`mis::weight`; the pinhole has no strategy behind it), in a loop of
        // their own.
        let mut weight = [0.0f32; N];
        for i in 0..N {
            let rev_i = [rev[0][i], 0.0, rev[1][i], rev[2][i]];
            weight[i] = near_weight(&Near::NONE, &q_near.at(i), rev_i);
        }

        for (i, j) in jobs.iter().enumerate().take(n) {
            let entry = &mut pending[j.slot as usize];
            if !ok[i] {
                entry.s = 0;
                continue;
            }
            *entry = Pending::weighed(
                Contribution::Splat(j.film, vec3_at(&value, i)),
                ray_at(&origin, &dir, &tmax, i),
                (j.s as usize, 1),
                weight[i],
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::bdpt::connect::{prepare, Prepared};
    use crate::integrators::bdpt::lanes::is_lambertian;
    use crate::integrators::bdpt::tests::{
        assert_same_strategy, assert_scalar_made_covered, for_each_lane_case, scalar_made,
        walked_group, LANE_TEST_SETTINGS,
    };

    /// Every Lambertian light vertex that lands on the film gets from the lanes exactly the
    /// pending splat `connect::prepare` makes (or none where it makes none), and its weighted
    /// contribution is the scalar one, bit for bit, at every compiled level, on the lane test
    /// scenes (`tests::lane_test_scenes`); the scalar strategy makes nothing of the vertices
    /// off the film, which never reach the lanes.
    #[test]
    fn vector_splats_equal_scalar_splats() {
        for_each_lane_case(check_level);
    }

    fn check_level(ctx: &Context, level: Isa) {
        let rs = ctx.rs;
        let (mut visible, mut off_film, mut scalar_side) = (0usize, 0usize, 0usize);
        for y in 0..16u32 {
            let paths = walked_group(ctx, &LANE_TEST_SETTINGS, y);
            let (cams, lights) = paths.split_at(8);
            let (mut jobs, mut want, mut pending) = (vec![], vec![], vec![]);
            for (k, light) in lights.iter().enumerate() {
                for s in 2..=light.len() {
                    if !is_lambertian(&light[s - 1]) {
                        continue;
                    }
                    let scalar = prepare(ctx, light, &cams[k], (s, 1), false);
                    let Some((film, cos_cam)) = ctx.camera.project_point(light[s - 1].p) else {
                        assert!(matches!(scalar, Prepared::Nothing));
                        off_film += 1;
                        continue;
                    };
                    jobs.push(SplatJob {
                        slot: pending.len() as u32,
                        k: k as u32,
                        s: s as u32,
                        film,
                        cos_cam,
                    });
                    pending.push(Pending::placeholder());
                    want.push(scalar);
                }
            }
            for chunk in jobs.chunks(N) {
                splat_chunk_at(level, ctx, lights, chunk, &mut pending);
            }
            for (j, want) in jobs.iter().zip(want) {
                let (k, s) = (j.k as usize, j.s as usize);
                let at = format!("{} {level:?} row {y} sample {k} s = {s}", rs.scene.name);
                let pair = (&lights[k][..s], &cams[k][..1]);
                let adds = assert_same_strategy(ctx, pair, pending[j.slot as usize], want, &at);
                visible += usize::from(adds);
                scalar_side += usize::from(adds && scalar_made(rs, &lights[k][s - 1]));
            }
        }
        assert_scalar_made_covered(ctx, scalar_side, "splats");
        assert!(
            visible > 50,
            "{} {level:?}: {visible} splats compared ({off_film} off the film)",
            rs.scene.name
        );
    }
}
