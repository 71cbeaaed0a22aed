//! χ² goodness-of-fit of light sampling: directions drawn by `Lights::sample` from a point must
//! follow the density that `environment_pdf` and `triangle_pdf` report (the densities MIS uses).

use crate::common;

use common::chi2;

use std::sync::Arc;

use lumo_image::Image;
use lumo_render::lights::Lights;
use lumo_scene::shapes::rectangle;
use lumo_scene::{EnvMap, Light, Mat4, Material, Vec2, Vec3};

/// An environment map with a bright patch, a dim gradient and a black band, so importance
/// sampling has structure to get wrong.
fn test_envmap() -> EnvMap {
    let (w, h) = (64, 32);
    let mut data = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        for x in 0..w {
            let mut v = 0.2 + 0.8 * x as f32 / w as f32;
            if (20..26).contains(&x) && (8..12).contains(&y) {
                v = 60.0;
            }
            if (24..28).contains(&y) {
                v = 0.0;
            }
            data.extend_from_slice(&[v, 0.5 * v, 0.25 * v]);
        }
    }
    EnvMap {
        image: Arc::new(Image::from_vec(w, h, 3, data)),
        scale: 1.0,
        to_world: Mat4::from_rotation_y(0.7),
    }
}

/// Möller–Trumbore; the hit distance of a ray with a triangle.
fn hit_triangle(o: Vec3, d: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Option<f32> {
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let s = o - a;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let t = e2.dot(q) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0).then_some(t)
}

/// Total density of `lights.sample` producing direction `d` from `p`, summed over every light
/// that can produce it (a one-sample mixture).
fn total_pdf(scene: &lumo_scene::Scene, lights: &Lights, p: Vec3, d: Vec3) -> f32 {
    let mut pdf = lights.environment_pdf(d);
    for (ii, inst) in scene.instances.iter().enumerate() {
        let mesh = &scene.meshes[inst.mesh];
        for (ti, t) in mesh.indices.iter().enumerate() {
            let v = |i: u32| inst.transform.transform_point3(mesh.positions[i as usize]);
            let (a, b, c) = (v(t[0]), v(t[1]), v(t[2]));
            // Emitters are one-sided: sampling rejects points whose front faces away from p.
            let facing = (b - a).cross(c - a).dot(p - a) > 0.0;
            if let (true, Some(dist)) = (facing, hit_triangle(p, d, a, b, c)) {
                pdf += lights.triangle_pdf(ii as u32, ti as u32, p, p + d * dist);
            }
        }
    }
    pdf
}

/// Bins `n` light samples from `p` over the sphere and compares with the integrated density.
fn chi2(scene: &lumo_scene::Scene, p: Vec3, n: usize) -> f64 {
    let lights = Lights::new(scene);
    let (nt, np) = (24usize, 48usize);
    let mut observed = vec![0f64; nt * np];
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((state >> 40) as f32) / (1u64 << 24) as f32
    };
    for _ in 0..n {
        let (a, b, c) = (next(), next(), next());
        if let Some(s) = lights.sample(p, a, Vec2::new(b, c)) {
            assert!(s.pdf > 0.0, "area and environment samples carry a density");
            observed[chi2::cell(s.wi, nt, np)] += 1.0;
        }
    }
    let expected = chi2::expected_counts(nt, np, 24, n, |d| total_pdf(scene, &lights, p, d));
    let total_expected: f64 = expected.iter().sum();
    let total_observed: f64 = observed.iter().sum();
    assert!(
        (total_expected / total_observed - 1.0).abs() < 0.02,
        "density integrates to {total_expected} samples, sampling produced {total_observed}"
    );
    let (pv, terms) = chi2::p_value(&observed, &expected);
    assert!(terms > 10, "too few populated cells ({terms})");
    pv
}

