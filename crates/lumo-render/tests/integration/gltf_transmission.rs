//! KHR_materials_transmission on glTF's BSDF: a white, non-absorbing transmissive material
//! reflects and transmits all it receives (a thin sheet exactly what a white metal of the
//! same roughness reflects, the microfacet lobe being the same), from either side; the thin
//! sheet's head-on transmittance is (1 − F0) × base colour; the volume boundary refracts as
//! lumo's dielectric of that index, tinted; and the BSDF stays reciprocal.

use glam::{Vec2, Vec3};
use lumo_render::bsdf::{Bsdf, Dielectric, GltfPbr, Microfacet};

use crate::common::bsdf_grid::{albedo_split, dir};

fn gltf(base: Vec3, metallic: f32, r: f32, t: f32, thin: bool) -> Bsdf {
    Bsdf::GltfPbr(GltfPbr::new(base, metallic, r).with_transmission(t, thin, 1.5))
}

/// A white thin sheet reflects and transmits, together, what a white metal reflects (1 when
/// smooth); at transmission 0.5 the diffuse half adds what the layer leaves; from both sides.
#[test]
fn a_white_thin_sheet_conserves_energy_like_a_white_metal() {
    for r in [0.0f32, 0.2, 0.5, 0.8] {
        let metal = Bsdf::GltfPbr(GltfPbr::new(Vec3::ONE, 1.0, r));
        for c in [1.0f32, 0.6, 0.25, 0.05] {
            let (m, _) = albedo_split(&metal, dir(c, 0.2), 300);
            for side in [1.0f32, -1.0] {
                let wo = dir(c, 0.2) * side;
                let (rf, tr) = albedo_split(&gltf(Vec3::ONE, 0.0, r, 1.0, true), wo, 300);
                let total = rf + tr;
                assert!(
                    (total - m).abs().max_element() < 0.01 && total.max_element() <= 1.005,
                    "roughness {r}, cos θo {}: {rf} + {tr} vs metal {m}",
                    wo.z
                );
                if c >= 0.6 {
                    assert!(tr.min_element() > 0.5, "{tr}");
                }
                if r == 0.0 {
                    assert!((total - Vec3::ONE).abs().max_element() < 1e-4, "{total}");
                }
            }
        }
    }
}

/// A white volume boundary reflects and refracts all it receives when smooth, from outside
/// and from inside (total internal reflection included), and never more when rough.
#[test]
fn a_white_volume_boundary_conserves_energy() {
    for r in [0.0f32, 0.3, 0.7] {
        for c in [1.0f32, 0.6, 0.25, 0.05, -0.3, -0.9] {
            let wo = dir(c, 0.7);
            let (rf, tr) = albedo_split(&gltf(Vec3::ONE, 0.0, r, 1.0, false), wo, 300);
            // Radiance entering the denser side is compressed by 1/η² (and expanded leaving
            // it): energy is the refracted weight with that factor taken out.
            let eta2 = if c > 0.0 {
                1.5f32 * 1.5
            } else {
                1.0 / (1.5 * 1.5)
            };
            let energy = rf + tr * eta2;
            assert!(
                energy.max_element() <= 1.005,
                "roughness {r}, cos θo {c}: {energy}"
            );
            if r == 0.0 {
                assert!(
                    (energy - Vec3::ONE).abs().max_element() < 1e-3,
                    "{c}: {energy}"
                );
            }
        }
    }
}

/// Half transmissive, half opaque white dielectric: what it reflects and transmits adds to
/// 1 (smooth: both parts are lossless).
#[test]
fn partial_transmission_mixes_without_losing_or_making_energy() {
    for c in [1.0f32, 0.5, 0.1] {
        let (rf, tr) = albedo_split(&gltf(Vec3::ONE, 0.0, 0.0, 0.5, true), dir(c, 0.0), 400);
        let total = rf + tr;
        assert!(
            (total - Vec3::ONE).abs().max_element() < 0.01,
            "{c}: {rf} + {tr}"
        );
        // Half the light meets the sheet, which passes 1 − F of it.
        let f = 0.04 + 0.96 * (1.0 - c).powi(5);
        assert!(
            (tr - Vec3::splat(0.5 * (1.0 - f))).abs().max_element() < 0.01,
            "{tr}"
        );
    }
    // A metal does not transmit, whatever the transmission factor.
    let (_, tr) = albedo_split(&gltf(Vec3::ONE, 1.0, 0.3, 1.0, true), dir(0.7, 0.0), 100);
    assert_eq!(tr, Vec3::ZERO);
}

/// Head-on, a smooth thin sheet transmits (1 − F0) × base colour straight through; a volume
/// boundary refracts as lumo's smooth dielectric, its refracted weight tinted.
#[test]
fn smooth_transmittance_is_the_fresnel_complement_tinted_by_the_base_colour() {
    let base = Vec3::new(0.9, 0.5, 0.2);
    let thin = Bsdf::GltfPbr(
        GltfPbr::new(base, 0.0, 0.0)
            .with_specular(2.0, 1.0, Vec3::ONE)
            .with_transmission(1.0, true, 2.0),
    );
    let (_, tr) = albedo_split(&thin, Vec3::Z, 32);
    let f0 = 1.0f32 / 9.0;
    assert!((tr - base * (1.0 - f0)).abs().max_element() < 2e-3, "{tr}");
    let wo = dir(0.6, 0.4);
    let s = (0..64)
        .filter_map(|k| thin.sample(wo, k as f32 / 64.0, Vec2::splat(0.5)))
        .find(|s| s.wi.z < 0.0)
        .expect("a transmitted sample");
    assert!(
        (s.wi + wo).length() < 1e-6,
        "thin sheets do not bend light: {}",
        s.wi
    );

    let volume = gltf(base, 0.0, 0.0, 1.0, false);
    let glass = Bsdf::Dielectric(Dielectric {
        eta: 1.5,
        mf: Microfacet::ggx(0.0),
    });
    for u_lobe in [0.01f32, 0.5, 0.99] {
        let (a, b) = (
            volume.sample(wo, u_lobe, Vec2::splat(0.5)).unwrap(),
            glass.sample(wo, u_lobe, Vec2::splat(0.5)).unwrap(),
        );
        assert!((a.wi - b.wi).length() < 1e-6 && a.eta == b.eta);
        let tint = if a.wi.z < 0.0 { base } else { Vec3::ONE };
        assert!((a.weight - b.weight * tint).abs().max_element() < 1e-5);
    }
}

/// f(wo, wi)/|cos θi| = f(wi, wo)/|cos θo| for the thin sheet and the opaque part, in
/// reflection and through the sheet.
#[test]
fn the_thin_sheet_is_reciprocal() {
    let b = Bsdf::GltfPbr(
        GltfPbr::new(Vec3::new(0.7, 0.5, 0.3), 0.2, 0.45)
            .with_specular(1.7, 0.8, Vec3::new(1.0, 0.8, 0.6))
            .with_transmission(0.6, true, 1.7),
    );
    for co in [0.9f32, 0.5, -0.3] {
        for ci in [0.8f32, 0.2, -0.6, -0.95] {
            let (wo, wi) = (dir(co, 0.3), dir(ci, 2.9));
            let (x, y) = (b.eval(wo, wi) / wi.z.abs(), b.eval(wi, wo) / wo.z.abs());
            assert!(
                (x - y).abs().max_element() <= 1e-4 * x.max_element().max(1e-6),
                "{co} {ci}: {x} vs {y}"
            );
            assert!(x.max_element() > 0.0, "{co} {ci}");
        }
    }
}
