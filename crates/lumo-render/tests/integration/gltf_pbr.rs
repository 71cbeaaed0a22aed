//! glTF's metallic-roughness BSDF: a white dielectric reflects exactly what it receives (the
//! diffuse lobe takes what the specular layer leaves), nothing reflects more at any metalness
//! or roughness, and its two ends are the lobes the glTF specification names.

use glam::{Vec2, Vec3};
use lumo_render::bsdf::{Bsdf, Conductor, GltfPbr, Microfacet};

use crate::common::bsdf_grid::{albedo, dir};

const ROUGHNESSES: [f32; 7] = [0.0, 0.05, 0.2, 0.4, 0.6, 0.8, 1.0];
const COSINES: [f32; 5] = [1.0, 0.7, 0.4, 0.15, 0.03];

#[test]
fn a_white_gltf_dielectric_reflects_all_it_receives() {
    for r in ROUGHNESSES {
        for c in COSINES {
            let b = Bsdf::GltfPbr(GltfPbr::new(Vec3::ONE, 0.0, r));
            let a = albedo(&b, dir(c, 0.3), 400);
            assert!(
                (a - Vec3::ONE).abs().max_element() < 0.01,
                "roughness {r}, cos θo {c}: albedo {a}"
            );
        }
    }
}

#[test]
fn no_gltf_material_reflects_more_than_it_receives() {
    for m in [0.0, 0.25, 0.5, 0.75, 1.0] {
        for r in ROUGHNESSES {
            for c in COSINES {
                let b = Bsdf::GltfPbr(GltfPbr::new(Vec3::ONE, m, r));
                let a = albedo(&b, dir(c, 1.1), 300);
                assert!(
                    a.max_element() <= 1.005,
                    "metallic {m}, roughness {r}, cos θo {c}: albedo {a}"
                );
            }
        }
    }
}

/// Pairs of directions above the surface, spread over the hemisphere.
fn direction_pairs() -> Vec<(Vec3, Vec3)> {
    let mut v = vec![];
    for (k, co) in [0.95f32, 0.6, 0.25, 0.08].into_iter().enumerate() {
        for (l, ci) in [0.9f32, 0.5, 0.2].into_iter().enumerate() {
            for phi in [0.0f32, 1.0, 2.5, 3.1] {
                v.push((dir(co, 0.2 * k as f32), dir(ci, phi + 0.1 * l as f32)));
            }
        }
    }
    v
}

fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).abs().max_element() <= tol * a.abs().max_element().max(b.abs().max_element()).max(1e-6)
}

/// The metal end with a white base colour reflects with Fresnel 1 at every angle: lumo's
/// microfacet conductor with an (almost) perfectly reflecting Fresnel term, same GGX.
#[test]
fn a_white_gltf_metal_is_a_perfectly_reflecting_conductor() {
    for r in [0.2f32, 0.5, 0.9] {
        let g = Bsdf::GltfPbr(GltfPbr::new(Vec3::ONE, 1.0, r));
        let c = Bsdf::Conductor(Conductor {
            eta: Vec3::ONE,
            k: Vec3::splat(1e4),
            mf: Microfacet::ggx(r * r),
        });
        for (wo, wi) in direction_pairs() {
            let (a, b) = (g.eval(wo, wi), c.eval(wo, wi));
            assert!(close(a, b, 1e-3), "roughness {r}: {a} vs conductor {b}");
            let (pa, pb) = (g.pdf(wo, wi), c.pdf(wo, wi));
            assert!((pa - pb).abs() <= 1e-3 * pb.max(1e-6), "{pa} vs {pb}");
        }
    }
}

/// glTF's dielectric specular layer is the metal's lobe with F0 = 0.04: a black dielectric
/// (no diffuse lobe left) equals a metal whose base colour is 0.04 grey.
#[test]
fn a_black_gltf_dielectric_is_a_metal_of_reflectance_four_percent() {
    for r in [0.1f32, 0.5, 1.0] {
        let d = Bsdf::GltfPbr(GltfPbr::new(Vec3::ZERO, 0.0, r));
        let m = Bsdf::GltfPbr(GltfPbr::new(Vec3::splat(0.04), 1.0, r));
        for (wo, wi) in direction_pairs() {
            let (a, b) = (d.eval(wo, wi), m.eval(wo, wi));
            assert!(close(a, b, 1e-5), "roughness {r}: {a} vs {b}");
        }
    }
}

