//! One step of up to sixteen subpath walks at once, structure of arrays, for walks whose ray
//! hit a simple diffuse surface ([`RenderScene::simple_diffuse_ref`]: constant or textured
//! reflectance, world space, flat or with vertex normals): the bidirectional counterpart of
//! the path tracer's vector bounce ([`crate::integrators::path::vector_bounce`]). The other
//! hits take the scalar [`super::subpath`] step.
//!
//! Why: with the walks' rays in packets, the scalar step (surface reconstruction, BSDF
//! sampling, both densities, the vertex record) was a third of a bidirectional sample's time
//! on the Cornell box, a few hundred scalar instructions per vertex with square roots and
//! divisions in series. Here each stage is a loop over lanes that the compiler turns into
//! vector instructions, with branches as selects.
//!
//! Per lane it computes exactly what the scalar step computes for such a surface, in both
//! transport modes: the same operations in the same order (Rust never fuses a multiply and
//! an add on its own), so a test compares the two vertex for vertex and walk for walk, bit
//! for bit. Only what is per lane by nature stays scalar: gathering the walk, its previous
//! vertex and the scene data, the random numbers, and writing the vertex.

// Lane loops index several arrays in lockstep by lane: the form the vectoriser turns into one
// vector operation per statement.
#![allow(clippy::needless_range_loop)]

use glam::{Vec2, Vec3};
use lumo_simd::multiversion;
#[cfg(test)]
use lumo_simd::Isa;

use super::lanes::{at, dot, sel, L3};
use super::subpath::Walk;
use super::vertex::{Context, Kind, Vertex};
use crate::accel::packet::LANES;
use crate::accel::Hit;
use crate::bsdf::{Bsdf, Diffuse, TransportMode};
use crate::geometry::{
    cosine_pdf, disk_map, hemisphere_z, max3_abs, offset_point, shading_frame_lane,
    survival_probability, vmax, Basis,
};
use crate::integrators::path::PathSettings;
use crate::render_scene::Surface;
use crate::sampler::PixelSampler;

const N: usize = LANES;

/// The walks and their subpaths that [`diffuse_steps`] advances: walk `k` with
/// `samplers[k]` into `paths[k]`, up to `max_vertices[k]` vertices (the arguments of
/// [`super::subpath::random_walks`]).
pub(super) struct Walks<'a> {
    /// The walks (`None`: ended).
    pub walks: &'a mut [Option<Walk>],
    /// Their samplers.
    pub samplers: &'a mut [PixelSampler],
    /// Their vertex limits.
    pub max_vertices: &'a [usize],
    /// Their subpaths.
    pub paths: &'a mut [Vec<Vertex>],
}

