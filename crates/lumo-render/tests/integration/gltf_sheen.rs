//! KHR_materials_sheen on glTF's BSDF: a white sheen over a white base never reflects more than
//! it receives (with and without a coat); over a base that reflects nothing the sheen's albedo
//! is the tabulated E times its colour (the table against the lobe integrated by sampling); the
//! sheened BSDF is reciprocal; a zero colour is no sheen.

use glam::Vec3;
use lumo_render::bsdf::{Bsdf, GltfPbr};

use crate::common::bsdf_grid::{albedo, dir};

/// White bases (rough and smooth dielectric, metal, thin transmissive) under white sheens of
/// every roughness, coated or not, reflect no more than they receive.
#[test]
fn a_sheen_never_makes_energy() {
    for (metallic, roughness, transmission) in [
        (0.0f32, 0.5f32, 0.0f32),
        (0.0, 0.0, 0.0),
        (1.0, 0.3, 0.0),
        (0.0, 0.4, 1.0),
    ] {
        for sheen_r in [0.0f32, 0.3, 0.6, 1.0] {
            for coat in [0.0f32, 1.0] {
                for cos in [1.0f32, 0.5, 0.15, 0.03] {
                    let b = Bsdf::GltfPbr(
                        GltfPbr::new(Vec3::ONE, metallic, roughness)
                            .with_transmission(transmission, true, 1.5)
                            .with_clearcoat(coat, 0.2)
                            .with_sheen(Vec3::ONE, sheen_r),
                    );
                    let a = albedo(&b, dir(cos, 0.6), 160);
                    assert!(
                        a.max_element() <= 1.01,
                        "metallic {metallic}, roughness {roughness}, transmission \
                         {transmission}, sheen roughness {sheen_r}, coat {coat}, cos θo {cos}: {a}"
                    );
                }
            }
        }
    }
}

/// Over a black base without a specular layer, the sheen alone remains: its sampled albedo
/// (the lobe integrated by its own sampling) equals the albedo AOV, colour × the tabulated E
/// (bounded by it for smooth sheens),
/// and a sheen's reflectance is significant only where it should be (grazing views of a
/// smooth sheen reflect more than head-on ones).
#[test]
fn over_nothing_the_sheen_reflects_its_tabulated_albedo() {
    let color = Vec3::new(1.0, 0.6, 0.2);
    for r in [0.07f32, 0.15, 0.3, 0.6, 1.0] {
        let mut head_on = 0.0;
        for cos in [1.0f32, 0.6, 0.3, 0.1, 0.03] {
            let b = Bsdf::GltfPbr(
                GltfPbr::new(Vec3::ZERO, 0.0, 0.5)
                    .with_specular(1.5, 0.0, Vec3::ONE)
                    .with_sheen(color, r),
            );
            let wo = dir(cos, 1.1);
            let sampled = albedo(&b, wo, 600);
            let tabulated = b.albedo_towards(wo);
            // Smooth sheens are divided by max(1, E(ωo), E(ωi)) where their fitted masking
            // reflects more than 1 (towards grazing angles): there the table bounds them.
            let err = if r >= 0.3 {
                (sampled - tabulated).abs().max_element()
            } else {
                (sampled - tabulated).max_element()
            };
            assert!(
                err <= 0.02 * tabulated.x + 1e-3,
                "r {r}, cos θo {cos}: sampled {sampled}, table {tabulated}"
            );
            assert!(
                (tabulated / color - Vec3::splat(tabulated.x))
                    .abs()
                    .max_element()
                    < 1e-6,
                "{tabulated}"
            );
            if cos == 1.0 {
                head_on = tabulated.x;
            }
            if r <= 0.3 && cos == 0.1 {
                assert!(
                    tabulated.x > 2.0 * head_on,
                    "r {r}: {tabulated} vs {head_on}"
                );
            }
        }
    }
}

