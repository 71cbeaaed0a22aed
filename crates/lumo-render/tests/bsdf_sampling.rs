//! χ² goodness-of-fit of every BSDF's sampling routine against its own pdf, and energy
//! bounds (white furnace per BSDF).

mod common;

use common::chi2::{self, dir};
use glam::{Vec2, Vec3};
use lumo_render::bsdf::{fresnel_diffuse_reflectance, Bsdf};
use std::f32::consts::PI;

/// xorshift64*: independent uniform numbers for the tests (not the renderer's Sobol points).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32) / (1u64 << 24) as f32
    }
    fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next(), self.next())
    }
}

fn test_bsdfs() -> Vec<(&'static str, Bsdf)> {
    vec![
        (
            "diffuse",
            Bsdf::Diffuse {
                albedo: Vec3::new(0.8, 0.5, 0.2),
            },
        ),
        (
            "conductor-0.2",
            Bsdf::Conductor {
                eta: Vec3::new(0.2, 0.9, 1.1),
                k: Vec3::new(3.9, 2.4, 1.6),
                alpha: 0.2,
            },
        ),
        (
            "conductor-0.6",
            Bsdf::Conductor {
                eta: Vec3::splat(1.5),
                k: Vec3::splat(2.0),
                alpha: 0.6,
            },
        ),
        (
            "plastic-smooth",
            Bsdf::Plastic {
                diffuse: Vec3::new(0.5, 0.4, 0.3),
                eta: 1.5,
                alpha: 0.0,
                fdr_int: fresnel_diffuse_reflectance(1.0 / 1.5),
            },
        ),
        (
            "plastic-rough",
            Bsdf::Plastic {
                diffuse: Vec3::new(0.5, 0.4, 0.3),
                eta: 1.5,
                alpha: 0.3,
                fdr_int: fresnel_diffuse_reflectance(1.0 / 1.5),
            },
        ),
        (
            "dielectric-rough-0.3",
            Bsdf::Dielectric {
                eta: 1.5,
                alpha: 0.3,
            },
        ),
        (
            "dielectric-rough-0.1",
            Bsdf::Dielectric {
                eta: 1.33,
                alpha: 0.1,
            },
        ),
    ]
}

/// Runs the χ² test of `bsdf`'s sampling for outgoing direction `wo`; returns the p-value.
fn chi2_test(bsdf: &Bsdf, wo: Vec3, seed: u64) -> f64 {
    let (nt, np) = (20usize, 40usize);
    let n = 400_000usize;
    let mut observed = vec![0f64; nt * np];
    let mut rng = Rng(seed);
    for _ in 0..n {
        let u_lobe = rng.next();
        if let Some(s) = bsdf.sample(wo, u_lobe, rng.next_2d()) {
            if !s.delta {
                observed[chi2::cell(s.wi, nt, np)] += 1.0;
            }
        }
    }
    let expected = chi2::expected_counts(nt, np, 12, n, |wi| bsdf.pdf(wo, wi));
    let (p, terms) = chi2::p_value(&observed, &expected);
    assert!(terms > 1, "χ² test saw no non-delta samples and no density");
    p
}

#[test]
fn chi2_sampling_matches_pdf() {
    let wos = [dir(0.9, 0.3), dir(0.4, 2.0), dir(0.15, 4.0)];
    let mut tests = 0;
    let mut failures = vec![];
    for (name, bsdf) in test_bsdfs() {
        for (k, wo) in wos.iter().enumerate() {
            for wo in [
                *wo,
                if matches!(bsdf, Bsdf::Dielectric { .. }) {
                    -*wo
                } else {
                    *wo
                },
            ] {
                tests += 1;
                let p = chi2_test(&bsdf, wo, 7 + k as u64);
                if p < 0.01 / 40.0 {
                    failures.push(format!("{name} wo={wo:?}: p = {p:.2e}"));
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {tests} χ² tests rejected:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn sample_weight_equals_eval_over_pdf() {
    let mut rng = Rng(99);
    for (name, bsdf) in test_bsdfs() {
        for _ in 0..2000 {
            let wo = dir(rng.next() * 0.98 + 0.01, rng.next() * 2.0 * PI);
            if let Some(s) = bsdf.sample(wo, rng.next(), rng.next_2d()) {
                if s.delta {
                    continue;
                }
                let f = bsdf.eval(wo, s.wi);
                let pdf = bsdf.pdf(wo, s.wi);
                assert!(
                    (pdf - s.pdf).abs() <= 1e-3 * pdf.max(1.0),
                    "{name}: pdf {pdf} vs {}",
                    s.pdf
                );
                let w = f / pdf;
                assert!(
                    (w - s.weight).abs().max_element() <= 2e-3 * w.max_element().max(1.0),
                    "{name}: {w:?} vs {:?}",
                    s.weight
                );
            }
        }
    }
}

/// Mean of the sample weights: the directional albedo (with 1/η² radiance scaling undone, so
/// it measures energy).
fn albedo(bsdf: &Bsdf, wo: Vec3, n: usize, seed: u64) -> Vec3 {
    let mut rng = Rng(seed);
    let mut sum = Vec3::ZERO;
    for _ in 0..n {
        if let Some(s) = bsdf.sample(wo, rng.next(), rng.next_2d()) {
            sum += s.weight * (s.eta * s.eta);
        }
    }
    sum / n as f32
}

#[test]
fn no_bsdf_creates_energy() {
    for (name, bsdf) in test_bsdfs() {
        for c in [1.0f32, 0.7, 0.3, 0.05] {
            let a = albedo(&bsdf, dir(c, 0.5), 200_000, 3);
            assert!(a.max_element() <= 1.01, "{name} at cos {c}: albedo {a:?}");
        }
    }
}

#[test]
fn lossless_bsdfs_reflect_everything() {
    // Mirror and smooth glass conserve energy exactly; a white Lambertian reflects all.
    let cases = [
        (
            "mirror",
            Bsdf::Mirror {
                reflectance: Vec3::ONE,
            },
        ),
        (
            "glass",
            Bsdf::Dielectric {
                eta: 1.5,
                alpha: 0.0,
            },
        ),
        ("white diffuse", Bsdf::Diffuse { albedo: Vec3::ONE }),
    ];
    for (name, bsdf) in cases {
        for c in [1.0f32, 0.5, 0.1, -0.5, -0.9] {
            if c < 0.0 && !matches!(bsdf, Bsdf::Dielectric { .. }) {
                continue;
            }
            let a = albedo(&bsdf, dir(c, 1.0), 50_000, 11);
            assert!(
                (a - Vec3::ONE).abs().max_element() < 5e-3,
                "{name} at cos {c}: {a:?}"
            );
        }
    }
    // Rough glass loses only what the microfacet shadowing term removes: a few percent.
    let a = albedo(
        &Bsdf::Dielectric {
            eta: 1.5,
            alpha: 0.1,
        },
        dir(0.8, 0.0),
        200_000,
        5,
    );
    assert!(a.x > 0.95 && a.x <= 1.01, "rough glass albedo {a:?}");
}