multiversion! {
    /// Advances the walks `lanes` (at most [`LANES`] pairs of a walk index and its ray's hit,
    /// every hit on a simple diffuse instance, every walk live and below its vertex limit) by
    /// one step: records the vertex and samples the direction that leaves it, ending the walks
    /// that stop.
    pub(super) fn diffuse_steps(
        ctx: &Context,
        settings: &PathSettings,
        lanes: &[(usize, Hit)],
        w: &mut Walks,
    ) as steps, at diffuse_steps_at {
        let rs = ctx.rs;
        let n = lanes.len().min(N);
        let eps = rs.ray_epsilon;

        // Gather (scalar loads): the walk, the vertex it leaves, the hit surface, the numbers.
        // Lanes past `n` keep harmless values; their results are never used.
        let (mut o, mut d, mut beta): (L3, L3, L3) = ([[0.0; N]; 3], [[0.0; N]; 3], [[0.0; N]; 3]);
        let (mut ng, mut albedo, mut prev_p, mut prev_ng): (L3, L3, L3, L3) =
            ([[0.0; N]; 3], [[0.0; N]; 3], [[0.0; N]; 3], [[0.0; N]; 3]);
        let (mut nv0, mut nv1, mut nv2): (L3, L3, L3) = ([[0.0; N]; 3], [[0.0; N]; 3], [[0.0; N]; 3]);
        let (mut t, mut bu, mut bv) = ([0.0f32; N], [0.0f32; N], [0.0f32; N]);
        let (mut pdf_dir, mut eta_scale) = ([0.0f32; N], [1.0f32; N]);
        let (mut u_dir, mut u_rr) = ([[0.0f32; N]; 2], [0.0f32; N]);
        let mut interpolate = [false; N];
        let mut one_sided = [false; N];
        let mut importance = [false; N];
        // How the previous vertex makes this one's forward density: its own Dirac lobe, a
        // directional light's parallel rays, or the solid-angle density turned into area.
        let (mut prev_delta, mut prev_directional) = ([false; N], [false; N]);
        // Room for a vertex after this one, and Russian roulette at this depth.
        let (mut room, mut roulette) = ([false; N], [false; N]);
        let mut u_light = [(0.0f32, Vec2::ZERO); N];
        for (i, &(k, hit)) in lanes.iter().enumerate().take(n) {
            let Some(walk) = &w.walks[k] else { continue };
            let sd = rs.simple_diffuse_ref(hit.instance);
            let normal = rs.unit_normal(sd.mesh, hit.triangle);
            if let Some([n0, n1, n2]) = rs.simple_normals(sd, hit.triangle) {
                interpolate[i] = true;
                for a in 0..3 {
                    (nv0[a][i], nv1[a][i], nv2[a][i]) = (n0[a], n1[a], n2[a]);
                }
            }
            let lane_albedo = rs.simple_albedo(sd, &hit);
            let path = &w.paths[k];
            let prev = &path[path.len() - 1];
            for a in 0..3 {
                o[a][i] = walk.origin[a];
                d[a][i] = walk.dir[a];
                beta[a][i] = walk.beta[a];
                ng[a][i] = normal[a];
                albedo[a][i] = lane_albedo[a];
                prev_p[a][i] = prev.p[a];
                prev_ng[a][i] = prev.ng[a];
            }
            (t[i], bu[i], bv[i]) = (hit.t, hit.u, hit.v);
            pdf_dir[i] = walk.pdf_dir;
            eta_scale[i] = walk.eta_scale;
            importance[i] = walk.mode == TransportMode::Importance;
            one_sided[i] = sd.one_sided;
            prev_delta[i] = prev.delta;
            prev_directional[i] = matches!(
                prev.kind,
                Kind::Light {
                    directional: true,
                    ..
                }
            );
            // The vertex count once this one is recorded.
            let len = path.len() + 1;
            room[i] = len < w.max_vertices[k];
            roulette[i] = (len - 1) as u32 >= settings.rr_depth;
            // The scalar step's draws, in its order.
            let sampler = &mut w.samplers[k];
            if !importance[i] {
                u_light[i] = (sampler.next_1d(), sampler.next_2d());
            }
            let _u_lobe = sampler.next_1d();
            let u = sampler.next_2d();
            (u_dir[0][i], u_dir[1][i]) = (u.x, u.y);
            u_rr[i] = sampler.next_1d();
        }

        // The surface (RenderScene::surface: the shading normal interpolated, normalised and on
        // the side of the geometric normal, its frame), the direction back along the ray in it,
        // the segment from the previous vertex and the vertex's densities and offset scale.
        let (mut pos, mut ns, mut fs, mut ft, mut wo): (L3, L3, L3, L3, L3) = (
            [[0.0; N]; 3],
            [[0.0; N]; 3],
            [[0.0; N]; 3],
            [[0.0; N]; 3],
            [[0.0; N]; 3],
        );
        let (mut w_prev, mut d2) = ([[0.0f32; N]; 3], [0.0f32; N]);
        let (mut cos_ng_wo, mut wp_z, mut off_scale, mut pdf_fwd) =
            ([0.0f32; N], [0.0f32; N], [0.0f32; N], [0.0f32; N]);
        let (mut black, mut faces_away) = ([false; N], [false; N]);
        for i in 0..N {
            let p = [
                o[0][i] + d[0][i] * t[i],
                o[1][i] + d[1][i] * t[i],
                o[2][i] + d[2][i] * t[i],
            ];
            let g = at(&ng, i);
            let nv = [at(&nv0, i), at(&nv1, i), at(&nv2, i)];
            let (sn, s_axis, t_axis) = shading_frame_lane(nv, (bu[i], bv[i]), g, interpolate[i]);
            let nd = [-d[0][i], -d[1][i], -d[2][i]];
            let wo_l = [dot(nd, s_axis), dot(nd, t_axis), dot(nd, sn)];
            // The segment from the previous vertex (its reverse is the vertex's `w_prev`).
            let dv = [
                p[0] - prev_p[0][i],
                p[1] - prev_p[1][i],
                p[2] - prev_p[2][i],
            ];
            let dd = dot(dv, dv);
            let len = dd.sqrt();
            let none = dd == 0.0;
            let w_in = [
                sel(none, 0.0, dv[0] / len),
                sel(none, 0.0, dv[1] / len),
                sel(none, 0.0, dv[2] / len),
            ];
            let wp = [-w_in[0], -w_in[1], -w_in[2]];
            // area_density_along(pdf_dir, this vertex, w_in, d2).
            let g_zero = g[0] == 0.0 && g[1] == 0.0 && g[2] == 0.0;
            let arrival = sel(g_zero, 1.0, dot(g, w_in).abs());
            let area = sel(none, 0.0, pdf_dir[i] * arrival / dd);
            let directional = pdf_dir[i] * dot(g, at(&d, i)).abs();
            pdf_fwd[i] = sel(
                prev_delta[i],
                1.0,
                sel(prev_directional[i], directional, area),
            );
            black[i] = wo_l[2] <= 0.0 && one_sided[i];
            // `RenderScene::emission`: nothing towards the back.
            faces_away[i] = dot(g, at(&d, i)) >= 0.0;
            cos_ng_wo[i] = dot(g, nd).abs();
            wp_z[i] = dot(wp, sn);
            off_scale[i] = eps * (1.0 + max3_abs(p));
            d2[i] = dd;
            for c in 0..3 {
                pos[c][i] = p[c];
                ns[c][i] = sn[c];
                fs[c][i] = s_axis[c];
                ft[c][i] = t_axis[c];
                wo[c][i] = wo_l[c];
                w_prev[c][i] = wp[c];
            }
        }

        // Sampling the direction that leaves (`lambert_sample`, then the world direction and the
        // scalar step's checks of either mode), the throughput, the previous vertex's reverse
        // density, the next ray and Russian roulette.
        let (mut new_o, mut new_d, mut new_beta) =
            ([[0.0f32; N]; 3], [[0.0f32; N]; 3], [[0.0f32; N]; 3]);
        let (mut new_pdf, mut prev_rev) = ([0.0f32; N], [0.0f32; N]);
        // `sampled`: the direction was drawn (the previous vertex's reverse density is set);
        // `goes_on`: the walk continues from it.
        let (mut sampled, mut goes_on) = ([false; N], [false; N]);
        for i in 0..N {
            let wo_z = wo[2][i];
            let g = at(&ng, i);
            let sn = at(&ns, i);
            let dir = at(&d, i);
            let cos_ng_l = dot(g, dir).abs();
            // lambert_sample.
            let flip = wo_z < 0.0;
            let (dx, dy) = disk_map(u_dir[0][i], u_dir[1][i]);
            let z = hemisphere_z(dx, dy);
            let pdf = cosine_pdf(z);
            let wi = [sel(flip, -dx, dx), sel(flip, -dy, dy), sel(flip, -z, z)];
            // (`lambert_sample` also asks for a finite reflectance: a bitmap's bilinear
            // filter can overflow even where every texel is finite.)
            let finite_albedo =
                albedo[0][i].is_finite() && albedo[1][i].is_finite() && albedo[2][i].is_finite();
            let mut ok = room[i] && !black[i] && wo_z != 0.0 && pdf > 0.0 && finite_albedo;
            ok &= !(importance[i] && cos_ng_l == 0.0);
            // Basis::to_world, then normalize.
            let wv = [
                fs[0][i] * wi[0] + ft[0][i] * wi[1] + sn[0] * wi[2],
                fs[1][i] * wi[0] + ft[1][i] * wi[1] + sn[1] * wi[2],
                fs[2][i] * wi[0] + ft[2][i] * wi[1] + sn[2] * wi[2],
            ];
            let rcp = 1.0 / dot(wv, wv).sqrt();
            let nd = [wv[0] * rcp, wv[1] * rcp, wv[2] * rcp];
            // Shading normals can send a sample through the geometric surface; drop it.
            let reflect = wi[2] * wo_z > 0.0;
            let geometric = dot(nd, g) * dot([-dir[0], -dir[1], -dir[2]], g) > 0.0;
            ok &= reflect == geometric;
            // Importance: `particle_direction`'s departure half of the adjoint correction and the
            // arrival half of the step; radiance: the reflectance alone.
            let cos_ns_o = dot(sn, nd).abs();
            ok &= !(importance[i] && cos_ns_o <= 0.0);
            let depart = dot(g, nd).abs() / cos_ns_o;
            let arrive = dot(sn, dir).abs() / cos_ng_l;
            let mut bt = [0.0f32; 3];
            for a in 0..3 {
                let imp = beta[a][i] * (albedo[a][i] * depart * arrive);
                let rad = beta[a][i] * albedo[a][i];
                bt[a] = sel(importance[i], imp, rad);
            }
            sampled[i] = ok;
            // The previous vertex's reverse density: lambert_pdf(wi, wo) towards it, in its area.
            let neg = wi[2] < 0.0;
            let (zo, zi) = (sel(neg, -wi[2], wi[2]), sel(neg, -wo_z, wo_z));
            let rev = sel(zo <= 0.0, 0.0, cosine_pdf(zi));
            let pn = at(&prev_ng, i);
            let pn_zero = pn[0] == 0.0 && pn[1] == 0.0 && pn[2] == 0.0;
            let wp = at(&w_prev, i);
            let arrival = sel(pn_zero, 1.0, dot(pn, wp).abs());
            prev_rev[i] = sel(d2[i] == 0.0, 0.0, rev * arrival / d2[i]);
            new_pdf[i] = pdf;
            let no = offset_point(at(&pos, i), g, nd, eps);
            // Russian roulette.
            let max = vmax(bt[0], vmax(bt[1], bt[2]));
            let q = survival_probability(max, eta_scale[i]);
            ok &= !(roulette[i] && u_rr[i] >= q);
            for a in 0..3 {
                bt[a] = sel(roulette[i], bt[a] / q, bt[a]);
            }
            ok &= !(bt[0] == 0.0 && bt[1] == 0.0 && bt[2] == 0.0)
                && bt[0].is_finite()
                && bt[1].is_finite()
                && bt[2].is_finite();
            for a in 0..3 {
                new_o[a][i] = no[a];
                new_d[a][i] = nd[a];
                new_beta[a][i] = bt[a];
            }
            goes_on[i] = ok;
        }

        // Scatter: the vertices, the previous vertices' reverse densities, the walks.
        for (i, &(k, hit)) in lanes.iter().enumerate().take(n) {
            let Some(walk) = &mut w.walks[k] else {
                continue;
            };
            let sd = rs.simple_diffuse_ref(hit.instance);
            let material = rs.scene.meshes[sd.mesh].material;
            let s = Surface {
                p: Vec3::new(pos[0][i], pos[1][i], pos[2][i]),
                ng: Vec3::new(ng[0][i], ng[1][i], ng[2][i]),
                frame: Basis {
                    s: Vec3::new(fs[0][i], fs[1][i], fs[2][i]),
                    t: Vec3::new(ft[0][i], ft[1][i], ft[2][i]),
                    n: Vec3::new(ns[0][i], ns[1][i], ns[2][i]),
                },
                // Not read: the reflectance is in `lambert` (see `Kind::Surface`).
                uv: Vec2::ZERO,
                color: Vec3::ONE,
                material,
                instance: hit.instance,
                triangle: hit.triangle,
                // As the scalar walk sets it; simple diffuse materials have one BSDF and
                // never consult it.
                back: Vec3::from(at(&d, i)).dot(Vec3::new(ng[0][i], ng[1][i], ng[2][i])) > 0.0,
            };
            let lane_albedo = Vec3::new(albedo[0][i], albedo[1][i], albedo[2][i]);
            let kind = Kind::Surface {
                s,
                bsdf: Bsdf::Diffuse(Diffuse {
                    albedo: lane_albedo,
                })
                .into(),
                wo_local: Vec3::new(wo[0][i], wo[1][i], wo[2][i]),
                cos_ng_wo: cos_ng_wo[i],
                wp_local: Vec3::new(0.0, 0.0, wp_z[i]),
                lambert: Some(lane_albedo),
                black: black[i],
            };
            let mut v = Vertex::new(
                kind,
                s.p,
                s.ng,
                Vec3::new(beta[0][i], beta[1][i], beta[2][i]),
            );
            v.off_scale = off_scale[i];
            v.w_prev = Vec3::new(w_prev[0][i], w_prev[1][i], w_prev[2][i]);
            v.d2_prev = d2[i];
            v.pdf_fwd = pdf_fwd[i];
            if !importance[i] {
                v.le = if faces_away[i] {
                    Vec3::ZERO
                } else {
                    sd.emission
                };
                v.u_light = u_light[i];
            }
            let path = &mut w.paths[k];
            if sampled[i] {
                let prev = path.len() - 1;
                path[prev].pdf_rev = prev_rev[i];
            }
            path.push(v);
            if goes_on[i] {
                walk.origin = Vec3::new(new_o[0][i], new_o[1][i], new_o[2][i]);
                walk.dir = Vec3::new(new_d[0][i], new_d[1][i], new_d[2][i]);
                walk.beta = Vec3::new(new_beta[0][i], new_beta[1][i], new_beta[2][i]);
                walk.pdf_dir = new_pdf[i];
            } else {
                w.walks[k] = None;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::bdpt::subpath::{camera_start, light_start, step};
    use crate::integrators::bdpt::tests::{for_each_lane_case, LANE_TEST_SETTINGS};

    /// The vector step leaves every vertex, reverse density, walk and sampler exactly as the
    /// scalar step does, for camera and light walks in the same lanes, at every compiled
    /// level, on the lane test scenes (`tests::lane_test_scenes`: vertex normals, a
    /// checkerboard floor looked up per lane, light subpaths from a point, a spot and a
    /// directional light).
    #[test]
    fn vector_steps_equal_scalar_steps() {
        for_each_lane_case(check_level);
    }

    /// Walks 16 rows of 8 camera and 8 light subpaths step by step; before each vector step
    /// the scalar step runs on copies of its lanes' walks, and the two must agree to the bit.
    fn check_level(ctx: &Context, level: Isa) {
        let rs = ctx.rs;
        let settings = LANE_TEST_SETTINGS;
        let max_depth = settings.max_depth as usize;
        // Steps checked: [camera, light] × [went on, ended].
        let mut checked = [[0usize; 2]; 2];
        for y in 0..16u32 {
            let (mut walks, mut samplers, mut paths, mut max_vertices) =
                (vec![], vec![], vec![], vec![]);
            for x in 0..8u32 {
                let mut sampler = PixelSampler::new(x, y, 1, 9);
                let mut path = Vec::new();
                let film = glam::Vec2::new(4.0 * x as f32 + 0.5, 2.0 * y as f32 + 0.5);
                walks.push(camera_start(ctx, film, max_depth + 1, &mut path));
                paths.push(path);
                samplers.push(sampler);
                max_vertices.push(max_depth + 1);
                let mut path = Vec::new();
                walks.push(light_start(ctx, &mut sampler, max_depth, &mut path));
                paths.push(path);
                samplers.push(sampler);
                max_vertices.push(max_depth);
            }
            loop {
                let live: Vec<usize> = (0..walks.len())
                    .filter(|&k| walks[k].is_some() && paths[k].len() < max_vertices[k])
                    .collect();
                if live.is_empty() {
                    break;
                }
                let mut lanes = vec![];
                let mut want = vec![];
                for k in live {
                    let walk = walks[k].expect("live");
                    let hit = rs
                        .accel
                        .intersect(walk.origin, walk.dir, 0.0, f32::INFINITY);
                    let (mut alone, mut sampler, mut path) = (walk, samplers[k], paths[k].clone());
                    let on = step(
                        ctx,
                        &mut alone,
                        hit,
                        &mut sampler,
                        &settings,
                        max_vertices[k],
                        &mut path,
                    );
                    match hit.filter(|h| rs.is_simple_diffuse(h.instance)) {
                        Some(h) => {
                            // The lanes leave texture coordinates out (see `Kind::Surface`).
                            if let Some(Kind::Surface { s, .. }) =
                                path.last_mut().map(|v| &mut v.kind)
                            {
                                s.uv = Vec2::ZERO;
                            }
                            lanes.push((k, h));
                            want.push((k, on.then_some(alone), sampler, path));
                        }
                        None => {
                            walks[k] = on.then_some(alone);
                            samplers[k] = sampler;
                            paths[k] = path;
                        }
                    }
                }
                for chunk in lanes.chunks(N) {
                    let mut w = Walks {
                        walks: &mut walks,
                        samplers: &mut samplers,
                        max_vertices: &max_vertices,
                        paths: &mut paths,
                    };
                    diffuse_steps_at(level, ctx, &settings, chunk, &mut w);
                }
                for (k, walk, mut sampler, path) in want {
                    let at = format!("level {level:?}, row {y}, walk {k}");
                    assert_eq!(walks[k].is_some(), walk.is_some(), "{at}: goes on");
                    if let (Some(got), Some(want)) = (walks[k], walk) {
                        assert_eq!(format!("{got:?}"), format!("{want:?}"), "{at}: walk");
                    }
                    assert_eq!(format!("{:?}", paths[k]), format!("{path:?}"), "{at}");
                    assert_eq!(
                        samplers[k].next_1d().to_bits(),
                        sampler.next_1d().to_bits(),
                        "{at}: sampler"
                    );
                    checked[k % 2][usize::from(walk.is_none())] += 1;
                }
            }
        }
        // Both modes, walks that go on and walks that end (roulette, the vertex limit).
        assert!(
            checked.iter().flatten().all(|&c| c > 40),
            "{}, level {level:?}: steps checked {checked:?}",
            rs.scene.name
        );
    }
}
