//! One bounce of up to sixteen paths at once, structure of arrays, for the common case: a
//! diffuse surface (constant or textured reflectance) in world space, flat or with vertex
//! normals. Used by the wavefront renderer for the lanes that qualify
//! ([`RenderScene::simple_diffuse`]); all others take [`PathState::advance`]. Light samples on
//! emissive triangles of constant radiance, on sphere lights seen from outside (their visible
//! cone) and of the constant environment are computed in the lanes under RGB transport, with
//! the scalar samplers' own plain-float formulas (`cone_point`, `towards`,
//! `uniform_sphere_map`); a lane that picked any other light (sun, environment image, point,
//! spot, disk or cylinder, textured emitter) or a spectral path's sphere or environment gets
//! its shadow ray from the scalar path's own light sample and connection.
//!
//! Why: after packet traversal, shading and sampling one path at a time was ≈ 60 % of a
//! Cornell-box render, a few hundred scalar instructions per bounce with square roots and
//! divisions in series. Here every step is a loop over lanes that the compiler turns into
//! vector instructions (sixteen lanes per AVX-512 instruction), with branches as selects.
//!
//! It computes, per lane, exactly what `advance` computes for such a surface — the same
//! operations in the same order (Rust never fuses a multiply and an add on its own), so the
//! wavefront's bit-for-bit test against the one-ray integrator covers it too, and a unit test
//! compares it with `advance` lane for lane, shadow rays included. Only what is
//! per-lane by nature stays scalar: gathering path state and scene data, the random numbers,
//! the light choice, and the rare emitter hit and first-hit record.

// Lane loops index several arrays in lockstep by lane: the form the vectoriser turns into one
// vector operation per statement.
#![allow(clippy::needless_range_loop)]

use glam::{Vec2, Vec3};

use crate::accel::analytic::cone_point;
use crate::accel::packet::LANES;
use crate::accel::Hit;
use crate::bsdf::{Bsdf, Diffuse};
use crate::geometry::{
    cosine_pdf, disk_map, hemisphere_z, offset_point, power_heuristic, shading_frame_lane,
    shadow_segment, survival_probability, triangle_map, uniform_sphere_map, vmax, Basis,
    UNIFORM_SPHERE_PDF,
};
use crate::integrators::path::{Arrival, BounceNumbers, PathSettings, PathState, ShadowRay};
use crate::lights::{towards, LaneLight};
use crate::render_scene::{RenderScene, Surface};

const N: usize = LANES;

/// A path at a simple diffuse surface: its index, its hit and the surface's material.
/// A lane of the vector bounce: the path and its hit on a simple diffuse instance (whose
/// [`SimpleDiffuse`] the bounce looks up: copying it into every lane cost more).
pub(crate) type SimpleLane = (u32, Hit);
type L = [f32; N];
type L3 = [L; 3];

/// Whether the vector bounce may run in this scene under these settings (per lane it also
/// needs [`RenderScene::simple_diffuse`]).
pub(crate) fn applies(settings: &PathSettings) -> bool {
    settings.nee && settings.bsdf_emission
}

/// `a · b` in glam's order.
#[inline(always)]
fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    (a[0] * b[0]) + (a[1] * b[1]) + (a[2] * b[2])
}

/// Lane `i` of a three-component array.
#[inline(always)]
fn at(v: &L3, i: usize) -> [f32; 3] {
    [v[0][i], v[1][i], v[2][i]]
}

/// `x` if `c`, else `y` (written as a select for the vectoriser).
#[inline(always)]
fn sel(c: bool, x: f32, y: f32) -> f32 {
    if c {
        x
    } else {
        y
    }
}

/// What [`other_light`] needs of a lane's surface.
struct Lane {
    p: [f32; 3],
    ng: [f32; 3],
    ns: [f32; 3],
    wo: [f32; 3],
    albedo: [f32; 3],
}

/// The shadow ray of a lane that picked a light other than a constant emissive triangle, from
/// the scalar path's light sample and connection at the lane's surface. Out of line: inlined,
/// its code made the bounce's light loop ~2 % slower on scenes that never take it.
#[cold]
#[inline(never)]
fn other_light(
    rs: &RenderScene,
    settings: &PathSettings,
    path: &mut PathState,
    hit: Hit,
    lane: &Lane,
    (light, light_point): (f32, Vec2),
) -> Option<ShadowRay> {
    // Only the light's numbers: passing the whole draw kept the compiler computing the
    // lobe number the vector bounce never reads (+3 % instructions on the Cornell box).
    let u = BounceNumbers {
        light,
        light_point,
        ..Default::default()
    };
    let sd = rs.simple_diffuse_ref(hit.instance);
    let uv = rs.simple_uv(sd, &hit);
    let at = Arrival {
        s: Surface {
            p: Vec3::from(lane.p),
            ng: Vec3::from(lane.ng),
            frame: Basis::new(Vec3::from(lane.ns)),
            uv,
            color: Vec3::ONE,
            material: rs.scene.meshes[sd.mesh].material,
            instance: hit.instance,
            triangle: hit.triangle,
            // Simple diffuse materials have one BSDF: the side is never consulted.
            back: false,
        },
        bsdf: Bsdf::Diffuse(Diffuse {
            albedo: Vec3::from(lane.albedo),
        })
        .into(),
        wo: Vec3::from(lane.wo),
    };
    let light = path.sample_light(rs, settings, &at, &u);
    path.connect(rs, settings, &at, light)
}

