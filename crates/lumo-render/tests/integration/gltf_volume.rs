//! A glTF transmissive slab rendered end to end: seen head-on against a light behind it, it
//! transmits what the two Fresnel interfaces and the Beer–Lambert absorption inside allow,
//! inter-reflections included: T = (1 − R)²·τ / (1 − R²·τ²), R = ((n − 1)/(n + 1))², τ =
//! exp(−σ_a·d) — for a volume with KHR_materials_volume's absorbing medium, for one without,
//! and for two thin-walled sheets (no medium, tinted twice by the base colour).

use std::path::Path;
use std::sync::Arc;

use glam::Vec3;
use lumo_render::{render, PathSettings, RenderScene, RenderSettings};
use lumo_scene::load::{load_mitsuba_str, LoadOptions};
use lumo_scene::media::Density;
use lumo_scene::{
    Boundary, BsdfSpec, GltfExtensions, Medium, MediumInterface, PhaseFunction, Scene, Texture,
};

/// The cube [-1, 1]³ seen along −z through a 1° field of view from z = 4, in front of an
/// emitting square of radiance 1 at z = −3; the cube's material is a white glTF glass of
/// index 1.5 with `extensions` and base colour `base`, and `sigma_a` (if any) fills it.
fn slab(base: Vec3, ext: GltfExtensions, sigma_a: Option<Vec3>) -> Scene {
    let xml = r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="1"/>
    <transform name="to_world"><lookat origin="0,0,4" target="0,0,0" up="0,1,0"/></transform>
  </sensor>
  <shape type="cube"><bsdf type="diffuse"/></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><translate z="-3"/></transform>
    <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
</scene>"#;
    let mut scene = load_mitsuba_str(xml, Path::new("slab.xml"), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .scene;
    let cube = (0..scene.meshes.len())
        .find(|&m| !scene.materials[scene.meshes[m].material].is_emissive())
        .expect("the cube");
    let material = scene.meshes[cube].material;
    scene.materials[material].bsdf = BsdfSpec::GltfPbr {
        base_color: Texture::Constant(base),
        metallic_roughness: None,
        metallic: 0.0,
        roughness: 0.0,
        extensions: Some(Arc::new(ext)),
    };
    if let Some(sigma_t) = sigma_a {
        scene.media.media.push(Medium {
            name: "glass".into(),
            sigma_t,
            albedo: Vec3::ZERO,
            density: Density::Homogeneous,
            phase: PhaseFunction::Isotropic,
            spectra: Default::default(),
        });
        let interface = MediumInterface {
            interior: Some(0),
            exterior: None,
        };
        scene.media.set_boundary(
            cube,
            Boundary {
                null: false,
                interface: Some(interface),
            },
        );
    }
    scene
}

fn mean_color(scene: Scene) -> Vec3 {
    let rs = RenderScene::new(scene).unwrap();
    let settings = RenderSettings {
        width: 4,
        height: 4,
        spp: 1024,
        seed: 5,
        path: PathSettings {
            max_depth: lumo_scene::DEPTH_LIMIT,
            rr_depth: 5,
            ..Default::default()
        },
    };
    let m = render(&rs, &settings, &|_| {}).0.color.channel_means();
    Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32)
}

fn transmissive(thickness: f32) -> GltfExtensions {
    GltfExtensions {
        transmission: Texture::Constant(Vec3::ONE),
        thickness,
        ..Default::default()
    }
}

/// (1 − R)²·τ / (1 − R²·τ²) per channel.
fn slab_transmittance(r: f32, tau: Vec3) -> Vec3 {
    (1.0 - r) * (1.0 - r) * tau / (Vec3::ONE - r * r * tau * tau)
}

fn assert_close(got: Vec3, want: Vec3, what: &str) {
    let rel = ((got - want) / want).abs().max_element();
    assert!(
        rel < 0.005,
        "{what}: got {got}, expected {want} ({:.2} %)",
        rel * 100.0
    );
}

#[test]
fn an_absorbing_gltf_glass_slab_transmits_fresnel_times_beer_lambert() {
    let r = 0.04;
    let sigma = Vec3::new(0.1, 0.4, 0.9);
    let got = mean_color(slab(Vec3::ONE, transmissive(1.0), Some(sigma)));
    assert_close(
        got,
        slab_transmittance(r, (-2.0 * sigma).exp()),
        "absorbing",
    );
    let clear = mean_color(slab(Vec3::ONE, transmissive(1.0), None));
    assert_close(clear, slab_transmittance(r, Vec3::ONE), "clear");
}

#[test]
fn two_thin_walled_sheets_transmit_their_fresnel_complement_tinted_twice() {
    let base = Vec3::new(1.0, 0.8, 0.5);
    let got = mean_color(slab(base, transmissive(0.0), None));
    // Each sheet: 1 − F0 through (tinted), F0 back (untinted, F0 = 0.04 at n = 1.5).
    let r = 0.04;
    let want = base * base * (1.0 - r) * (1.0 - r) / (1.0 - r * r);
    assert_close(got, want, "thin");
}