fn scene_with_lights(env: bool, constant: bool, area: bool) -> lumo_scene::Scene {
    let mut scene = common::empty_scene(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO);
    if env {
        scene.lights.push(Light::Environment(test_envmap()));
    }
    if constant {
        scene.lights.push(Light::Constant {
            radiance: Vec3::splat(0.3),
        });
    }
    if area {
        let bright =
            scene.add_material(Material::diffuse("l1", Vec3::ZERO).with_emission(Vec3::splat(8.0)));
        let dim = scene.add_material(
            Material::diffuse("l2", Vec3::ZERO).with_emission(Vec3::new(1.0, 2.0, 0.5)),
        );
        scene.add_mesh(rectangle(
            &(Mat4::from_translation(Vec3::new(0.3, 0.2, 1.5))
                * Mat4::from_rotation_x(0.4)
                * Mat4::from_scale(Vec3::splat(0.6))),
            bright,
        ));
        scene.add_mesh(rectangle(
            &(Mat4::from_translation(Vec3::new(-1.0, -0.5, -0.8))
                * Mat4::from_rotation_y(2.0)
                * Mat4::from_scale(Vec3::new(1.2, 0.4, 1.0))),
            dim,
        ));
    }
    scene
}

#[test]
fn light_sampling_follows_its_pdf() {
    let cases = [
        ("envmap", scene_with_lights(true, false, false)),
        ("envmap+constant", scene_with_lights(true, true, false)),
        ("constant", scene_with_lights(false, true, false)),
        ("area lights", scene_with_lights(false, false, true)),
        ("envmap+area lights", scene_with_lights(true, false, true)),
    ];
    let p = Vec3::new(0.05, -0.1, 0.2);
    let mut failures = vec![];
    for (name, scene) in &cases {
        let pv = chi2(scene, p, 300_000);
        if pv < 0.01 / cases.len() as f64 {
            failures.push(format!("{name}: p = {pv:.2e}"));
        }
    }
    assert!(failures.is_empty(), "χ² rejects: {failures:?}");
}

#[test]
fn spot_falloff_is_mitsubas_linear_in_angle_and_its_power_integrates() {
    use lumo_render::lights::SpotCone;
    // Mitsuba 3's falloff_curve: 1 inside the beam, (cutoff − θ)/(cutoff − beam) between,
    // 0 at and beyond the cutoff.
    let cone = SpotCone::new(15.0, 30.0, Default::default());
    for (deg, expected) in [
        (0.0f32, 1.0f32),
        (14.9, 1.0),
        (20.0, 2.0 / 3.0),
        (25.0, 1.0 / 3.0),
        (29.9, 0.1 / 15.0),
        (30.5, 0.0),
        (90.0, 0.0),
    ] {
        let got = cone.falloff(deg.to_radians().cos());
        assert!((got - expected).abs() < 2e-3, "{deg}°: {got} vs {expected}");
    }
    // The power factor is ∫ falloff dω, integrated numerically over θ.
    for (beam, cutoff) in [(15.0f32, 30.0f32), (30.0, 30.0), (0.0, 45.0), (60.0, 80.0)] {
        let cone = SpotCone::new(beam, cutoff, Default::default());
        let n = 200_000;
        let mut sum = 0.0f64;
        for i in 0..n {
            let theta = (i as f64 + 0.5) / n as f64 * std::f64::consts::PI;
            sum += cone.falloff(theta.cos() as f32) as f64 * theta.sin();
        }
        let numeric = 2.0 * std::f64::consts::PI * sum * std::f64::consts::PI / n as f64;
        let closed = cone.solid_angle() as f64;
        assert!(
            (numeric - closed).abs() < 1e-3 * closed,
            "{beam}/{cutoff}: {numeric} vs {closed}"
        );
    }
}

