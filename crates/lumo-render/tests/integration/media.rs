//! Participating media: furnaces (albedo-1 media in a uniform environment must show exactly
//! the environment, whatever the medium, its boundary or the glass around it), Beer–Lambert
//! through a slab, and the null boundary's invisibility.

use std::path::Path;

use glam::Vec3;
use lumo_render::{render, PathSettings, RenderScene, RenderSettings};
use lumo_scene::load::{load_mitsuba_str, LoadOptions};
use lumo_scene::Scene;

/// A Mitsuba scene: a camera at z = 4 looking at the origin (`fov` degrees), a constant
/// environment of radiance `env`, and `shapes`.
fn scene_xml(fov: f32, env: &str, shapes: &str) -> Scene {
    let xml = format!(
        r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="{fov}"/>
    <transform name="to_world"><lookat origin="0,0,4" target="0,0,0" up="0,1,0"/></transform>
  </sensor>
  <emitter type="constant"><rgb name="radiance" value="{env}"/></emitter>
  {shapes}
</scene>"#
    );
    load_mitsuba_str(&xml, Path::new("media-test.xml"), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .scene
}

fn mean_color(scene: &Scene, size: usize, spp: u32, spectral: bool) -> Vec3 {
    let rs = RenderScene::new(scene.clone()).unwrap();
    let settings = RenderSettings {
        width: size,
        height: size,
        spp,
        seed: 3,
        path: PathSettings {
            max_depth: lumo_scene::DEPTH_LIMIT,
            rr_depth: 5,
            spectral,
            ..Default::default()
        },
    };
    let m = render(&rs, &settings, &|_| {}).0.color.channel_means();
    Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32)
}

/// A unit sphere of `bsdf` holding `medium` as its interior.
fn sphere_with(bsdf: &str, medium: &str) -> String {
    format!(
        r#"<shape type="sphere"><float name="radius" value="1"/>{bsdf}
  <medium type="homogeneous" name="interior">{medium}</medium></shape>"#
    )
}

fn assert_close(got: Vec3, want: Vec3, tol: f32, what: &str) {
    let rel = ((got - want) / want).abs().max_element();
    assert!(
        rel < tol,
        "{what}: got {got}, expected {want} (off by {:.2} %)",
        rel * 100.0
    );
}

#[test]
fn albedo_one_media_in_a_uniform_environment_show_the_environment() {
    let env = Vec3::new(1.0, 0.6, 0.3);
    let null = r#"<bsdf type="null"/>"#;
    let cases = [
        (
            "isotropic",
            sphere_with(
                null,
                r#"<float name="sigma_t" value="2"/><float name="albedo" value="1"/>"#,
            ),
        ),
        (
            "hg 0.7",
            sphere_with(
                null,
                r#"<float name="sigma_t" value="3"/><float name="albedo" value="1"/><phase type="hg"><float name="g" value="0.7"/></phase>"#,
            ),
        ),
        (
            "chromatic",
            sphere_with(
                null,
                r#"<rgb name="sigma_t" value="0.5, 2, 6"/><float name="albedo" value="1"/>"#,
            ),
        ),
        (
            "inside glass",
            sphere_with(
                r#"<bsdf type="dielectric"><float name="int_ior" value="1.5"/></bsdf>"#,
                r#"<float name="sigma_t" value="2"/><float name="albedo" value="1"/>"#,
            ),
        ),
    ];
    for (what, shapes) in &cases {
        let scene = scene_xml(40.0, "1, 0.6, 0.3", shapes);
        assert!(scene.media.is_active());
        assert_close(mean_color(&scene, 12, 128, false), env, 0.01, what);
    }
}

#[test]
fn spectral_transport_keeps_the_medium_furnace() {
    let shapes = sphere_with(
        r#"<bsdf type="null"/>"#,
        r#"<rgb name="sigma_t" value="1, 2, 3"/><float name="albedo" value="1"/>"#,
    );
    let scene = scene_xml(40.0, "0.5", &shapes);
    assert_close(
        mean_color(&scene, 12, 96, true),
        Vec3::splat(0.5),
        0.02,
        "spectral",
    );
}

#[test]
fn an_absorbing_slab_transmits_beer_lambert() {
    // A cube [-1, 1]³ seen straight through (a 1° field of view): every ray crosses 2 units.
    let sigma = Vec3::new(0.25, 0.5, 1.0);
    let shapes = r#"<shape type="cube"><bsdf type="null"/>
  <medium type="homogeneous" name="interior"><rgb name="sigma_t" value="0.25, 0.5, 1"/>
  <float name="albedo" value="0"/></medium></shape>"#;
    let scene = scene_xml(1.0, "1", shapes);
    let want = (-sigma * 2.0).exp();
    assert_close(mean_color(&scene, 4, 64, false), want, 0.005, "slab");
}

#[test]
fn null_boundaries_without_media_are_invisible() {
    let room = r#"<shape type="rectangle"><transform name="to_world"><scale value="3"/><translate z="-1.5"/></transform>
  <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.5, 0.3"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/><scale value="3"/><translate y="-1.2"/></transform>
  <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="90"/><scale value="0.5"/><translate y="1.4"/></transform>
  <emitter type="area"><rgb name="radiance" value="10"/></emitter></shape>"#;
    let plain = scene_xml(50.0, "0.1", room);
    let a = mean_color(&plain, 16, 64, false);
    // A sphere, and a box whose top lies just below the light (shadow rays cross it at
    // grazing angles a few hundredths before they reach the light).
    for ghost in [
        r#"<shape type="sphere"><float name="radius" value="0.8"/><bsdf type="null"/></shape>"#,
        r#"<shape type="cube"><transform name="to_world"><scale x="1" y="1.2" z="1"/><translate y="0.15"/></transform><bsdf type="null"/></shape>"#,
    ] {
        let scene = scene_xml(50.0, "0.1", &format!("{room}{ghost}"));
        assert!(!plain.media.is_active() && scene.media.is_active());
        assert_close(mean_color(&scene, 16, 64, false), a, 0.01, ghost);
    }
}
