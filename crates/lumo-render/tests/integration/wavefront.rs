//! The wavefront renderer (rays of many paths traced in packets) against the one-ray-at-a-time
//! integrator: every pixel's estimate, G-buffer record and ray count must agree bit for bit on
//! every built-in scene, at several spp (packets of one pixel's samples and of many pixels').

use lumo_render::camera::PinholeCamera;
use lumo_render::integrators::path::wavefront::render_pixels;
use lumo_render::{render_pixel_one_ray, PathSettings, RenderScene, RenderSettings};

#[test]
fn wavefront_equals_one_ray_at_a_time_on_every_builtin_scene() {
    // The built-in scenes, and the Cornell box with one instance moved off the identity (a
    // two-level tree: packets go ray by ray, that instance's hits take the scalar bounce).
    let mut scenes: Vec<(String, lumo_scene::Scene)> = lumo_scene::BUILTIN_SCENES
        .iter()
        .map(|info| (info.name.to_string(), (info.build)()))
        .collect();
    let mut moved = lumo_scene::builtin_scene("cornell").expect("built-in");
    let last = moved.instances.len() - 1;
    moved.instances[last].transform =
        glam::Mat4::from_translation(glam::Vec3::new(0.05, 0.0, 0.02));
    scenes.push(("cornell, one instance moved".into(), moved));
    // The Cornell box with an exact (non-emissive) sphere: triangle lights, so the vector
    // bounce runs, while packets go ray by ray through the sphere's placement.
    let mut with_ball = lumo_scene::builtin_scene("cornell").expect("built-in");
    let (lo, hi) = with_ball.bounds();
    let to_mesh = glam::Mat4::from_translation((lo + hi) * 0.5)
        * glam::Mat4::from_scale(glam::Vec3::splat((hi - lo).min_element() * 0.2));
    let mut ball = lumo_scene::shapes::sphere(&to_mesh, 0, 8, 16);
    ball.analytic = Some(lumo_scene::Analytic {
        kind: lumo_scene::AnalyticKind::Sphere,
        to_mesh,
        flip_normals: false,
    });
    with_ball.add_mesh(ball);
    scenes.push(("cornell with an exact sphere".into(), with_ball));
    // Exact spheres, disks and cylinders (leaves of the instance tree), with disk and sphere
    // area lights: the vector bounce stands aside, packets go ray by ray.
    for name in ["analytic_shapes", "sphere_limb_closeup"] {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/data/mitsuba/scenes")
            .join(format!("{name}.xml"));
        let text = std::fs::read_to_string(&path).expect("suite scene");
        let loaded = lumo_scene::load::load_mitsuba_str(
            &text,
            &path,
            &lumo_scene::load::LoadOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        scenes.push((name.into(), loaded.scene));
    }
    for (name, scene) in scenes {
        let rs = RenderScene::new(scene).expect("valid scene");
        // Both sides of the surface prefetch (a hint that must not change a bit) are covered.
        match name.as_str() {
            "atrium" => assert!(rs.prefetches_surfaces(), "the atrium's meshes are large"),
            "cornell" => assert!(!rs.prefetches_surfaces(), "the Cornell box fits the cache"),
            _ => {}
        }
        for spp in [1u32, 3, 16] {
            let settings = RenderSettings {
                width: 24,
                height: 18,
                spp,
                seed: 7,
                path: PathSettings {
                    max_depth: 6,
                    rr_depth: 3,
                    ..Default::default()
                },
            };
            let camera = PinholeCamera::new(&rs.scene.camera, settings.width, settings.height);
            let mut nonzero = 0;
            for y in 0..settings.height {
                let row = render_pixels(&rs, &camera, &settings, y, 0..settings.width);
                assert_eq!(row.len(), settings.width);
                for (x, got) in row.iter().enumerate() {
                    let want = render_pixel_one_ray(&rs, &camera, &settings, x, y);
                    assert_eq!(
                        estimate_bits(got),
                        estimate_bits(&want),
                        "{name} spp {spp} pixel ({x}, {y})"
                    );
                    nonzero += (got.direct + got.indirect != glam::Vec3::ZERO) as usize;
                }
            }
            assert!(nonzero > 50, "{name}: only {nonzero} lit pixels");
        }
    }
}

/// The albedo plane is the mean of the pixel's samples' first-hit albedos (the colour averages
/// the same samples), not the pixel-centre sample's: where a pixel straddles the Cornell box's
/// walls their albedos mix. The other G-buffer planes stay the centre ray's.
#[test]
fn the_albedo_plane_averages_the_pixels_samples() {
    let scene = lumo_scene::builtin_scene("cornell").expect("built-in");
    let rs = RenderScene::new(scene).expect("scene");
    let (w, h, spp) = (24, 24, 8);
    let settings = RenderSettings {
        width: w,
        height: h,
        spp,
        seed: 3,
        path: PathSettings::default(),
    };
    let camera = PinholeCamera::new(&rs.scene.camera, w, h);
    let mut mixed = 0;
    for y in 0..h {
        let row = render_pixels(&rs, &camera, &settings, y, 0..w);
        for (x, e) in row.iter().enumerate() {
            let albedos: Vec<glam::Vec3> = (0..spp)
                .map(|i| {
                    lumo_render::trace_sample(&rs, &camera, &settings, (x, y), i, None)
                        .0
                        .albedo
                })
                .collect();
            let mean = albedos
                .iter()
                .fold(glam::DVec3::ZERO, |s, a| s + a.as_dvec3())
                / spp as f64;
            assert_eq!(e.first_hit.albedo, mean.as_vec3(), "pixel ({x}, {y})");
            if albedos.iter().any(|a| *a != albedos[0]) {
                mixed += 1;
                assert_ne!(e.first_hit.albedo, albedos[0], "pixel ({x}, {y})");
            }
        }
    }
    assert!(mixed > 10, "only {mixed} pixels straddle an edge");
}

/// Paths a caller starts itself ([`trace_paths`], as the temporal filter's re-shading does: its
/// own origins, directions and samplers) end as each traced alone ([`trace_path`]) would:
/// radiance, first hit and ray count bit for bit, on a scene with diffuse surfaces (the vector
/// bounce) and on one with glossy and glass ones (the scalar bounce).
#[test]
fn trace_paths_equals_trace_path() {
    use lumo_render::integrators::path::wavefront::trace_paths;
    use lumo_render::integrators::path::PathState;
    use lumo_render::sampler::PixelSampler;
    use lumo_render::{trace_path, FirstHit};
    for name in ["cornell", "cornell-spheres"] {
        let rs = RenderScene::new(lumo_scene::builtin_scene(name).expect("built-in"))
            .expect("valid scene");
        let path = PathSettings::default();
        let (w, h) = (21, 13);
        let camera = PinholeCamera::new(&rs.scene.camera, w, h);
        let start = |k: usize| {
            let (x, y) = (k % w, k / w);
            // An odd direction per path (not the pixel centre), as re-shading's are.
            let p = glam::Vec2::new(x as f32 + 0.3, y as f32 + 0.7);
            let sampler = PixelSampler::new(x as u32, y as u32, 0, 11);
            (camera.origin(), camera.direction(p), sampler)
        };
        let mut paths: Vec<PathState> = (0..w * h)
            .map(|k| {
                let (o, d, s) = start(k);
                PathState::new(o, d, s, true).spectral(path.spectral)
            })
            .collect();
        trace_paths(&rs, &path, &mut paths);
        assert_eq!(paths.len(), w * h);
        let bits = |v: glam::Vec3| v.to_array().map(f32::to_bits);
        let mut lit = 0;
        for (k, got) in paths.iter().enumerate() {
            let (o, d, mut s) = start(k);
            let mut first = FirstHit::default();
            let want = trace_path(&rs, o, d, &mut s, &path, Some(&mut first));
            let r = got.result();
            assert_eq!(bits(r.direct), bits(want.direct), "{name} path {k}");
            assert_eq!(bits(r.indirect), bits(want.indirect), "{name} path {k}");
            assert_eq!(r.rays, want.rays, "{name} path {k}");
            let f = &got.first_hit;
            assert_eq!(bits(f.position), bits(first.position), "{name} path {k}");
            assert_eq!(f.depth.to_bits(), first.depth.to_bits(), "{name} path {k}");
            lit += usize::from(want.indirect != glam::Vec3::ZERO);
        }
        // Not a trivial comparison: a good share of the paths bounce and gather light (about
        // a third on the Cornell box at its default depth 5 with Russian roulette).
        assert!(lit > w * h / 5, "{name}: {lit} paths carry indirect light");
    }
}

/// The whole-frame loop that writes estimates in place ([`lumo_render::render_estimates`],
/// the temporal sequence's trace) gives every pixel the bits the exact sums give
/// ([`lumo_render::render_sums`], then [`lumo_render::PixelSums::estimate`]), at one sample
/// per pixel and at several, on a frame whose width is not a multiple of a batch.
#[test]
fn render_estimates_equals_the_sums_estimates() {
    let scene = lumo_scene::builtin_scene("cornell").expect("built-in");
    let rs = RenderScene::new(scene).expect("scene");
    for spp in [1u32, 3] {
        let settings = RenderSettings {
            width: 37,
            height: 11,
            spp,
            seed: 5,
            path: PathSettings::default(),
        };
        let got = lumo_render::render_estimates(&rs, &settings, &|_| {});
        let want: Vec<_> = lumo_render::render_sums(&rs, &settings, 0, spp, &|_| {})
            .iter()
            .map(lumo_render::PixelSums::estimate)
            .collect();
        assert_eq!(got.len(), want.len());
        let mut lit = 0;
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert_eq!(estimate_bits(g), estimate_bits(w), "spp {spp} pixel {i}");
            lit += (g.direct + g.indirect != glam::Vec3::ZERO) as usize;
        }
        assert!(lit > 50, "only {lit} lit pixels");
    }
}

/// Every field of a pixel estimate as bits, for bit-for-bit comparisons.
fn estimate_bits(e: &lumo_render::PixelEstimate) -> Vec<u32> {
    let f = &e.first_hit;
    let mut v: Vec<u32> = [e.direct, e.indirect, e.emitted, f.normal, f.position]
        .iter()
        .chain([f.albedo, f.emitted].iter())
        .flat_map(|c| c.to_array())
        .map(f32::to_bits)
        .collect();
    v.extend([e.luminance_variance.to_bits(), f.depth.to_bits()]);
    v.push(e.rays as u32);
    v
}