/// The BSDF is reciprocal (the light tracer and BDPT see the same surface as the path
/// tracer), and a smooth surface's mirror reflection is Schlick's Fresnel of the mix.
#[test]
fn the_gltf_bsdf_is_reciprocal_and_smooth_fresnel_is_schlicks() {
    for (m, r) in [(0.0f32, 0.3f32), (0.6, 0.7), (0.3, 0.0)] {
        let b = Bsdf::GltfPbr(GltfPbr::new(Vec3::new(0.7, 0.4, 0.2), m, r));
        for (wo, wi) in direction_pairs() {
            // eval includes cos θi: f·cos θi / cos θi must be symmetric.
            let (a, c) = (b.eval(wo, wi) / wi.z, b.eval(wi, wo) / wo.z);
            assert!(close(a, c, 1e-4), "metallic {m}, roughness {r}: {a} vs {c}");
        }
    }
    let base = Vec3::new(0.9, 0.5, 0.1);
    let b = Bsdf::GltfPbr(GltfPbr::new(base, 0.5, 0.0));
    let wo = dir(0.3, 0.0);
    let s = (0..64)
        .filter_map(|k| b.sample(wo, k as f32 / 64.0, Vec2::splat(0.5)))
        .find(|s| s.delta)
        .expect("a mirror sample");
    let schlick = |f0: Vec3| f0 + (Vec3::ONE - f0) * 0.7f32.powi(5);
    let expected = 0.5 * schlick(Vec3::splat(0.04)) + 0.5 * schlick(base);
    assert!(
        close(s.weight * s.pdf, expected, 1e-4),
        "{} vs {expected}",
        s.weight * s.pdf
    );
}

/// A metal's G-buffer albedo is its base colour (what a denoiser divides by), a dielectric's
/// its base colour plus the specular layer's reflection.
#[test]
fn a_gltf_metals_albedo_is_its_base_colour() {
    let base = Vec3::new(0.95, 0.64, 0.54);
    let metal = Bsdf::GltfPbr(GltfPbr::new(base, 1.0, 0.4));
    assert!(close(metal.albedo(), base, 1e-6), "{}", metal.albedo());
    assert!(close(metal.albedo_towards(Vec3::Z), base, 1e-6));
    let dielectric = Bsdf::GltfPbr(GltfPbr::new(base, 0.0, 0.4));
    let a = dielectric.albedo();
    assert!(a.cmpgt(base).all() && a.cmplt(base + 0.05).all(), "{a}");
}

/// A rectangle filling the view, head-on, lit by a constant environment.
pub(crate) const FACING_QUAD: &str = r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0,0,2" target="0,0,0" up="0,1,0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
  </sensor>
  <shape type="rectangle"><bsdf type="diffuse"/></shape>
  <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>"#;

/// A 2×1 linear-RGB bitmap, nearest lookups: `left` for u < ½, `right` above.
pub(crate) fn two_texels(left: Vec3, right: Vec3) -> lumo_scene::Texture {
    let data = [left.to_array(), right.to_array()].concat();
    lumo_scene::Texture::Bitmap {
        image: std::sync::Arc::new(lumo_image::Image::from_vec(2, 1, 3, data)),
        uv_scale: Vec2::ONE,
        filter: lumo_scene::TextureFilter::Nearest,
        wrap: lumo_scene::WrapMode::Repeat,
    }
}

/// The albedo AOV of a glTF material whose metallicRoughness texture makes the left half
/// metal and the right half dielectric: the base colour on the metal half, and on the
/// dielectric half the base colour plus the specular layer's few percent. (With the texture
/// replaced by its mean, as lumo did before, both halves were one material.)
#[test]
fn the_albedo_aov_follows_a_textured_metalness() {
    use lumo_render::{render, RenderScene, RenderSettings};
    let loaded = lumo_scene::load::load_mitsuba_str(
        FACING_QUAD,
        std::path::Path::new("quad.xml"),
        &Default::default(),
    )
    .unwrap();
    let mut scene = loaded.scene;
    let (red, blue) = (Vec3::new(0.9, 0.1, 0.1), Vec3::new(0.1, 0.1, 0.9));
    scene.materials[0].bsdf = lumo_scene::BsdfSpec::GltfPbr {
        base_color: two_texels(red, blue),
        // Roughness (green) 0.5 on both; metalness (blue) 1 on the left, 0 on the right.
        metallic_roughness: Some(two_texels(
            Vec3::new(0.0, 0.5, 1.0),
            Vec3::new(0.0, 0.5, 0.0),
        )),
        metallic: 1.0,
        roughness: 1.0,
        extensions: None,
    };
    let rs = RenderScene::new(scene).unwrap();
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 1,
        seed: 1,
        path: Default::default(),
    };
    let film = render(&rs, &settings, &|_| {}).0;
    for y in 0..8 {
        for x in [0, 1, 2, 5, 6, 7] {
            let a = Vec3::from_slice(&film.albedo.pixel(x, y)[..3]);
            if x < 4 {
                assert!(close(a, red, 1e-4), "metal half ({x}, {y}): {a}");
            } else {
                // E + base·(1 − E), E ≈ 4 %: red and green rise by a few percent.
                assert!(a.x > blue.x + 0.01 && a.x < blue.x + 0.1, "({x}, {y}): {a}");
                assert!(a.z > 0.9, "dielectric half ({x}, {y}): {a}");
            }
        }
    }
}