/// The sheened BSDF (with the base's lobes and a coat) is reciprocal.
#[test]
fn the_sheened_bsdf_is_reciprocal() {
    let b = Bsdf::GltfPbr(
        GltfPbr::new(Vec3::new(0.6, 0.3, 0.1), 0.3, 0.5)
            .with_clearcoat(0.5, 0.4)
            .with_sheen(Vec3::new(0.2, 0.9, 0.5), 0.4),
    );
    for co in [0.95f32, 0.5, 0.1] {
        for ci in [0.8f32, 0.3, 0.05] {
            let (wo, wi) = (dir(co, 0.3), dir(ci, 2.4));
            let (x, y) = (b.eval(wo, wi) / wi.z, b.eval(wi, wo) / wo.z);
            assert!(
                (x - y).abs().max_element() <= 1e-4 * x.max_element(),
                "{co} {ci}: {x} vs {y}"
            );
        }
    }
}

/// A sheen of colour zero is no sheen: the BSDF evaluates, samples and reports its albedo as
/// without the extension; a coloured one dims the base by the albedo scaling.
#[test]
fn a_black_sheen_is_no_sheen() {
    let plain = GltfPbr::new(Vec3::new(0.7, 0.5, 0.3), 0.2, 0.5).with_clearcoat(0.5, 0.3);
    let (a, b) = (
        Bsdf::GltfPbr(plain),
        Bsdf::GltfPbr(plain.with_sheen(Vec3::ZERO, 0.5)),
    );
    let (wo, wi) = (dir(0.7, 0.2), dir(0.4, 2.0));
    assert_eq!(a.eval(wo, wi), b.eval(wo, wi));
    assert_eq!(a.pdf(wo, wi), b.pdf(wo, wi));
    assert_eq!(a.albedo_towards(wo), b.albedo_towards(wo));
    // Head-on, a white smooth sheen reflects little and takes as much from the base.
    let c = Bsdf::GltfPbr(plain.with_sheen(Vec3::ONE, 0.2));
    let (x, y) = (a.eval(wo, wi), c.eval(wo, wi));
    assert!(
        x != y && y.max_element() < 1.05 * x.max_element(),
        "{x} {y}"
    );
}

/// The albedo AOV of a quad seen head-on whose glTF material has a sheen colour texture
/// (red on the left half, none on the right) and a clearcoat texture (none on the left, full
/// on the right) over a black base: the render scene reads both per texel (the sheen's red
/// E(1) ≈ 0.16 on the left, the coat's grey ≈ 4 % on the right). With the textures replaced
/// by their means, both halves would be alike.
#[test]
fn the_albedo_aov_follows_sheen_and_coat_textures() {
    use crate::gltf_pbr::{two_texels, FACING_QUAD};
    use lumo_render::{render, RenderScene, RenderSettings};
    let loaded = lumo_scene::load::load_mitsuba_str(
        FACING_QUAD,
        std::path::Path::new("quad.xml"),
        &Default::default(),
    )
    .unwrap();
    let mut scene = loaded.scene;
    let ext = lumo_scene::GltfExtensions {
        specular: lumo_scene::Texture::Constant(Vec3::ZERO),
        sheen_color: two_texels(Vec3::X, Vec3::ZERO),
        sheen_roughness: lumo_scene::Texture::Constant(Vec3::ONE),
        clearcoat: 1.0,
        clearcoat_roughness: 0.3,
        clearcoat_texture: Some(two_texels(Vec3::ZERO, Vec3::ONE)),
        ..Default::default()
    };
    scene.materials[0].bsdf = lumo_scene::BsdfSpec::GltfPbr {
        base_color: lumo_scene::Texture::Constant(Vec3::ZERO),
        metallic_roughness: None,
        metallic: 0.0,
        roughness: 0.5,
        extensions: Some(std::sync::Arc::new(ext)),
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
                assert!(
                    a.x > 0.12 && a.x < 0.2 && a.y < 1e-3,
                    "sheen half ({x}, {y}): {a}"
                );
            } else {
                assert!(
                    a.min_element() > 0.03 && a.max_element() < 0.06 && a.x == a.z,
                    "coat half ({x}, {y}): {a}"
                );
            }
        }
    }
}
