//! The wavefront renderer (rays of many paths traced in packets) against the one-ray-at-a-time
//! integrator: every pixel's estimate, G-buffer record and ray count must agree bit for bit on
//! every built-in scene, at several spp (packets of one pixel's samples and of many pixels').

use lumo_render::camera::CameraRays;
use lumo_render::wavefront::render_pixels;
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
    for (name, scene) in scenes {
        let rs = RenderScene::new(scene).expect("valid scene");
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
            let camera = CameraRays::new(&rs.scene.camera, settings.width, settings.height);
            let mut nonzero = 0;
            for y in 0..settings.height {
                let row = render_pixels(&rs, &camera, &settings, y, 0..settings.width);
                assert_eq!(row.len(), settings.width);
                for (x, got) in row.iter().enumerate() {
                    let want = render_pixel_one_ray(&rs, &camera, &settings, x, y);
                    let key = |e: &lumo_render::PixelEstimate| {
                        let f = &e.first_hit;
                        let mut v: Vec<u32> = [e.direct, e.indirect, f.normal, f.position]
                            .iter()
                            .chain([f.albedo, f.emitted].iter())
                            .flat_map(|c| c.to_array())
                            .map(f32::to_bits)
                            .collect();
                        v.extend([e.luminance_variance.to_bits(), f.depth.to_bits()]);
                        v.push(e.rays as u32);
                        v
                    };
                    assert_eq!(key(got), key(&want), "{name} spp {spp} pixel ({x}, {y})");
                    nonzero += (got.direct + got.indirect != glam::Vec3::ZERO) as usize;
                }
            }
            assert!(nonzero > 50, "{name}: only {nonzero} lit pixels");
        }
    }
}
