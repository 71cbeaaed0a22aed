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

/// A wall at z = −1 behind a box of fog (a null cube, z from −0.5 to 1.5) seen from z = 4:
/// pixels whose centre ray scatters in the fog record the wall behind it in the G-buffer
/// (normal, depth from the camera), not the random scattering point, so the depth plane of a
/// dense fog bank is as smooth as the wall's (docs/media.md, "AOVs of a pixel in fog"); and
/// the wall seen through the clear box has its depth from the camera, not from the box's
/// faces.
#[test]
fn fog_pixels_record_the_surface_behind_the_fog() {
    let wall = r#"<shape type="rectangle"><transform name="to_world"><scale value="3"/><translate z="-1"/></transform>
  <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>"#;
    let fog = |sigma: f32| {
        format!(
            r#"<shape type="cube"><transform name="to_world"><translate z="0.5"/></transform><bsdf type="null"/>
  <medium type="homogeneous" name="interior"><float name="sigma_t" value="{sigma}"/>
  <rgb name="albedo" value="0.8"/></medium></shape>"#
        )
    };
    let gbuffer = |sigma: f32| {
        let scene = scene_xml(20.0, "0.5", &format!("{wall}{}", fog(sigma)));
        let rs = RenderScene::new(scene).unwrap();
        let settings = RenderSettings {
            width: 16,
            height: 16,
            spp: 1,
            seed: 1,
            path: PathSettings::default(),
        };
        render(&rs, &settings, &|_| {}).0
    };
    // σ_t 40: nearly every centre ray scatters in the fog. σ_t 1e-4: almost none does, so
    // that frame's G-buffer is the wall's, seen through the null boundary.
    let (dense, clear) = (gbuffer(40.0), gbuffer(1e-4));
    // The fog's albedo shows where the centre ray scattered.
    let scattered = dense
        .albedo
        .data
        .chunks(3)
        .filter(|a| (a[0] - 0.8).abs() < 1e-6)
        .count();
    assert!(scattered > 200, "{scattered} of 256 centre rays scattered");
    // Two centre rays of this frame pass exactly through the wall's diagonal and slip
    // between its two triangles (a watertightness fault of the triangle test, noted in
    // docs/renderer.md); they see the sky in both frames and are left out here.
    let mut compared = 0;
    for (k, (d, c)) in dense.depth.data.iter().zip(&clear.depth.data).enumerate() {
        if c.is_infinite() {
            continue;
        }
        compared += 1;
        // The wall is 5 from the camera along the axis, a little more off it (20° fov).
        assert!((5.0..5.2).contains(c), "pixel {k}: depth {c} without fog");
        assert!(
            (d - c).abs() <= 1e-4 * c.abs().max(1.0),
            "pixel {k}: depth {d} in fog, {c} without it"
        );
    }
    assert!(compared >= 250, "{compared} pixels see the wall");
    for (k, (n, c)) in dense.normal.data.iter().zip(&clear.normal.data).enumerate() {
        if clear.depth.data[k / 3].is_infinite() {
            continue;
        }
        assert!(
            (n - c).abs() < 1e-4,
            "normal component {k}: {n} in fog, {c} without"
        );
    }
}
