//! KHR_materials_clearcoat on glTF's BSDF: the coat never makes a surface reflect more than
//! it receives, over any base; over a black base it is exactly a 4 % dielectric layer of its
//! roughness times its intensity; the coated BSDF is reciprocal; its albedo AOV adds the coat.

use glam::Vec3;
use lumo_render::bsdf::{Bsdf, GltfPbr};

use crate::common::bsdf_grid::{albedo, dir};

/// White bases (dielectric, metal, thin transmissive) under coats of every intensity and
/// roughness reflect no more than they receive; a full smooth coat over a white dielectric
/// loses little.
#[test]
fn a_coat_never_makes_energy() {
    for (metallic, transmission) in [(0.0f32, 0.0f32), (1.0, 0.0), (0.0, 1.0)] {
        for base_r in [0.0f32, 0.5] {
            for (c, cr) in [(1.0f32, 0.0f32), (1.0, 0.3), (0.5, 0.8), (1.0, 1.0)] {
                for cos in [1.0f32, 0.5, 0.15, 0.03] {
                    let b = Bsdf::GltfPbr(
                        GltfPbr::new(Vec3::ONE, metallic, base_r)
                            .with_transmission(transmission, true, 1.5)
                            .with_clearcoat(c, cr),
                    );
                    let a = albedo(&b, dir(cos, 0.6), 300);
                    assert!(
                        a.max_element() <= 1.01,
                        "metallic {metallic}, transmission {transmission}, roughness {base_r}, \
                         coat {c}/{cr}, cos θo {cos}: {a}"
                    );
                    if metallic == 0.0 && transmission == 0.0 && cr == 0.0 && cos >= 0.5 {
                        assert!(a.min_element() > 0.9, "{cos}: {a}");
                    }
                }
            }
        }
    }
}

/// Over a base that reflects nothing (black, specular weight 0) the coat is the core
/// dielectric layer (F0 = 0.04, GGX of the coat's roughness) scaled by its intensity.
#[test]
fn over_nothing_the_coat_is_a_four_percent_layer() {
    for cr in [0.2f32, 0.6] {
        let coated = Bsdf::GltfPbr(
            GltfPbr::new(Vec3::ZERO, 0.0, 0.9)
                .with_specular(1.5, 0.0, Vec3::ONE)
                .with_clearcoat(0.7, cr),
        );
        let layer =
            Bsdf::GltfPbr(GltfPbr::new(Vec3::ZERO, 0.0, cr).with_specular(1.5, 0.7, Vec3::ONE));
        for (co, ci) in [(0.9f32, 0.4f32), (0.3, 0.8), (0.1, 0.1)] {
            let (wo, wi) = (dir(co, 0.0), dir(ci, 2.5));
            let (a, b) = (coated.eval(wo, wi), layer.eval(wo, wi));
            assert!(
                (a - b).abs().max_element() <= 1e-5 * b.max_element(),
                "{a} vs {b}"
            );
            let (p, q) = (coated.pdf(wo, wi), layer.pdf(wo, wi));
            assert!(p > 0.0 && q > 0.0, "{p} {q}");
        }
        let (a, b) = (
            albedo(&coated, dir(0.5, 0.0), 200),
            albedo(&layer, dir(0.5, 0.0), 200),
        );
        assert!((a - b).abs().max_element() < 2e-3, "{a} vs {b}");
    }
}

/// The coated BSDF is reciprocal, and its albedo AOV adds the coat's reflectance.
#[test]
fn the_coated_bsdf_is_reciprocal_and_its_albedo_adds_the_coat() {
    let plain = GltfPbr::new(Vec3::new(0.6, 0.3, 0.1), 0.4, 0.6);
    let b = Bsdf::GltfPbr(plain.with_clearcoat(0.9, 0.25));
    for co in [0.95f32, 0.5, 0.1] {
        for ci in [0.8f32, 0.3, 0.05] {
            let (wo, wi) = (dir(co, 0.3), dir(ci, 2.4));
            let (x, y) = (b.eval(wo, wi) / wi.z, b.eval(wi, wo) / wo.z);
            assert!(
                (x - y).abs().max_element() <= 1e-4 * x.max_element(),
                "{x} vs {y}"
            );
        }
    }
    let (coated, bare) = (b.albedo(), Bsdf::GltfPbr(plain).albedo());
    assert!(
        coated.cmpgt(bare * 0.9).all() && (coated - bare).min_element() > -0.05,
        "{coated} {bare}"
    );
    assert!(
        coated.z > bare.z,
        "the coat's grey reflection lifts the dark channel: {coated} {bare}"
    );
}
