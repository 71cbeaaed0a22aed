use glam::{Mat4, Vec2, Vec3};
use lumo_image::luminance;
use lumo_scene::shapes::{cube, rectangle};
use lumo_scene::{builtin_scene, Camera, FovAxis, Light, Material, Scene};

use super::connect::{finish, Pending, Prepared};
use super::mis::{set_camera_ratios, set_light_ratios, weight, Connection};
use super::subpath::{camera_start, camera_subpath, light_start, random_walks};
use super::vertex::{light_vertex, Context, Kind, Vertex};
use super::*;
use crate::{render, render_bdpt, RenderSettings};

/// Mean luminance over `b`×`b` blocks of an RGB image.
fn blocks(img: &lumo_image::Image, b: usize) -> Vec<f32> {
    let (w, h) = (img.width, img.height);
    let mut out = vec![0.0; (w / b) * (h / b)];
    for y in 0..h {
        for x in 0..w {
            let p = img.pixel(x, y);
            out[(y / b) * (w / b) + x / b] += luminance([p[0], p[1], p[2]]) / (b * b) as f32;
        }
    }
    out
}

fn mean(v: &[f32]) -> f32 {
    v.iter().sum::<f32>() / v.len() as f32
}

fn settings(w: usize, spp: u32, max_depth: u32) -> RenderSettings {
    RenderSettings {
        width: w,
        height: w,
        spp,
        seed: 3,
        path: PathSettings {
            max_depth,
            ..Default::default()
        },
    }
}

fn path_traced(rs: &RenderScene, s: &RenderSettings) -> lumo_image::Image {
    render(rs, s, &|_| {}).0.color
}

fn bdpt(rs: &RenderScene, s: &RenderSettings, only: Option<(usize, usize)>) -> lumo_image::Image {
    let b = BdptSettings { path: s.path, only };
    render_bdpt(rs, s, &b, &|_| {}).0
}

/// The path tracer's and BDPT's images of `rs` agree: means within 1 %, 8×8 block means within
/// `block_tolerance` (relative, absolute below 0.05).
fn path_and_bdpt_agree(rs: &RenderScene, s: &RenderSettings, block_tolerance: f32) {
    let (pt, bd) = (
        blocks(&path_traced(rs, s), 8),
        blocks(&bdpt(rs, s, None), 8),
    );
    let (a, b) = (mean(&pt), mean(&bd));
    assert!((a - b).abs() < 0.01 * a, "image means: path {a}, bdpt {b}");
    for (i, (x, y)) in pt.iter().zip(&bd).enumerate() {
        assert!(
            (x - y).abs() < block_tolerance * x.max(0.05),
            "block {i}: path {x}, bdpt {y}"
        );
    }
}

/// The full-path densities of a camera path x_0 … x_n ending on an area light, in both
/// directions, and the weights of all its strategies computed by brute force: the power
/// heuristic over the products of the densities of the strategies that can make the path
/// (no connection at a specular vertex; a density through a specular vertex counts 1). The
/// ratio recursion must give the same weights, and they sum to 1. Paths through the glass
/// sphere of `cornell-spheres` test the specular rules.
#[test]
fn mis_weights_match_brute_force_and_sum_to_one() {
    for (scene, wanted) in [("cornell", 40), ("cornell-spheres", 40)] {
        let (checked, specular) = check_weights_on(scene, wanted);
        assert!(
            checked >= wanted / 2,
            "{scene}: only {checked} paths reached the light"
        );
        if scene == "cornell-spheres" {
            assert!(specular >= 5, "only {specular} paths through the glass");
        }
    }
}