#[test]
fn interpolated_envmap_light_sampling_agrees_with_bsdf_sampling() {
    // The map is looked up bilinearly, the light sampler draws texel cells: its density must
    // stay positive wherever the interpolated radiance is (next to the black band and the
    // bright patch) or light sampling would miss light that BSDF sampling finds.
    use lumo_render::{render, PathSettings, RenderScene, RenderSettings};
    let mut scene = scene_with_lights(false, false, false);
    // One-texel stripes: every other column and row black, so half of the texel cells are
    // black while the interpolated radiance there is not.
    let (w, h) = (32, 16);
    let data = (0..w * h)
        .flat_map(|i| {
            let v = if (i % w) % 2 == 0 && (i / w) % 2 == 0 {
                2.0
            } else {
                0.0
            };
            [v, v, v]
        })
        .collect();
    scene.lights.push(Light::Environment(EnvMap {
        image: Arc::new(Image::from_vec(w, h, 3, data)),
        scale: 1.0,
        to_world: Mat4::IDENTITY,
    }));
    let grey = scene.add_material(Material::diffuse("grey", Vec3::splat(0.6)));
    scene.add_mesh(rectangle(
        &(Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2) * Mat4::from_scale(Vec3::splat(0.8))),
        grey,
    ));
    scene.camera.origin = Vec3::new(0.0, 1.5, 1.5);
    let rs = RenderScene::new(scene).unwrap();
    let mean = |nee: bool, bsdf_emission: bool| {
        let settings = RenderSettings {
            width: 24,
            height: 24,
            spp: 512,
            seed: 3,
            path: PathSettings {
                max_depth: 2,
                nee,
                bsdf_emission,
                ..Default::default()
            },
        };
        let m = render(&rs, &settings, &|_| {}).0.direct.channel_means();
        Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32)
    };
    let (light, bsdf) = (mean(true, false), mean(false, true));
    let rel = ((light - bsdf) / bsdf).abs().max_element();
    assert!(rel < 0.02, "light sampling {light} vs BSDF sampling {bsdf}");
}

#[test]
fn empty_images_built_in_code_emit_and_reflect_nothing() {
    // The loaders refuse 0×N images; a scene built in code must still render, not panic.
    use lumo_render::{render, PathSettings, RenderScene, RenderSettings};
    use lumo_scene::{Texture, TextureFilter, WrapMode};
    let empty = Arc::new(Image::from_vec(0, 4, 3, vec![]));
    let mut scene = scene_with_lights(false, true, false);
    scene.lights.push(Light::Environment(EnvMap {
        image: empty.clone(),
        scale: 1.0,
        to_world: Mat4::IDENTITY,
    }));
    let textured = scene.add_material(Material {
        name: "empty texture".into(),
        bsdf: lumo_scene::BsdfSpec::Diffuse {
            reflectance: Texture::Bitmap {
                image: empty,
                uv_scale: Vec2::ONE,
                filter: TextureFilter::Bilinear,
                wrap: WrapMode::Repeat,
            },
        },
        emission: Vec3::ZERO,
        emission_map: None,
        spectra: Default::default(),
        two_sided: true,
    });
    scene.add_mesh(rectangle(&Mat4::IDENTITY, textured));
    let rs = RenderScene::new(scene).unwrap();
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 4,
        seed: 1,
        path: PathSettings::default(),
    };
    let frame = render(&rs, &settings, &|_| {}).0;
    // The constant light is seen around the black (empty-textured) square.
    let m = frame.color.channel_means();
    assert!(m.iter().all(|v| v.is_finite() && *v > 0.0), "{m:?}");
}