/// A lane's shading point as the connection to a light reads it.
struct Shading {
    p: [f32; 3],
    ng: [f32; 3],
    ns: [f32; 3],
    /// z of the outgoing direction in the shading frame.
    woz: f32,
    albedo: [f32; 3],
    throughput: [f32; 3],
}

/// A lane's shadow ray towards a light sample and what it carries.
struct LaneShadow {
    origin: [f32; 3],
    dir: [f32; 3],
    tmax: f32,
    contribution: [f32; 3],
    /// The BSDF is zero towards the light: no shadow ray (`connect` returns none).
    f_zero: bool,
}

/// `PathState::connect` for the two-sided diffuse BSDF of a lane: the BSDF towards `wi`, the
/// shadow ray from the offset point to the light point `q` (`finite`) or along `wi` to
/// infinity (a distant light), and the light sample's `weight` times the BSDF and the
/// power-heuristic weight against BSDF sampling (light density `pdf`). The same operations
/// in the same order as the scalar path, for any kind of light sample the lanes draw.
#[inline(always)]
fn connect_lane(
    s: &Shading,
    (q, wi, finite): ([f32; 3], [f32; 3], bool),
    weight: [f32; 3],
    pdf: f32,
    eps: f32,
) -> LaneShadow {
    // Bsdf::eval for a diffuse BSDF, two-sided.
    let wiz = dot(wi, s.ns);
    let flip = s.woz < 0.0;
    let woz = sel(flip, -s.woz, s.woz);
    let wiz = sel(flip, -wiz, wiz);
    let front = !(woz <= 0.0 || wiz <= 0.0);
    let cos_pdf = cosine_pdf(wiz);
    let f = [
        sel(front, s.albedo[0] * cos_pdf, 0.0),
        sel(front, s.albedo[1] * cos_pdf, 0.0),
        sel(front, s.albedo[2] * cos_pdf, 0.0),
    ];
    let origin = offset_point(s.p, s.ng, wi, eps);
    let (sdir, tmax) = shadow_segment(origin, q, wi, eps);
    // Bsdf::pdf: 0 when the viewer is below the (oriented) surface.
    let bsdf_pdf = sel(woz <= 0.0, 0.0, cos_pdf);
    let w = sel(pdf > 0.0, power_heuristic(pdf, bsdf_pdf), 1.0);
    let t = s.throughput;
    LaneShadow {
        origin,
        dir: [
            sel(finite, sdir[0], wi[0]),
            sel(finite, sdir[1], wi[1]),
            sel(finite, sdir[2], wi[2]),
        ],
        tmax: sel(finite, tmax, f32::INFINITY),
        contribution: [
            t[0] * f[0] * weight[0] * w,
            t[1] * f[1] * weight[1] * w,
            t[2] * f[2] * weight[2] * w,
        ],
        f_zero: f[0] == 0.0 && f[1] == 0.0 && f[2] == 0.0,
    }
}