/// Checks up to `wanted` paths of `scene`; returns how many, and how many had a specular vertex.
fn check_weights_on(scene: &str, wanted: usize) -> (usize, usize) {
    let rs = RenderScene::new(builtin_scene(scene).expect("builtin")).expect("scene");
    let camera = PinholeCamera::new(&rs.scene.camera, 16, 16);
    let ctx = Context {
        rs: &rs,
        camera: &camera,
    };
    let (mut checked, mut specular) = (0, 0);
    let mut path = Vec::new();
    for i in 0..20000u32 {
        let mut sampler = PixelSampler::new(i % 16, (i / 16) % 16, i, 5);
        let film = Vec2::new((i % 16) as f32 + 0.5, ((i / 16) % 16) as f32 + 0.5);
        let settings = PathSettings {
            max_depth: 6,
            rr_depth: 100,
            ..Default::default()
        };
        camera_subpath(&ctx, film, &mut sampler, &settings, 7, &mut path);
        // The first vertex (beyond the first hit) on the light: a path of n + 1 vertices.
        let Some(n) = (2..path.len()).find(|&k| path[k].le != Vec3::ZERO) else {
            continue;
        };
        let x = &path[..=n];
        let delta = |k: usize| k != 0 && k != n && x[k].delta;
        let through_glass = (1..n).any(delta);
        if scene == "cornell-spheres" && !through_glass && checked >= wanted / 2 {
            continue;
        }
        let Kind::Surface {
            s: light_surface, ..
        } = x[n].kind
        else {
            continue;
        };
        let index = rs
            .lights
            .light_index(light_surface.instance, light_surface.triangle)
            .expect("an emissive triangle");
        // The light subpath's view of the same vertices: x_n as a light vertex, the others
        // with their outgoing direction towards the light side.
        let towards = (x[n - 1].p - x[n].p).normalize();
        let l0 = light_vertex(&rs.lights, index, x[n].p, x[n].ng, towards, None);
        let as_light = |k: usize| -> Vertex {
            if k == n {
                return l0;
            }
            let mut v = x[k];
            if k > 0 {
                v.set_previous(&x[k + 1]);
            }
            v
        };
        let light_side: Vec<Vertex> = (0..=n).map(as_light).collect();
        // Densities: camera side from x_{k-1} (given x_{k-2}), light side from x_{k+1}.
        let mut p_cam = vec![1.0f32; n + 1];
        for k in 1..=n {
            p_cam[k] = if delta(k - 1) {
                1.0
            } else {
                x[k - 1].pdf(&ctx, k.checked_sub(2).map(|j| &x[j]), &x[k])
            };
        }
        let mut p_light = vec![0.0f32; n + 1];
        p_light[n] = l0.pdf_fwd;
        for k in (1..n).rev() {
            let from = &light_side[k + 1];
            let prev = (k + 2 <= n).then(|| &light_side[k + 2]);
            p_light[k] = if delta(k + 1) {
                1.0
            } else {
                from.pdf(&ctx, prev, &light_side[k])
            };
        }
        // Strategies (s, t) with s + t = n + 1 and t ≥ 1; those that connect at a specular
        // vertex cannot make the path.
        let total = n + 1;
        let possible = |t: usize| t == total || (!delta(t - 1) && !delta(t));
        let density = |t: usize| -> f64 {
            (0..t).map(|k| p_cam[k] as f64).product::<f64>()
                * (t..total).map(|k| p_light[k] as f64).product::<f64>()
        };
        let sum_sq: f64 = (1..=total)
            .filter(|&t| possible(t))
            .map(|t| density(t).powi(2))
            .sum();
        let mut sum_w = 0.0;
        for t in (1..=total).filter(|&t| possible(t)) {
            let s = total - t;
            let mut cam: Vec<Vertex> = x[..t].to_vec();
            for k in 0..t {
                cam[k].pdf_fwd = p_cam[k];
                cam[k].pdf_rev = p_light[k];
            }
            let mut light: Vec<Vertex> = (0..s).map(|j| light_side[n - j]).collect();
            for (j, v) in light.iter_mut().enumerate() {
                v.pdf_fwd = p_light[n - j];
                v.pdf_rev = p_cam[n - j];
            }
            set_camera_ratios(&mut cam);
            set_light_ratios(&mut light);
            let w = weight(
                &ctx,
                &Connection {
                    light: &light,
                    camera: &cam,
                    segment: None,
                },
            );
            let expected = density(t).powi(2) / sum_sq;
            assert!(
                (w as f64 - expected).abs() < 1e-3 * (1.0 + expected),
                "{scene}: path of {total} vertices, strategy ({s}, {t}): ratio form {w}, brute force {expected}"
            );
            sum_w += w as f64;
        }
        assert!(
            (sum_w - 1.0).abs() < 1e-3,
            "{scene}: weights sum to {sum_w}"
        );
        checked += 1;
        specular += through_glass as usize;
        if checked >= wanted {
            break;
        }
    }
    (checked, specular)
}

