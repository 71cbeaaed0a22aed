//! Area lights whose radiance is a texture (Mitsuba's `radiance` given as a `<texture>`): the
//! light tracer, which starts paths on the light, agrees with the path tracer, which finds the
//! light by next-event estimation and by hitting it, channel by channel; exact shapes, where
//! lumo does not support it, keep the average with a warning. (The Mitsuba suite's
//! `emission_texture` scene checks the image against Mitsuba 3.)

use std::path::Path;

use lumo_render::camera::PinholeCamera;
use lumo_render::integrators::light::trace_light_path;
use lumo_render::sampler::PixelSampler;
use lumo_render::{render, PathSettings, RenderScene, RenderSettings};
use lumo_scene::load::{load_mitsuba_str, LoadOptions};

const SCENE: &str = r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="60"/>
    <transform name="to_world"><lookat origin="0,0.5,2.6" target="0,0.45,0" up="0,1,0"/></transform>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="-90"/><scale value="3"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.8"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="90"/><scale x="0.9" y="0.6" z="1"/><translate y="1.1" z="-0.3"/></transform>
    <emitter type="area">
      <texture type="checkerboard" name="radiance">
        <rgb name="color0" value="6, 0.5, 0.2"/><rgb name="color1" value="0.2, 1, 5"/>
        <transform name="to_uv"><scale x="1" y="0.5"/></transform>
      </texture>
    </emitter>
  </shape>
</scene>"#;

#[test]
fn light_tracer_and_path_tracer_agree_on_a_textured_area_light() {
    let loaded = load_mitsuba_str(SCENE, Path::new("t.xml"), &LoadOptions::default()).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let scene = loaded.scene;
    assert!(scene.materials.iter().any(|m| m.emission_map.is_some()));
    let rs = RenderScene::new(scene.clone()).unwrap();
    let (w, h) = (32usize, 32usize);
    let settings = RenderSettings {
        width: w,
        height: h,
        spp: 1024,
        seed: 3,
        path: PathSettings {
            max_depth: 3,
            ..Default::default()
        },
    };
    // Per half of the image (left, right) and channel: the checkerboard's two colours sit
    // on the two halves of the light, so a tracer that read the light as its average would
    // tint the halves of the floor alike and miss the other's red/blue split.
    let image = render(&rs, &settings, &|_| {}).0.color;
    let mut path = [[0.0f64; 3]; 2];
    for y in 0..h {
        for x in 0..w {
            for (c, v) in image.pixel(x, y).iter().take(3).enumerate() {
                path[usize::from(x >= w / 2)][c] += *v as f64;
            }
        }
    }
    let film = PinholeCamera::new(&scene.camera, w, h);
    let mut light = [[0.0f64; 3]; 2];
    let paths = 400_000u32;
    for m in 0..paths {
        let mut sampler = PixelSampler::new(1 << 20, m >> 16, m & 0xffff, 11);
        trace_light_path(&rs, &film, &mut sampler, &settings.path, &mut |s| {
            let half = usize::from(s.film.x >= (w / 2) as f32);
            for (t, v) in light[half].iter_mut().zip(s.value.to_array()) {
                *t += v as f64 / paths as f64;
            }
        });
    }
    for half in 0..2 {
        for c in [0, 2] {
            let (l, p) = (light[half][c], path[half][c]);
            assert!(
                (l - p).abs() < 0.05 * p,
                "half {half}, channel {c}: light tracer {l:.3} vs path tracer {p:.3}"
            );
        }
    }
}

#[test]
fn a_textured_light_on_an_exact_shape_keeps_its_average_with_a_warning() {
    let text = r#"<scene version="3.0.0">
  <sensor type="perspective"><transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform></sensor>
  <shape type="sphere"><emitter type="area">
    <texture type="checkerboard" name="radiance"><rgb name="color0" value="2"/><rgb name="color1" value="4"/></texture>
  </emitter></shape>
</scene>"#;
    let loaded = load_mitsuba_str(text, Path::new("s.xml"), &LoadOptions::default()).unwrap();
    assert_eq!(loaded.warnings.len(), 1, "{:?}", loaded.warnings);
    let w = loaded.warnings[0].to_string();
    assert!(w.contains("sphere") && w.contains("average"), "{w}");
    let m = &loaded.scene.materials[loaded.scene.meshes[0].material];
    assert!(m.emission_map.is_none());
    assert_eq!(m.emission, lumo_scene::Vec3::splat(3.0));
}