/// Emissive exact shapes: the light pdf of the point a direction hits integrates to one over
/// the sphere of directions, every light sample lands where its ray hits the shape with the
/// pdf `triangle_pdf` gives that point, and E[1/pdf] is the solid angle the shape covers — for
/// a sphere seen from outside (its visible cone, by solid angle), from inside (by area), a disk
/// and an open cylinder seen from inside (by area, converted to solid angle).
#[test]
fn analytic_light_pdfs_integrate_to_one_and_match_their_samples() {
    use lumo_render::RenderScene;
    use lumo_scene::load::{load_mitsuba_str, LoadOptions};
    use std::f32::consts::PI;
    let emitter = r#"<emitter type="area"><rgb name="radiance" value="1"/></emitter>"#;
    let cases = [
        (
            format!(
                r#"<shape type="sphere"><point name="center" value="0.2,0,0"/><float name="radius" value="0.5"/>{emitter}</shape>"#
            ),
            Vec3::new(0.0, 0.3, 1.7),
        ),
        (
            format!(
                r#"<shape type="sphere"><float name="radius" value="0.5"/><boolean name="flip_normals" value="true"/>{emitter}</shape>"#
            ),
            Vec3::new(0.1, -0.2, 0.15),
        ),
        (
            format!(
                r#"<shape type="disk"><transform name="to_world"><scale value="0.7"/></transform>{emitter}</shape>"#
            ),
            Vec3::new(0.3, 0.2, 0.6),
        ),
        (
            format!(
                r#"<shape type="cylinder"><point name="p0" value="0,0,-1"/><point name="p1" value="0,0,1"/><boolean name="flip_normals" value="true"/>{emitter}</shape>"#
            ),
            Vec3::new(0.2, 0.1, 0.3),
        ),
    ];
    for (shape, from) in cases {
        let text = format!(r#"<scene version="3.0.0">{shape}</scene>"#);
        let loaded = load_mitsuba_str(
            &text,
            std::path::Path::new("t.xml"),
            &LoadOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let rs = RenderScene::new(loaded.scene).unwrap();
        // ∫ pdf dω and the covered solid angle, over stratified directions.
        let (nt, np) = (400usize, 800usize);
        let (mut integral, mut covered) = (0.0f64, 0.0f64);
        for i in 0..nt {
            for j in 0..np {
                let cos = 1.0 - 2.0 * (i as f32 + 0.5) / nt as f32;
                let phi = 2.0 * PI * (j as f32 + 0.5) / np as f32;
                let sin = (1.0 - cos * cos).max(0.0).sqrt();
                let d = Vec3::new(sin * phi.cos(), sin * phi.sin(), cos);
                if let Some(hit) = rs.accel.intersect(from, d, 0.0, f32::INFINITY) {
                    let s = rs.surface(&hit, from, d);
                    let dw = 4.0 * std::f64::consts::PI / (nt * np) as f64;
                    integral +=
                        rs.lights.triangle_pdf(hit.instance, s.triangle, from, s.p) as f64 * dw;
                    covered += dw;
                }
            }
        }
        assert!(
            (integral - 1.0).abs() < 0.01,
            "{shape}: ∫ pdf dω = {integral}"
        );
        let mut inv_pdf = 0.0f64;
        let n = 20000;
        for k in 0..n {
            let u = Vec2::new(
                (k as f32 + 0.5) / n as f32,
                ((k as u64 * 2654435761) % 65536) as f32 / 65536.0,
            );
            let ls = rs
                .lights
                .sample(from, 0.5, u)
                .unwrap_or_else(|| panic!("{shape}: no sample"));
            let hit = rs.accel.intersect(from, ls.wi, 0.0, f32::INFINITY).unwrap();
            assert!(
                (hit.t - ls.distance).abs() < 1e-3 * (1.0 + ls.distance),
                "{shape}: sample at {} but its ray hits at {}",
                ls.distance,
                hit.t
            );
            let s = rs.surface(&hit, from, ls.wi);
            let pdf = rs.lights.triangle_pdf(hit.instance, s.triangle, from, s.p);
            assert!(
                (pdf - ls.pdf).abs() <= 2e-3 * ls.pdf,
                "{shape}: sampled pdf {} but pdf {pdf} at the hit",
                ls.pdf
            );
            inv_pdf += 1.0 / ls.pdf as f64;
        }
        let solid_angle = inv_pdf / n as f64;
        assert!(
            (solid_angle - covered).abs() < 0.01 * covered,
            "{shape}: E[1/pdf] = {solid_angle}, covered solid angle {covered}"
        );
    }
}