/// Each strategy alone, unweighted, estimates the paths of its depth: its image matches the
/// path tracer's image of exactly that depth (depth ≤ k minus depth ≤ k − 1).
#[test]
fn every_strategy_alone_is_unbiased() {
    let rs = RenderScene::new(builtin_scene("cornell").expect("builtin")).expect("scene");
    let w = 16;
    let mut reference = Vec::new();
    for depth in 1..=3 {
        let img = path_traced(&rs, &settings(w, 1024, depth));
        reference.push(mean(&blocks(&img, w)));
    }
    for (depth, strategies) in [
        (2usize, vec![(0usize, 3usize), (1, 2), (2, 1)]),
        (3, vec![(0, 4), (1, 3), (2, 2), (3, 1)]),
    ] {
        let expected = reference[depth - 1] - reference[depth - 2];
        for (s, t) in strategies {
            // Hitting the small light by BSDF sampling alone (s = 0) is the noisiest.
            let spp = if s == 0 { 2048 } else { 256 };
            let img = bdpt(&rs, &settings(w, spp, depth as u32), Some((s, t)));
            let got = mean(&blocks(&img, w));
            let tol = if s == 0 { 0.05 } else { 0.03 };
            assert!(
                (got - expected).abs() < tol * expected,
                "strategy ({s}, {t}) of depth {depth}: {got}, path tracer {expected}"
            );
        }
    }
}

/// Weighted together, the strategies converge to the path tracer's image: the Cornell box
/// with a glass and a rough gold sphere.
#[test]
fn converges_to_the_path_tracer() {
    let rs = RenderScene::new(builtin_scene("cornell-spheres").expect("builtin")).expect("scene");
    let w = 32;
    let s = settings(w, 256, 6);
    path_and_bdpt_agree(&rs, &s, 0.08);
}

/// A floor and a box lit by a point light, a spot light, a directional light and a constant
/// environment: the delta lights and the environment through every strategy that can reach
/// them.
fn mixed_lights_scene() -> Scene {
    let mut scene = Scene::empty(Camera {
        origin: Vec3::new(0.0, 2.0, 5.0),
        target: Vec3::new(0.0, 0.3, 0.0),
        up: Vec3::Y,
        fov: 45.0,
        fov_axis: FovAxis::X,
        lens: Default::default(),
        filter: Default::default(),
    });
    let grey = scene.add_material(Material::diffuse("grey", Vec3::splat(0.6)));
    let red = scene.add_material(Material::diffuse("red", Vec3::new(0.7, 0.2, 0.2)));
    let floor =
        Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2) * Mat4::from_scale(Vec3::splat(3.0));
    scene.add_mesh(rectangle(&floor, grey));
    scene.add_mesh(cube(
        &(Mat4::from_translation(Vec3::new(0.3, 0.5, 0.0)) * Mat4::from_scale(Vec3::splat(0.5))),
        red,
    ));
    scene.lights.push(Light::Point {
        position: Vec3::new(-1.0, 2.0, 1.0),
        intensity: Vec3::splat(4.0),
        range: None,
    });
    scene.lights.push(Light::Spot {
        position: Vec3::new(1.5, 2.5, 1.0),
        direction: Vec3::new(-0.5, -1.0, -0.3),
        intensity: Vec3::splat(10.0),
        beam_width: 20.0,
        cutoff: 30.0,
        falloff: Default::default(),
        range: None,
    });
    scene.lights.push(Light::Directional {
        direction: Vec3::new(0.3, -1.0, -0.4),
        irradiance: Vec3::splat(0.8),
    });
    scene.lights.push(Light::Constant {
        radiance: Vec3::splat(0.2),
    });
    scene
}