lumo_simd::multiversion! {
    /// Advances the paths `lanes` (at most [`LANES`], every hit on a simple diffuse instance,
    /// [`applies`] true) by one bounce, pushing shadow rays and continuing paths
    /// as [`PathState::advance`] would. One function: split into stages that pass their lanes
    /// in structs, it took a third more instructions (issue 51).
    pub(crate) fn diffuse_bounce(
        rs: &RenderScene,
        settings: &PathSettings,
        paths: &mut [PathState],
        lanes: &[SimpleLane],
        shadows: &mut Vec<(u32, ShadowRay)>,
        next: &mut Vec<u32>,
    ) as bounce, at diffuse_bounce_at {
        let n = lanes.len().min(N);
        let eps = rs.ray_epsilon;

        // Gather: path state and the hit surface (scalar loads).
        // Lanes past `n` keep harmless values; their results are never used.
        let mut o: L3 = [[0.0; N]; 3];
        let mut d: L3 = [[0.0; N]; 3];
        let mut ng: L3 = [[0.0; N]; 3];
        let mut albedo: L3 = [[0.0; N]; 3];
        let mut thr: L3 = [[0.0; N]; 3];
        let mut pos: L3 = [[0.0; N]; 3];
        let mut eta_scale = [1.0f32; N];
        let mut depth = [0u32; N];
        let mut alive = [false; N];
        let mut one_sided = [false; N];
        let (mut bu, mut bv) = ([0.0f32; N], [0.0f32; N]);
        let (mut nv0, mut nv1, mut nv2): (L3, L3, L3) = ([[0.0; N]; 3], [[0.0; N]; 3], [[0.0; N]; 3]);
        let mut interpolate = [false; N];
        // Lanes whose hit `arrive` must record (a first hit wanted, or emission seen): rare, so
        // the record is built only for them, in a second pass once the frame is known.
        let mut records = [false; N];
        for (i, &(p, hit)) in lanes.iter().enumerate().take(n) {
            let sd = rs.simple_diffuse_ref(hit.instance);
            let path = &mut paths[p as usize];
            path.radiance.rays += 1;
            let normal = rs.unit_normal(sd.mesh, hit.triangle);
            if let Some([n0, n1, n2]) = rs.simple_normals(sd, hit.triangle) {
                interpolate[i] = true;
                for a in 0..3 {
                    (nv0[a][i], nv1[a][i], nv2[a][i]) = (n0[a], n1[a], n2[a]);
                }
            }
            bu[i] = hit.u;
            bv[i] = hit.v;
            // Under spectral transport the lanes of a colour are the path's wavelengths.
            // (Textured reflectances are looked up after this loop.)
            let lane_albedo = match &path.wl {
                None => sd.albedo,
                Some(wl) => rs.spectral_reflectance(sd.albedo, rs.scene.meshes[sd.mesh].material, wl),
            };
            for a in 0..3 {
                o[a][i] = path.origin[a];
                d[a][i] = path.dir[a];
                ng[a][i] = normal[a];
                albedo[a][i] = lane_albedo[a];
                thr[a][i] = path.throughput[a];
                // p = origin + dir·t
                pos[a][i] = o[a][i] + d[a][i] * hit.t;
            }
            let seen_front = dot(normal.into(), path.dir.into()) < 0.0;
            records[i] = path.want_first_hit || (seen_front && sd.emission != Vec3::ZERO);
            // The albedo plane's share of this sample: what `take_hit` records on the scalar path
            // (the same value: its BSDF there is this diffuse albedo).
            if path.depth == 1 {
                path.radiance.albedo = sd.albedo;
            }
            eta_scale[i] = path.eta_scale;
            depth[i] = path.depth;
            alive[i] = path.depth < settings.max_depth;
            one_sided[i] = sd.one_sided;
        }

        // Textured reflectances, per lane as the scalar path looks them up. A separate pass, so
        // that the gather above stays as it is for untextured scenes (a lookup in it made the
        // Cornell box 4 % slower).
        if rs.has_textured_simple() {
            for (i, &(p, hit)) in lanes.iter().enumerate().take(n) {
                let sd = rs.simple_diffuse_ref(hit.instance);
                if !sd.textured {
                    continue;
                }
                let path = &mut paths[p as usize];
                let rgb = rs.simple_albedo(sd, &hit);
                let lane_albedo = match &path.wl {
                    None => rgb,
                    Some(wl) => rs.spectral_reflectance(rgb, rs.scene.meshes[sd.mesh].material, wl),
                };
                for a in 0..3 {
                    albedo[a][i] = lane_albedo[a];
                }
                if path.depth == 1 {
                    path.radiance.albedo = rgb;
                }
            }
        }

        // Shading normal (RenderScene::surface: interpolated, normalised, on the side of the
        // geometric normal), its frame (Basis::new) and the outgoing direction in it.
        let mut ns: L3 = [[0.0; N]; 3];
        let (mut fs, mut ft, mut wo) = ([[0.0; N]; 3], [[0.0; N]; 3], [[0.0; N]; 3]);
        for i in 0..N {
            let nv = [at(&nv0, i), at(&nv1, i), at(&nv2, i)];
            let (sn, s_axis, t_axis) =
                shading_frame_lane(nv, (bu[i], bv[i]), at(&ng, i), interpolate[i]);
            for c in 0..3 {
                ns[c][i] = sn[c];
                fs[c][i] = s_axis[c];
                ft[c][i] = t_axis[c];
            }
            let nd = [-d[0][i], -d[1][i], -d[2][i]];
            wo[0][i] = dot(nd, at(&fs, i));
            wo[1][i] = dot(nd, at(&ft, i));
            wo[2][i] = dot(nd, sn);
            // `arrive`: a one-sided surface seen from behind ends the path.
            alive[i] &= !(one_sided[i] && wo[2][i] <= 0.0);
        }

        // What `arrive` records for the hit: the first-hit record, emission seen along the ray.
        for (i, &(p, hit)) in lanes.iter().enumerate().take(n) {
            if !records[i] {
                continue;
            }
            let sd = rs.simple_diffuse_ref(hit.instance);
            let path = &mut paths[p as usize];
            let g = Vec3::new(ng[0][i], ng[1][i], ng[2][i]);
            let le = if g.dot(path.dir) < 0.0 {
                sd.emission
            } else {
                Vec3::ZERO
            };
            if path.want_first_hit || le != Vec3::ZERO {
                let (albedo, uv) = (rs.simple_albedo(sd, &hit), rs.simple_uv(sd, &hit));
                let s = Surface {
                    p: Vec3::new(pos[0][i], pos[1][i], pos[2][i]),
                    ng: g,
                    frame: Basis::new(Vec3::new(ns[0][i], ns[1][i], ns[2][i])),
                    uv,
                    color: Vec3::ONE,
                    material: rs.scene.meshes[sd.mesh].material,
                    instance: hit.instance,
                    triangle: hit.triangle,
                    // Simple diffuse materials have one BSDF: the side is never consulted.
                    back: false,
                };
                let bsdf = Bsdf::Diffuse(Diffuse { albedo });
                path.take_hit(rs, settings, &s, hit.t, &bsdf, le);
            }
        }

        // Random numbers and the light choice (scalar: per-path sampler state, table lookups).
        let (mut u_light2, mut u_dir) = ([[0.0f32; N]; 2], [[0.0f32; N]; 2]);
        let mut u_rr = [0.0f32; N];
        let (mut lp0, mut le1, mut le2, mut ln, mut lrad) = (
            [[0.0f32; N]; 3],
            [[0.0f32; N]; 3],
            [[0.0f32; N]; 3],
            [[0.0f32; N]; 3],
            [[0.0f32; N]; 3],
        );
        let (mut pick, mut area) = ([1.0f32; N], [0.0f32; N]);
        let mut has_light = [false; N];
        // Lanes sampling a sphere light's cone (centre, radius, inward normals) or the
        // constant environment; their radiance goes in `lrad`, their choice in `pick`.
        let (mut is_sphere, mut is_env) = ([false; N], [false; N]);
        let (mut sc, mut srad, mut sflip) = ([[0.0f32; N]; 3], [0.0f32; N], [false; N]);
        for (i, &(p, _)) in lanes.iter().enumerate().take(n) {
            if !alive[i] {
                continue;
            }
            let path = &mut paths[p as usize];
            let u = path.draw();
            u_light2[0][i] = u.light_point.x;
            u_light2[1][i] = u.light_point.y;
            u_dir[0][i] = u.direction.x;
            u_dir[1][i] = u.direction.y;
            u_rr[i] = u.roulette;
            let Some((pk, tri, light)) = rs.lights.choose_triangle(u.light) else {
                let chosen = rs.lights.choose_lane(u.light);
                // A sphere seen from outside and the constant environment are sampled in the
                // lanes below under RGB transport (a spectral path's light weight goes through
                // the light's spectrum, on the scalar path).
                let rgb = path.wl.is_none();
                let sphere = match chosen {
                    LaneLight::Shape(pk, shape) if rgb => {
                        shape.sphere_lane(Vec3::from(at(&pos, i))).map(|s| (pk, s))
                    }
                    _ => None,
                };
                if let Some((pk, sphere)) = sphere {
                    is_sphere[i] = true;
                    pick[i] = pk;
                    sflip[i] = sphere.flip;
                    srad[i] = sphere.radius;
                    for a in 0..3 {
                        sc[a][i] = sphere.center[a];
                        lrad[a][i] = sphere.radiance[a];
                    }
                    continue;
                }
                if let (LaneLight::Environment(pk), true) = (chosen, rgb) {
                    is_env[i] = true;
                    pick[i] = pk;
                    let radiance = rs.lights.constant_radiance();
                    for a in 0..3 {
                        lrad[a][i] = radiance[a];
                    }
                    continue;
                }
                // Another light (a sun, an environment image, a point, spot or other exact
                // shape, a textured emitter): the scalar path's own light sample and
                // connection. Its shadow ray goes first in the list; a path has one per
                // bounce, so the order of the list changes nothing.
                let lane = Lane {
                    p: at(&pos, i),
                    ng: at(&ng, i),
                    ns: at(&ns, i),
                    wo: at(&wo, i),
                    albedo: at(&albedo, i),
                };
                let light_numbers = (u.light, u.light_point);
                if let Some(shadow) = other_light(rs, settings, path, lanes[i].1, &lane, light_numbers)
                {
                    shadows.push((p, shadow));
                }
                continue;
            };
            has_light[i] = true;
            pick[i] = pk;
            area[i] = tri.area;
            for a in 0..3 {
                lp0[a][i] = tri.p0[a];
                le1[a][i] = tri.e1[a];
                le2[a][i] = tri.e2[a];
                ln[a][i] = tri.normal[a];
                lrad[a][i] = tri.radiance[a];
            }
            if let Some(wl) = &path.wl {
                let l = rs.spectral_light(tri.radiance, light, wl);
                for a in 0..3 {
                    lrad[a][i] = l[a];
                }
            }
        }

        // Next-event estimation: a point on the chosen triangle, the BSDF towards it, the shadow
        // ray and its MIS-weighted contribution (Lights::sample, Bsdf::eval/pdf, `connect`).
        let mut sh_ok = [false; N];
        let (mut sh_o, mut sh_d, mut sh_c) = ([[0.0f32; N]; 3], [[0.0f32; N]; 3], [[0.0f32; N]; 3]);
        let mut sh_tmax = [0.0f32; N];
        let shading = |i: usize| Shading {
            p: at(&pos, i),
            ng: at(&ng, i),
            ns: at(&ns, i),
            woz: wo[2][i],
            albedo: at(&albedo, i),
            throughput: at(&thr, i),
        };
        if has_light.contains(&true) {
        for i in 0..N {
            let (bx, by) = triangle_map(u_light2[0][i], u_light2[1][i]);
            let p = at(&pos, i);
            let q = [
                lp0[0][i] + le1[0][i] * bx + le2[0][i] * by,
                lp0[1][i] + le1[1][i] * bx + le2[1][i] * by,
                lp0[2][i] + le1[2][i] * bx + le2[2][i] * by,
            ];
            let dv = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
            let dist2 = dot(dv, dv);
            let distance = dist2.sqrt();
            let inv = 1.0 / distance;
            let wi = [dv[0] * inv, dv[1] * inv, dv[2] * inv];
            let cos = dot(at(&ln, i), [-wi[0], -wi[1], -wi[2]]);
            let (num, den) = (pick[i] * dist2, area[i] * cos);
            let r = den / num;
            let weight = [lrad[0][i] * r, lrad[1][i] * r, lrad[2][i] * r];
            let pdf = num / den;
            let mut ok = alive[i]
                && has_light[i]
                && !(cos <= 0.0 || area[i] <= 0.0)
                && weight[0].is_finite()
                && weight[1].is_finite()
                && weight[2].is_finite();
            let sh = connect_lane(&shading(i), (q, wi, true), weight, pdf, eps);
            ok &= !sh.f_zero;
            for a in 0..3 {
                sh_o[a][i] = sh.origin[a];
                sh_d[a][i] = sh.dir[a];
                sh_c[a][i] = sh.contribution[a];
            }
            sh_tmax[i] = sh.tmax;
            sh_ok[i] = ok;
        }
        }

        // The same for sphere lights (a point of the visible cone, `ShapeLight::sample_from`)
        // and the constant environment (a uniform direction, `EnvironmentLight::sample_from`):
        // each kind's sample where a lane drew one, then one connection for both.
        let (any_sphere, any_env) = (is_sphere.contains(&true), is_env.contains(&true));
        if any_sphere || any_env {
            let (mut gq, mut gwi, mut gw) = ([[0.0f32; N]; 3], [[0.0f32; N]; 3], [[0.0f32; N]; 3]);
            let (mut gpdf, mut gok) = ([0.0f32; N], [false; N]);
            if any_sphere {
                for i in 0..N {
                    let from = at(&pos, i);
                    let u = [u_light2[0][i], u_light2[1][i]];
                    let (q, d, cone_pdf) = cone_point(at(&sc, i), srad[i], from, u);
                    let n = [sel(sflip[i], -d[0], d[0]), sel(sflip[i], -d[1], d[1]), sel(sflip[i], -d[2], d[2])];
                    let ls = towards(q, n, cone_pdf, pick[i], at(&lrad, i), from);
                    for a in 0..3 {
                        gq[a][i] = q[a];
                        gwi[a][i] = ls.wi[a];
                        gw[a][i] = ls.weight[a];
                    }
                    gpdf[i] = ls.pdf;
                    gok[i] = is_sphere[i] && cone_pdf.is_finite() && cone_pdf > 0.0 && ls.ok;
                }
            }
            if any_env {
                for i in 0..N {
                    let wi = uniform_sphere_map(u_light2[0][i], u_light2[1][i]);
                    let pdf = pick[i] * UNIFORM_SPHERE_PDF;
                    let e = is_env[i];
                    for a in 0..3 {
                        gwi[a][i] = sel(e, wi[a], gwi[a][i]);
                        gw[a][i] = sel(e, lrad[a][i] / pdf, gw[a][i]);
                    }
                    gpdf[i] = sel(e, pdf, gpdf[i]);
                    gok[i] = if e { pdf > 0.0 } else { gok[i] };
                }
            }
            for i in 0..N {
                let (wi, weight) = (at(&gwi, i), at(&gw, i));
                let mut ok = alive[i]
                    && gok[i]
                    && weight[0].is_finite()
                    && weight[1].is_finite()
                    && weight[2].is_finite();
                let sh = connect_lane(&shading(i), (at(&gq, i), wi, is_sphere[i]), weight, gpdf[i], eps);
                ok &= !sh.f_zero;
                for a in 0..3 {
                    sh_o[a][i] = sel(ok, sh.origin[a], sh_o[a][i]);
                    sh_d[a][i] = sel(ok, sh.dir[a], sh_d[a][i]);
                    sh_c[a][i] = sel(ok, sh.contribution[a], sh_c[a][i]);
                }
                sh_tmax[i] = sel(ok, sh.tmax, sh_tmax[i]);
                sh_ok[i] |= ok;
            }
        }

        // BSDF sampling (cosine hemisphere by the concentric disk), the continuation ray and
        // Russian roulette (Bsdf::sample, `scatter`).
        let mut goes_on = [false; N];
        let (mut new_o, mut new_d, mut new_thr) =
            ([[0.0f32; N]; 3], [[0.0f32; N]; 3], [[0.0f32; N]; 3]);
        let mut new_pdf = [0.0f32; N];
        for i in 0..N {
            let flip = wo[2][i] < 0.0;
            let woz = sel(flip, -wo[2][i], wo[2][i]);
            let (dx, dy) = disk_map(u_dir[0][i], u_dir[1][i]);
            let z = hemisphere_z(dx, dy);
            let pdf = cosine_pdf(z);
            let wi = [sel(flip, -dx, dx), sel(flip, -dy, dy), sel(flip, -z, z)];
            let mut ok = alive[i] && woz != 0.0 && pdf > 0.0;
            // Basis::to_world, then normalize.
            let w = [
                fs[0][i] * wi[0] + ft[0][i] * wi[1] + ns[0][i] * wi[2],
                fs[1][i] * wi[0] + ft[1][i] * wi[1] + ns[1][i] * wi[2],
                fs[2][i] * wi[0] + ft[2][i] * wi[1] + ns[2][i] * wi[2],
            ];
            let rcp = 1.0 / dot(w, w).sqrt();
            let nd = [w[0] * rcp, w[1] * rcp, w[2] * rcp];
            let g = at(&ng, i);
            let reflect = wi[2] * wo[2][i] > 0.0;
            let geometric = dot(nd, g) * dot([-d[0][i], -d[1][i], -d[2][i]], g) > 0.0;
            ok &= reflect == geometric;
            let mut th = [
                thr[0][i] * albedo[0][i],
                thr[1][i] * albedo[1][i],
                thr[2][i] * albedo[2][i],
            ];
            let p = at(&pos, i);
            let no = offset_point(p, g, nd, eps);
            // Russian roulette (the scalar code's depth test is per lane here).
            let max = vmax(th[0], vmax(th[1], th[2]));
            let q = survival_probability(max, eta_scale[i]);
            let roulette = depth[i] >= settings.rr_depth;
            ok &= !(roulette && u_rr[i] >= q);
            for a in 0..3 {
                th[a] = sel(roulette, th[a] / q, th[a]);
            }
            ok &= !(th[0] == 0.0 && th[1] == 0.0 && th[2] == 0.0);
            for a in 0..3 {
                new_o[a][i] = no[a];
                new_d[a][i] = nd[a];
                new_thr[a][i] = th[a];
            }
            new_pdf[i] = pdf;
            goes_on[i] = ok;
        }

        // Scatter: shadow rays, continuing paths.
        for (i, &(p, _)) in lanes.iter().enumerate().take(n) {
            if sh_ok[i] {
                let path = &mut paths[p as usize];
                path.radiance.rays += 1;
                shadows.push((
                    p,
                    ShadowRay {
                        origin: Vec3::new(sh_o[0][i], sh_o[1][i], sh_o[2][i]),
                        dir: Vec3::new(sh_d[0][i], sh_d[1][i], sh_d[2][i]),
                        tmax: sh_tmax[i],
                        contribution: Vec3::new(sh_c[0][i], sh_c[1][i], sh_c[2][i]),
                        depth: depth[i] + 1,
                    },
                ));
            }
            if goes_on[i] {
                let path = &mut paths[p as usize];
                path.throughput = Vec3::new(new_thr[0][i], new_thr[1][i], new_thr[2][i]);
                path.prev_pdf = Some(new_pdf[i]);
                path.prev_point = Vec3::new(pos[0][i], pos[1][i], pos[2][i]);
                path.origin = Vec3::new(new_o[0][i], new_o[1][i], new_o[2][i]);
                path.dir = Vec3::new(new_d[0][i], new_d[1][i], new_d[2][i]);
                path.depth += 1;
                next.push(p);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::PinholeCamera;
    use crate::sampler::PixelSampler;
    use glam::Vec2;
    use lumo_simd::Isa;

    /// Everything a bounce leaves in a path and its shadow ray, as bits.
    fn bits(path: &PathState, shadow: Option<&ShadowRay>) -> Vec<u32> {
        let f = &path.first_hit;
        let mut v: Vec<u32> = [path.origin, path.dir, path.throughput, path.prev_point]
            .iter()
            .chain([path.radiance.direct, path.radiance.indirect].iter())
            .chain([f.normal, f.position, f.albedo, f.emitted].iter())
            .flat_map(|c| c.to_array())
            .map(f32::to_bits)
            .collect();
        v.extend([path.depth, path.radiance.rays, f.depth.to_bits()]);
        v.push(path.prev_pdf.unwrap_or(-1.0).to_bits());
        if let Some(s) = shadow {
            v.extend(
                [s.origin, s.dir, s.contribution]
                    .iter()
                    .flat_map(|c| c.to_array())
                    .map(f32::to_bits),
            );
            v.extend([s.tmax.to_bits(), s.depth]);
        }
        v
    }

    /// The vector bounce leaves every path, shadow ray and continuation exactly as
    /// `PathState::advance` does, for paths at depths 1–6 (so roulette and the depth limit
    /// are both reached), on the Cornell box (vertex normals, an emitter, one area light).
    /// Compares the shadow rays themselves, which an image only sees through occlusion.
    #[test]
    fn vector_bounce_equals_advance_lane_for_lane() {
        let rs = RenderScene::new(lumo_scene::builtin_scene("cornell").expect("built-in"))
            .expect("valid scene");
        assert!(applies(&lane_settings()));
        check_every_level(&rs, 20);
    }

    /// The same on textured floors: `cornell-spheres`' checkerboard (no uvs, so the
    /// barycentric coordinates index it) and the Cornell box with a bilinear bitmap over
    /// per-vertex uvs, so the vector bounce's per-lane texture lookups are the scalar path's.
    #[test]
    fn vector_bounce_equals_advance_on_textured_floors() {
        use lumo_scene::{BsdfSpec, Texture, TextureFilter, WrapMode};
        use std::sync::Arc;
        let spheres = lumo_scene::builtin_scene("cornell-spheres").expect("built-in");
        let mut bitmap = lumo_scene::builtin_scene("cornell").expect("built-in");
        let texels: Vec<f32> = (0..4 * 4 * 3)
            .map(|i| 0.1 + (i * 7 % 11) as f32 / 14.0)
            .collect();
        let floor = bitmap
            .meshes
            .iter()
            .position(|m| m.name == "floor")
            .expect("the Cornell box has a floor");
        let mesh = &mut bitmap.meshes[floor];
        mesh.uvs = mesh
            .positions
            .iter()
            .map(|p| Vec2::new(p.x, p.z) * 1.7)
            .collect();
        let material = mesh.material;
        bitmap.materials[material].bsdf = BsdfSpec::Diffuse {
            reflectance: Texture::Bitmap {
                image: Arc::new(lumo_image::Image::from_vec(4, 4, 3, texels)),
                uv_scale: Vec2::ONE,
                filter: TextureFilter::Bilinear,
                wrap: WrapMode::Repeat,
            },
        };
        for scene in [spheres, bitmap] {
            let rs = RenderScene::new(scene).expect("valid scene");
            let textured = (0..rs.scene.instances.len() as u32)
                .filter(|&i| rs.is_simple_diffuse(i) && rs.simple_diffuse_ref(i).textured)
                .count();
            assert!(
                textured > 0,
                "{}: no textured simple diffuse instance",
                rs.scene.name
            );
            // Darker floors: fewer paths survive the roulette to the limit.
            check_every_level(&rs, 2);
        }
    }

    /// The same where lanes pick other lights than constant emissive triangles (a point,
    /// a spot, a sun, a constant environment beside the Cornell box's area light): those
    /// lanes' shadow rays come from the scalar light sample, the rest from the lanes.
    #[test]
    fn vector_bounce_equals_advance_with_other_lights() {
        let mut scene = lumo_scene::builtin_scene("cornell").expect("built-in");
        scene
            .lights
            .extend(crate::test_lights::every_other_light_kind());
        let rs = RenderScene::new(scene).expect("valid scene");
        check_every_level(&rs, 20);
    }

    /// The same where lanes pick sphere lights (their cones sampled, connected and weighed in
    /// the lanes: one lamp-sized, one large, one with inward normals, one placed by an instance
    /// transform) beside the Cornell box's area light and a constant environment (its uniform
    /// sample in the lanes too): every lane's shadow ray (direction, distance, contribution)
    /// and continuation must be `advance`'s, bit for bit.
    #[test]
    fn vector_bounce_equals_advance_with_sphere_lights() {
        use crate::test_shapes::{add_exact_sphere, translate_instances};
        use lumo_scene::{Light, Material};
        let mut scene = lumo_scene::builtin_scene("cornell").expect("built-in");
        let spheres = [
            (
                Vec3::new(-0.5, 0.6, 0.2),
                0.03,
                Vec3::new(40.0, 30.0, 20.0),
                false,
            ),
            (
                Vec3::new(0.4, -0.3, -0.4),
                0.25,
                Vec3::new(1.0, 2.0, 3.0),
                false,
            ),
            (
                Vec3::new(0.0, 0.2, 0.0),
                0.1,
                Vec3::new(5.0, 5.0, 5.0),
                true,
            ),
            (
                Vec3::new(0.3, 0.7, -0.1),
                0.05,
                Vec3::new(9.0, 4.0, 2.0),
                false,
            ),
        ];
        for (k, (c, r, emission, flip)) in spheres.into_iter().enumerate() {
            let mut lamp = Material::diffuse("lamp", Vec3::splat(0.5));
            lamp.emission = emission;
            let material = scene.add_material(lamp);
            let mesh = add_exact_sphere(&mut scene, c, r, material, flip);
            if k == 3 {
                translate_instances(&mut scene, mesh, Vec3::new(-0.1, -0.05, 0.02));
            }
        }
        scene.lights.push(Light::Constant {
            radiance: Vec3::new(0.3, 0.2, 0.1),
        });
        let rs = RenderScene::new(scene).expect("valid scene");
        // Both kinds are picked often enough to be walked.
        let (mut cones, mut uniform) = (0, 0);
        for k in 0..1000 {
            match rs.lights.choose_lane((k as f32 + 0.5) / 1000.0) {
                LaneLight::Shape(..) => cones += 1,
                LaneLight::Environment(..) => uniform += 1,
                _ => {}
            }
        }
        assert!(
            cones > 100 && uniform > 20,
            "{cones} sphere, {uniform} environment picks"
        );
        check_every_level(&rs, 20);
    }

    /// What every comparison here walks: depths 1–6 with roulette from depth 3, so the
    /// roulette and the depth limit are both reached.
    fn lane_settings() -> PathSettings {
        PathSettings {
            max_depth: 6,
            rr_depth: 3,
            ..Default::default()
        }
    }

    /// [`check_level`] with [`lane_settings`] at every compiled form this CPU runs (AVX-512,
    /// AVX2, baseline).
    fn check_every_level(rs: &RenderScene, deepest: usize) {
        for level in Isa::detect().up_to() {
            check_level(rs, &lane_settings(), level, deepest);
        }
    }

    /// Walks 32 rows of 16 paths with both bounces at `level`; at least `deepest` bounces must
    /// reach the depth limit.
    fn check_level(rs: &RenderScene, settings: &PathSettings, level: Isa, deepest: usize) {
        let (rs, settings) = (rs, *settings);
        let camera = PinholeCamera::new(&rs.scene.camera, 32, 32);
        let mut checked = [0usize; 7];
        for y in 0..32u32 {
            // Sixteen paths of one row, walked together bounce by bounce.
            let mut paths: Vec<PathState> = (0..16u32)
                .map(|x| {
                    let mut s = PixelSampler::new(2 * x, y, y % 3, 5);
                    let j = s.next_2d();
                    let dir = camera.direction(Vec2::new(2.0 * x as f32, y as f32) + j);
                    PathState::new(camera.origin(), dir, s, x % 5 == 0)
                })
                .collect();
            let mut alive: Vec<u32> = (0..16).collect();
            while !alive.is_empty() {
                let (mut lanes, mut want, mut others) = (vec![], vec![], vec![]);
                for &p in &alive {
                    let path = &paths[p as usize];
                    let hit = rs
                        .accel
                        .intersect(path.origin, path.dir, 0.0, f32::INFINITY);
                    let mut alone = *path;
                    let (shadow, on) = alone.advance(rs, &settings, hit);
                    match hit.filter(|h| rs.is_simple_diffuse(h.instance)) {
                        Some(h) => {
                            lanes.push((p, h));
                            want.push((p, path.depth, alone, shadow, on));
                        }
                        None => {
                            paths[p as usize] = alone;
                            if on {
                                others.push(p);
                            }
                        }
                    }
                }
                let (mut shadows, mut next) = (vec![], vec![]);
                diffuse_bounce_at(
                    level,
                    rs,
                    &settings,
                    &mut paths,
                    &lanes,
                    &mut shadows,
                    &mut next,
                );
                for (p, depth, alone, shadow, on) in want {
                    let got = shadows.iter().find(|s| s.0 == p).map(|s| &s.1);
                    assert_eq!(
                        got.is_some(),
                        shadow.is_some(),
                        "level {level:?} row {y} path {p}"
                    );
                    assert_eq!(next.contains(&p), on, "level {level:?} row {y} path {p}");
                    if on {
                        assert_eq!(
                            bits(&paths[p as usize], got),
                            bits(&alone, shadow.as_ref()),
                            "row {y} path {p}"
                        );
                    }
                    // Ended paths: what they gathered (the state left behind does not matter).
                    assert_eq!(
                        bits(&paths[p as usize], None)[12..33],
                        bits(&alone, None)[12..33],
                        "row {y} path {p}: radiance, first hit, depth or ray count"
                    );
                    checked[depth.min(6) as usize] += 1;
                }
                next.extend(others);
                alive = next;
            }
        }
        assert!(
            checked[1] > 400 && checked[3] > 100 && checked[6] > deepest,
            "level {level:?}: bounces checked per depth: {checked:?}"
        );
    }
}
