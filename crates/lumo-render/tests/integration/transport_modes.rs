//! Light paths carry importance, camera paths radiance: through a refraction the two scale
//! differently (radiance by 1/η² into the denser medium, importance not at all). With a camera
//! inside glass below a single glass–air interface and the light above it, the light tracer
//! must still agree with the path tracer; had it used the radiance weights it would be dark by
//! 1/η² = 0.44.

use std::path::Path;

use lumo_render::camera::PinholeCamera;
use lumo_render::integrators::light::trace_light_path;
use lumo_render::sampler::PixelSampler;
use lumo_render::{render, PathSettings, RenderScene, RenderSettings};
use lumo_scene::load::{load_mitsuba_str, LoadOptions};

const SCENE: &str = r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="50"/>
    <transform name="to_world"><lookat origin="0,0.6,0" target="0,0,0" up="0,0,1"/></transform>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="-90"/><scale value="5"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.7"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="-90"/><scale value="5"/><translate y="1"/></transform>
    <bsdf type="dielectric"><float name="int_ior" value="1.5"/><float name="ext_ior" value="1"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="90"/><scale value="3"/><translate y="1.5"/></transform>
    <emitter type="area"><rgb name="radiance" value="2"/></emitter>
  </shape>
</scene>"#;

#[test]
fn light_tracer_agrees_with_the_path_tracer_through_one_refraction() {
    let loaded = load_mitsuba_str(SCENE, Path::new("t.xml"), &LoadOptions::default()).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let scene = loaded.scene;
    let rs = RenderScene::new(scene.clone()).unwrap();
    let (w, h) = (16usize, 16usize);
    let settings = RenderSettings {
        width: w,
        height: h,
        spp: 4096,
        seed: 5,
        path: PathSettings {
            max_depth: 4,
            ..Default::default()
        },
    };
    let image = render(&rs, &settings, &|_| {}).0.color;
    let path: f64 = image.data.iter().map(|&v| v as f64).sum::<f64>() / 3.0;
    let camera = PinholeCamera::new(&scene.camera, w, h);
    let paths = 400_000u32;
    let mut light = 0.0f64;
    for m in 0..paths {
        let mut sampler = PixelSampler::new(1 << 20, m >> 16, m & 0xffff, 13);
        trace_light_path(&rs, &camera, &mut sampler, &settings.path, &mut |s| {
            light += s.value.to_array().iter().map(|&v| v as f64).sum::<f64>() / 3.0;
        });
    }
    light /= paths as f64;
    assert!(
        path > 0.0,
        "the path tracer finds the light through the glass"
    );
    assert!(
        (light / path - 1.0).abs() < 0.05,
        "light tracer {light:.4} vs path tracer {path:.4} (ratio {:.3})",
        light / path
    );
}