#[test]
fn delta_lights_and_the_environment_match_the_path_tracer() {
    let rs = RenderScene::new(mixed_lights_scene()).expect("scene");
    let w = 32;
    let s = settings(w, 128, 4);
    path_and_bdpt_agree(&rs, &s, 0.06);
}

/// The image is the same bits on one thread and on two.
#[test]
fn same_bits_on_any_thread_count() {
    let rs = RenderScene::new(builtin_scene("cornell").expect("builtin")).expect("scene");
    let s = settings(24, 4, 5);
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
            .install(|| bdpt(&rs, &s, None))
    };
    let (a, b) = (run(1), run(2));
    assert_eq!(a.data, b.data);
}

/// The subpaths of eight samples on row `y % 32` of a 32² film (sample index `y / 32`),
/// walked together and with their ratios set: camera subpaths at 0..8, light subpaths at
/// 8..16 (for the lane loops' tests).
pub(super) fn walked_group(ctx: &Context, settings: &PathSettings, y: u32) -> Vec<Vec<Vertex>> {
    let max_depth = settings.max_depth as usize;
    let mut walks = vec![None; 16];
    let mut samplers = vec![PixelSampler::new(0, 0, 0, 0); 16];
    let mut paths = vec![Vec::new(); 16];
    let mut max_vertices = vec![0; 16];
    for x in 0..8usize {
        let film = Vec2::new(4.0 * x as f32 + 0.5, (y % 32) as f32 + 0.5);
        walks[x] = camera_start(ctx, film, max_depth + 1, &mut paths[x]);
        samplers[x] = PixelSampler::new(x as u32, y % 32, y / 32, 3);
        max_vertices[x] = max_depth + 1;
        let mut light_sampler = PixelSampler::new(x as u32, y % 32, y / 32, 4);
        walks[8 + x] = light_start(ctx, &mut light_sampler, max_depth, &mut paths[8 + x]);
        samplers[8 + x] = light_sampler;
        max_vertices[8 + x] = max_depth;
    }
    random_walks(
        ctx,
        &mut walks,
        &mut samplers,
        settings,
        &max_vertices,
        &mut paths,
    );
    for (k, p) in paths.iter_mut().enumerate() {
        if k < 8 {
            set_camera_ratios(p);
        } else {
            set_light_ratios(p);
        }
    }
    paths
}

/// The scenes the lane loops' tests run on: the Cornell box (vertex normals, an emitter, one
/// area light), `cornell-spheres` (a checkerboard floor, glass and gold spheres whose vertices
/// stay scalar), the Cornell box with a point, a spot, a directional and an environment
/// light added (light subpaths from delta lights, choices the lanes do not take), and the
/// Cornell box with Lambertian surfaces that the walk takes one at a time but the strategy
/// lanes take ([`scalar_lambertian_cornell`]).
pub(super) fn lane_test_scenes() -> Vec<crate::render_scene::RenderScene> {
    let cornell = builtin_scene("cornell").expect("built-in");
    let spheres = builtin_scene("cornell-spheres").expect("built-in");
    let mut lights = builtin_scene("cornell").expect("built-in");
    lights
        .lights
        .extend(crate::test_lights::every_other_light_kind());
    [cornell, spheres, lights, scalar_lambertian_cornell()]
        .into_iter()
        .map(|s| crate::render_scene::RenderScene::new(s).expect("valid scene"))
        .collect()
}

