//! KHR_materials_ior and KHR_materials_specular on glTF's BSDF: the dielectric layer's F0
//! follows the index ((n − 1)/(n + 1))², the specular weight and colour scale it as the
//! extension defines, and the diffuse lobe keeps taking exactly what the layer leaves (a white
//! base reflects all it receives at every index and weight; no channel reflects more).

use glam::Vec3;
use lumo_render::bsdf::{Bsdf, Diffuse, GltfPbr};

use crate::common::bsdf_grid::{albedo, dir};

fn gltf(base: Vec3, roughness: f32, ior: f32, weight: f32, color: Vec3) -> Bsdf {
    Bsdf::GltfPbr(GltfPbr::new(base, 0.0, roughness).with_specular(ior, weight, color))
}

const IORS: [f32; 5] = [1.0, 1.2, 1.5, 2.5, 0.0];
const COSINES: [f32; 4] = [1.0, 0.6, 0.2, 0.04];

/// A white base under a grey layer reflects everything, whatever the index and the weight
/// (the diffuse lobe's share follows the layer's albedo at that F0 and weight).
#[test]
fn a_white_base_reflects_all_at_every_ior_and_specular_weight() {
    for ior in IORS {
        for weight in [0.0, 0.5, 1.0] {
            for r in [0.0, 0.3, 0.7, 1.0] {
                for c in COSINES {
                    let b = gltf(Vec3::ONE, r, ior, weight, Vec3::ONE);
                    let a = albedo(&b, dir(c, 0.4), 300);
                    assert!(
                        (a - Vec3::ONE).abs().max_element() < 0.012,
                        "ior {ior}, weight {weight}, roughness {r}, cos θo {c}: albedo {a}"
                    );
                }
            }
        }
    }
}

/// A coloured F0 (specularColorFactor, even above 1 as the extension allows) never makes a
/// channel reflect more than it receives; the channel with the largest F0 reflects all.
#[test]
fn a_coloured_specular_layer_reflects_no_more_than_it_receives() {
    for color in [Vec3::new(1.0, 0.3, 0.0), Vec3::new(4.0, 1.0, 0.5)] {
        for ior in [1.5, 3.0] {
            for r in [0.0, 0.4, 1.0] {
                for c in COSINES {
                    let b = gltf(Vec3::ONE, r, ior, 1.0, color);
                    let a = albedo(&b, dir(c, 1.3), 300);
                    assert!(
                        a.max_element() <= 1.01 && (a.x - 1.0).abs() < 0.012,
                        "colour {color}, ior {ior}, roughness {r}, cos θo {c}: albedo {a}"
                    );
                }
            }
        }
    }
}

/// A smooth black dielectric reflects, head-on, F0 = ((n − 1)/(n + 1))² × colour × weight —
/// 1/9 at n = 2 rather than the core material's 4 % — and at grazing view tends to the
/// weight (F90).
#[test]
fn smooth_reflectance_follows_the_ior_and_the_specular_factors() {
    let color = Vec3::new(1.0, 0.5, 0.25);
    for (ior, f0) in [(2.0f32, 1.0f32 / 9.0), (1.5, 0.04), (1.0, 0.0), (0.0, 1.0)] {
        for weight in [1.0f32, 0.5] {
            let b = gltf(Vec3::ZERO, 0.0, ior, weight, color);
            let head_on = albedo(&b, Vec3::Z, 16);
            let expected = (color * f0).min(Vec3::ONE) * weight;
            assert!(
                (head_on - expected).abs().max_element() < 1e-4,
                "ior {ior}, weight {weight}: {head_on} vs {expected}"
            );
            let grazing = albedo(&b, dir(1e-3, 0.0), 16);
            assert!(
                (grazing - Vec3::splat(weight)).abs().max_element() < 0.01,
                "ior {ior}, weight {weight}: grazing {grazing}"
            );
        }
    }
}

/// specularFactor 0 removes the dielectric layer: what is left is a Lambertian base.
#[test]
fn zero_specular_weight_is_lambertian() {
    let base = Vec3::new(0.7, 0.5, 0.2);
    let d = Bsdf::Diffuse(Diffuse { albedo: base });
    for r in [0.0, 0.5] {
        let g = gltf(base, r, 1.5, 0.0, Vec3::ONE);
        for (co, ci) in [(0.9, 0.3), (0.2, 0.8), (0.05, 0.5)] {
            let (wo, wi) = (dir(co, 0.0), dir(ci, 2.0));
            let (a, b) = (g.eval(wo, wi), d.eval(wo, wi));
            assert!(
                (a - b).abs().max_element() < 1e-5,
                "roughness {r}: {a} vs {b}"
            );
        }
        assert!((g.albedo() - base).abs().max_element() < 1e-5);
    }
}

/// With the extensions the BSDF stays reciprocal, and the G-buffer albedo is the layer's
/// reflectance plus the base colour's remainder: it grows with the index for a black base.
#[test]
fn the_extended_bsdf_is_reciprocal_and_its_albedo_follows_f0() {
    let b = Bsdf::GltfPbr(
        GltfPbr::new(Vec3::new(0.6, 0.4, 0.3), 0.3, 0.5).with_specular(
            2.0,
            0.7,
            Vec3::new(1.0, 0.6, 0.3),
        ),
    );
    for co in [0.95f32, 0.5, 0.1] {
        for ci in [0.8f32, 0.3] {
            let (wo, wi) = (dir(co, 0.3), dir(ci, 2.4));
            let (x, y) = (b.eval(wo, wi) / wi.z, b.eval(wi, wo) / wo.z);
            assert!(
                (x - y).abs().max_element() <= 1e-4 * x.max_element(),
                "{x} vs {y}"
            );
        }
    }
    let black = |ior| gltf(Vec3::ZERO, 0.5, ior, 1.0, Vec3::ONE).albedo().x;
    let (a15, a25) = (black(1.5), black(2.5));
    assert!(
        a15 > 0.03 && a15 < 0.06 && a25 > 0.15 && a25 < 0.22,
        "{a15} {a25}"
    );
}