/// The Cornell box with Lambertian surfaces that are not simple diffuse ones
/// ([`crate::render_scene::RenderScene::is_simple_diffuse`]): the large box with vertex
/// colours, the small box placed by an instance transform and an analytic sphere. Their
/// vertices come from the scalar walk step, and the strategy lanes then take them like any
/// other Lambertian vertex.
fn scalar_lambertian_cornell() -> Scene {
    let mut scene = builtin_scene("cornell").expect("built-in");
    scene.name = SCALAR_LAMBERTIAN.into();
    let large = scene.meshes.iter().position(|m| m.name == "large-box");
    let small = scene.meshes.iter().position(|m| m.name == "small-box");
    let (Some(large), Some(small)) = (large, small) else {
        panic!("the Cornell box has lost its boxes");
    };
    let colours = scene.meshes[large].positions.len();
    scene.meshes[large].colors = (0..colours)
        .map(|i| Vec3::new(0.5 + 0.1 * (i % 5) as f32, 0.9, 0.4 + 0.15 * (i % 3) as f32))
        .collect();
    for inst in scene.instances.iter_mut().filter(|i| i.mesh == small) {
        inst.transform = Mat4::from_translation(Vec3::new(0.0, 0.0, -0.1));
    }
    let white = scene.meshes[small].material;
    let placed =
        Mat4::from_translation(Vec3::new(0.4, -0.75, -0.4)) * Mat4::from_scale(Vec3::splat(0.25));
    let mut ball = lumo_scene::shapes::sphere(&placed, white, 12, 24);
    ball.name = "analytic-ball".into();
    ball.analytic = Some(lumo_scene::Analytic {
        kind: lumo_scene::AnalyticKind::Sphere,
        to_mesh: placed,
        flip_normals: false,
    });
    scene.add_mesh(ball);
    scene
}

/// The name of [`scalar_lambertian_cornell`]'s scene.
const SCALAR_LAMBERTIAN: &str = "cornell-scalar-lambertian";

/// Whether `v` lies on an instance that is not a simple diffuse surface (the scalar walk
/// step made it).
pub(super) fn scalar_made(rs: &crate::render_scene::RenderScene, v: &Vertex) -> bool {
    matches!(v.kind, Kind::Surface { ref s, .. } if !rs.is_simple_diffuse(s.instance))
}

/// Asserts, on [`scalar_lambertian_cornell`]'s scene, that a lane test compared enough
/// strategies with an added value at a vertex the scalar walk step made (`count`).
pub(super) fn assert_scalar_made_covered(ctx: &Context, count: usize, what: &str) {
    if ctx.rs.scene.name == SCALAR_LAMBERTIAN {
        assert!(
            count > 20,
            "{SCALAR_LAMBERTIAN}: only {count} {what} at vertices of the scalar walk step"
        );
    }
}

/// The path settings of the lane loops' tests: short paths that reach both Russian roulette
/// and the depth limit.
pub(super) const LANE_TEST_SETTINGS: PathSettings = PathSettings {
    max_depth: 6,
    rr_depth: 3,
    nee: true,
    bsdf_emission: true,
    spectral: false,
};

/// Asserts that the pending entry `got` a lane loop made for a strategy of `light` and
/// `camera` is the one `connect::prepare` made (`want`; the lanes' weight, and what only the
/// scalar weight reads, left out), and that both weigh to the same contribution
/// (`connect::finish`). Returns whether the strategy adds anything.
pub(super) fn assert_same_strategy(
    ctx: &Context,
    (light, camera): (&[Vertex], &[Vertex]),
    got: Pending,
    want: Prepared,
    at: &str,
) -> bool {
    let Prepared::Pending(want) = want else {
        assert_eq!(got.s, 0, "{at}: the scalar strategy adds nothing");
        return false;
    };
    // The lanes carry the weight itself instead of what the scalar weight reads.
    let mut plain = got;
    plain.segment = want.segment;
    plain.weight = None;
    plain.nee = want.nee;
    assert_eq!(format!("{plain:?}"), format!("{want:?}"), "{at}");
    let weighed = |p: &Pending| format!("{:?}", finish(ctx, light, camera, p, false));
    assert_eq!(weighed(&got), weighed(&want), "{at}: weighted");
    true
}

/// Runs `check` on every lane test scene ([`lane_test_scenes`]) with its camera at 32², at
/// every instruction set the CPU runs (AVX-512, AVX2, baseline).
pub(super) fn for_each_lane_case(check: impl Fn(&Context, lumo_simd::Isa)) {
    for rs in lane_test_scenes() {
        let camera = crate::camera::PinholeCamera::new(&rs.scene.camera, 32, 32);
        let ctx = Context {
            rs: &rs,
            camera: &camera,
        };
        for level in lumo_simd::Isa::detect().up_to() {
            check(&ctx, level);
        }
    }
}
