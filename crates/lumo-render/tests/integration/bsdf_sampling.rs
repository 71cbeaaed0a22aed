//! χ² goodness-of-fit of every BSDF's sampling routine against its own pdf, and energy
//! bounds (white furnace per BSDF).

use crate::common;

use common::chi2::{self, dir, Rng};
use glam::Vec3;
use lumo_render::bsdf::{
    fresnel_diffuse_reflectance, Bsdf, Conductor, Dielectric, Diffuse, Distribution, GltfPbr,
    Microfacet, Mirror, Plastic, RoughCoat,
};
use std::f32::consts::PI;

fn test_bsdfs() -> Vec<(&'static str, Bsdf)> {
    vec![
        (
            "diffuse",
            Bsdf::Diffuse(Diffuse {
                albedo: Vec3::new(0.8, 0.5, 0.2),
            }),
        ),
        (
            "conductor-0.2",
            Bsdf::Conductor(Conductor {
                eta: Vec3::new(0.2, 0.9, 1.1),
                k: Vec3::new(3.9, 2.4, 1.6),
                mf: Microfacet::ggx(0.2),
            }),
        ),
        (
            "conductor-0.6",
            Bsdf::Conductor(Conductor {
                eta: Vec3::splat(1.5),
                k: Vec3::splat(2.0),
                mf: Microfacet::ggx(0.6),
            }),
        ),
        (
            "conductor-beckmann-0.2",
            Bsdf::Conductor(Conductor {
                eta: Vec3::splat(1.5),
                k: Vec3::splat(2.0),
                mf: Microfacet::isotropic(Distribution::Beckmann, 0.2),
            }),
        ),
        (
            "conductor-beckmann-0.7",
            Bsdf::Conductor(Conductor {
                eta: Vec3::splat(1.5),
                k: Vec3::splat(2.0),
                mf: Microfacet::isotropic(Distribution::Beckmann, 0.7),
            }),
        ),
        (
            "conductor-beckmann-aniso",
            Bsdf::Conductor(Conductor {
                eta: Vec3::splat(1.5),
                k: Vec3::splat(2.0),
                mf: BECKMANN_ANISO,
            }),
        ),
        (
            "conductor-ggx-aniso",
            Bsdf::Conductor(Conductor {
                eta: Vec3::splat(1.5),
                k: Vec3::splat(2.0),
                mf: GGX_ANISO,
            }),
        ),
        (
            "gltf-dielectric-0.5",
            Bsdf::GltfPbr(GltfPbr::new(Vec3::new(0.8, 0.5, 0.2), 0.0, 0.5)),
        ),
        (
            "gltf-metal-0.3",
            Bsdf::GltfPbr(GltfPbr::new(Vec3::new(0.9, 0.6, 0.3), 1.0, 0.3)),
        ),
        (
            "gltf-mixed-0.8",
            Bsdf::GltfPbr(GltfPbr::new(Vec3::new(0.3, 0.6, 0.9), 0.4, 0.8)),
        ),
        (
            "gltf-smooth-mixed",
            Bsdf::GltfPbr(GltfPbr::new(Vec3::new(0.5, 0.5, 0.5), 0.5, 0.0)),
        ),
        (
            "gltf-ior-specular-0.4",
            Bsdf::GltfPbr(
                GltfPbr::new(Vec3::new(0.6, 0.5, 0.4), 0.2, 0.4).with_specular(
                    2.2,
                    0.6,
                    Vec3::new(1.0, 0.4, 0.2),
                ),
            ),
        ),
        (
            "gltf-thin-transmission-0.4",
            Bsdf::GltfPbr(
                GltfPbr::new(Vec3::new(0.9, 0.7, 0.4), 0.2, 0.4)
                    .with_specular(1.8, 0.8, Vec3::new(1.0, 0.7, 0.5))
                    .with_transmission(0.7, true, 1.8),
            ),
        ),
        (
            "gltf-volume-transmission-0.5",
            Bsdf::GltfPbr(
                GltfPbr::new(Vec3::new(0.8, 0.9, 0.6), 0.1, 0.5).with_transmission(0.8, false, 1.5),
            ),
        ),
        (
            "gltf-smooth-thin-transmission",
            Bsdf::GltfPbr(
                GltfPbr::new(Vec3::new(0.6, 0.8, 0.9), 0.0, 0.0).with_transmission(0.5, true, 1.5),
            ),
        ),
        (
            "gltf-clearcoat-0.2-over-0.7",
            Bsdf::GltfPbr(
                GltfPbr::new(Vec3::new(0.7, 0.3, 0.2), 0.3, 0.7).with_clearcoat(0.8, 0.2),
            ),
        ),
        (
            "gltf-smooth-clearcoat-over-transmission",
            Bsdf::GltfPbr(
                GltfPbr::new(Vec3::new(0.9, 0.8, 0.7), 0.0, 0.4)
                    .with_transmission(0.6, true, 1.5)
                    .with_clearcoat(1.0, 0.0),
            ),
        ),
        (
            // The coat's own normal (clearcoatNormalTexture) tilted 25° from the base's.
            "gltf-tilted-clearcoat-0.3-over-0.6",
            Bsdf::GltfPbr(
                GltfPbr::new(Vec3::new(0.7, 0.3, 0.2), 0.3, 0.6)
                    .with_clearcoat(0.9, 0.3)
                    .with_coat_normal(dir(0.906, 1.0)),
            ),
        ),
        (
            "gltf-tilted-smooth-clearcoat-over-transmission",
            Bsdf::GltfPbr(
                GltfPbr::new(Vec3::new(0.9, 0.8, 0.7), 0.0, 0.4)
                    .with_transmission(0.6, true, 1.5)
                    .with_clearcoat(1.0, 0.0)
                    .with_coat_normal(dir(0.8, 4.0)),
            ),
        ),
        (
            "gltf-sheen-0.3-over-0.6",
            Bsdf::GltfPbr(
                GltfPbr::new(Vec3::new(0.3, 0.2, 0.6), 0.0, 0.6)
                    .with_sheen(Vec3::new(0.9, 0.7, 0.5), 0.3),
            ),
        ),
        (
            "gltf-sheen-0.5-over-smooth-metal",
            Bsdf::GltfPbr(
                GltfPbr::new(Vec3::new(0.8, 0.6, 0.3), 1.0, 0.0).with_sheen(Vec3::ONE, 0.5),
            ),
        ),
        (
            "gltf-coat-over-sheen-over-transmission",
            Bsdf::GltfPbr(
                GltfPbr::new(Vec3::new(0.9, 0.8, 0.7), 0.0, 0.5)
                    .with_transmission(0.6, true, 1.5)
                    .with_clearcoat(0.6, 0.3)
                    .with_sheen(Vec3::new(0.4, 0.8, 0.6), 1.0),
            ),
        ),
        (
            "plastic-smooth",
            Bsdf::Plastic(Plastic {
                diffuse: Vec3::new(0.5, 0.4, 0.3),
                eta: 1.5,
                mf: Microfacet::ggx(0.0),
                fdr_int: fresnel_diffuse_reflectance(1.0 / 1.5),
                coat: None,
                nonlinear: false,
            }),
        ),
        (
            "plastic-rough",
            Bsdf::Plastic(Plastic {
                diffuse: Vec3::new(0.5, 0.4, 0.3),
                eta: 1.5,
                mf: Microfacet::ggx(0.3),
                fdr_int: fresnel_diffuse_reflectance(1.0 / 1.5),
                coat: None,
                nonlinear: false,
            }),
        ),
        (
            "plastic-ggx-coat",
            rough_plastic(Distribution::Ggx, 0.3, false),
        ),
        (
            "plastic-beckmann-coat",
            rough_plastic(Distribution::Beckmann, 0.15, false),
        ),
        (
            "plastic-beckmann-nonlinear",
            rough_plastic(Distribution::Beckmann, 0.5, true),
        ),
        (
            "dielectric-rough-0.3",
            Bsdf::Dielectric(Dielectric {
                eta: 1.5,
                mf: Microfacet::ggx(0.3),
            }),
        ),
        (
            "dielectric-rough-0.1",
            Bsdf::Dielectric(Dielectric {
                eta: 1.33,
                mf: Microfacet::ggx(0.1),
            }),
        ),
        (
            "dielectric-beckmann-0.3",
            Bsdf::Dielectric(Dielectric {
                eta: 1.5,
                mf: Microfacet::isotropic(Distribution::Beckmann, 0.3),
            }),
        ),
        (
            "dielectric-beckmann-aniso",
            Bsdf::Dielectric(Dielectric {
                eta: 1.5,
                mf: BECKMANN_ANISO,
            }),
        ),
        (
            "dielectric-ggx-aniso",
            Bsdf::Dielectric(Dielectric {
                eta: 1.33,
                mf: GGX_ANISO,
            }),
        ),
        // A dispersive glass as spectral transport sees it: BK7 at its hero wavelength.
        (
            "dielectric-bk7-420nm",
            Bsdf::Dielectric(Dielectric {
                eta: bk7_at(420.0),
                mf: Microfacet::ggx(0.2),
            }),
        ),
        (
            "dielectric-bk7-680nm",
            Bsdf::Dielectric(Dielectric {
                eta: bk7_at(680.0),
                mf: Microfacet::isotropic(Distribution::Beckmann, 0.2),
            }),
        ),
    ]
}

/// BK7's index at `lambda` nm, quoted as Mitsuba's 1.5046 at the d line.
fn bk7_at(lambda: f32) -> f32 {
    lumo_spectrum::Glass::named("bk7")
        .expect("bk7 is a known glass")
        .ior(1.5046, lambda)
}

const BECKMANN_ANISO: Microfacet = Microfacet {
    distribution: Distribution::Beckmann,
    alpha_u: 0.1,
    alpha_v: 0.4,
};

const GGX_ANISO: Microfacet = Microfacet {
    distribution: Distribution::Ggx,
    alpha_u: 0.4,
    alpha_v: 0.1,
};

/// Mitsuba's roughplastic (tabulated coat) over a coloured base, η = 1.5.
fn rough_plastic(distribution: Distribution, alpha: f32, nonlinear: bool) -> Bsdf {
    let mf = Microfacet::isotropic(distribution, alpha);
    let coat = RoughCoat::shared(mf, 1.5);
    Bsdf::Plastic(Plastic {
        diffuse: Vec3::new(0.5, 0.4, 0.3),
        eta: 1.5,
        mf,
        fdr_int: coat.internal_reflectance,
        coat: Some(coat),
        nonlinear,
    })
}

#[test]
fn chi2_sampling_matches_pdf() {
    let wos = [dir(0.9, 0.3), dir(0.4, 2.0), dir(0.15, 4.0)];
    let bsdfs = test_bsdfs();
    // Bonferroni: a 1 % chance that any of the tests rejects a correct sampler.
    let count = bsdfs.len() * wos.len() * 2;
    let mut tests = 0;
    let mut failures = vec![];
    for (name, bsdf) in bsdfs {
        for (k, wo) in wos.iter().enumerate() {
            for wo in [
                *wo,
                if matches!(bsdf, Bsdf::Dielectric(_)) || name.contains("transmission") {
                    -*wo
                } else {
                    *wo
                },
            ] {
                tests += 1;
                let p = chi2::sampling_p_value(&bsdf, wo, 7 + k as u64);
                println!("χ² {name:28} cos θo {:+.2}: p = {p:.3}", wo.z);
                if p < 0.01 / count as f64 {
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

#[test]
fn no_bsdf_creates_energy() {
    for (name, bsdf) in test_bsdfs() {
        for c in [1.0f32, 0.7, 0.3, 0.05] {
            let a = chi2::sampled_albedo(&bsdf, dir(c, 0.5), 200_000, 3);
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
            Bsdf::Mirror(Mirror {
                reflectance: Vec3::ONE,
            }),
        ),
        (
            "glass",
            Bsdf::Dielectric(Dielectric {
                eta: 1.5,
                mf: Microfacet::ggx(0.0),
            }),
        ),
        (
            "white diffuse",
            Bsdf::Diffuse(Diffuse { albedo: Vec3::ONE }),
        ),
    ];
    for (name, bsdf) in cases {
        for c in [1.0f32, 0.5, 0.1, -0.5, -0.9] {
            if c < 0.0 && !matches!(bsdf, Bsdf::Dielectric(_)) {
                continue;
            }
            let a = chi2::sampled_albedo(&bsdf, dir(c, 1.0), 50_000, 11);
            assert!(
                (a - Vec3::ONE).abs().max_element() < 5e-3,
                "{name} at cos {c}: {a:?}"
            );
        }
    }
    // Rough glass loses only what the microfacet shadowing term removes: a few percent.
    let a = chi2::sampled_albedo(
        &Bsdf::Dielectric(Dielectric {
            eta: 1.5,
            mf: Microfacet::ggx(0.1),
        }),
        dir(0.8, 0.0),
        200_000,
        5,
    );
    assert!(a.x > 0.95 && a.x <= 1.01, "rough glass albedo {a:?}");
}

/// `dir` in Mitsuba's convention for the test points below.
fn mdir(c: f32, phi: f32) -> Vec3 {
    dir(c, phi)
}

#[test]
// The reference values are kept as Mitsuba printed them (8 significant digits).
#[allow(clippy::excessive_precision)]
fn microfacet_bsdfs_evaluate_as_mitsuba() {
    // f·cos θ from Mitsuba 3.9.1 (scalar_rgb, `BSDF::eval`) for the viewer `wo` and light
    // `wi` pairs below: Beckmann and anisotropic distributions, and roughplastic's
    // tabulated coat (linear and nonlinear). Mitsuba's Beckmann shadowing is a rational fit
    // (< 0.35 % off the exact Λ lumo uses) and its coat tables come from its own sampling
    // warp, so agreement is to 1 %.
    let pairs = [
        (mdir(0.9, 0.3), mdir(0.7, 2.5)),
        (mdir(0.4, 2.0), mdir(0.5, 5.0)),
        (mdir(0.15, 4.0), mdir(0.8, 0.9)),
        (mdir(0.6, 1.0), mdir(0.6, 1.0 + PI)),
    ];
    let metal = |mf| {
        Bsdf::Conductor(Conductor {
            eta: Vec3::splat(1.5),
            k: Vec3::splat(2.0),
            mf,
        })
    };
    let cases: [(&str, Bsdf, [[f32; 3]; 4]); 6] = [
        (
            "roughplastic ggx 0.15",
            rough_plastic(Distribution::Ggx, 0.15, false),
            [
                [9.7627714e-02, 7.9008989e-02, 6.0390268e-02],
                [2.8883779e-01, 2.7728105e-01, 2.6572430e-01],
                [1.1103644e-01, 9.5119208e-02, 7.9201974e-02],
                [4.4904792e-01, 4.3382406e-01, 4.1860017e-01],
            ],
        ),
        (
            "roughplastic beckmann 0.3",
            rough_plastic(Distribution::Beckmann, 0.3, false),
            [
                [1.0739096e-01, 8.8388413e-02, 6.9385856e-02],
                [2.4861030e-01, 2.3682599e-01, 2.2504167e-01],
                [1.7460369e-01, 1.5723729e-01, 1.3987091e-01],
                [1.7245892e-01, 1.5698466e-01, 1.4151041e-01],
            ],
        ),
        (
            "roughplastic beckmann 0.3 nonlinear",
            rough_plastic(Distribution::Beckmann, 0.3, true),
            [
                [7.3137224e-02, 5.7716377e-02, 4.4239059e-02],
                [2.2736806e-01, 2.1780491e-01, 2.0944704e-01],
                [1.4329927e-01, 1.2920620e-01, 1.1688931e-01],
                [1.4456524e-01, 1.3200766e-01, 1.2103274e-01],
            ],
        ),
        (
            "roughconductor beckmann 0.2",
            metal(Microfacet::isotropic(Distribution::Beckmann, 0.2)),
            [
                [4.5167796e-02; 3],
                [1.3216864e+00; 3],
                [1.0975450e-01; 3],
                [1.4174004e+00; 3],
            ],
        ),
        (
            "roughconductor beckmann (0.1, 0.4)",
            metal(BECKMANN_ANISO),
            [
                [2.1399449e-01; 3],
                [2.3793393e-01; 3],
                [9.7530970e-04; 3],
                [1.4174004e+00; 3],
            ],
        ),
        (
            "roughconductor ggx (0.4, 0.1)",
            metal(GGX_ANISO),
            [
                [6.5622902e-03; 3],
                [1.6817318e+00; 3],
                [5.0487678e-02; 3],
                [1.3534284e+00; 3],
            ],
        ),
    ];
    let mut worst = 0.0f32;
    for (name, bsdf, expected) in cases {
        for ((wo, wi), e) in pairs.iter().zip(expected) {
            let got = bsdf.eval(*wo, *wi);
            let e = Vec3::from(e);
            let rel = ((got - e).abs() / e.max(Vec3::splat(1e-3))).max_element();
            worst = worst.max(rel);
            assert!(rel < 0.01, "{name} wo {wo} wi {wi}: lumo {got} Mitsuba {e}");
        }
    }
    // Rough dielectric, Beckmann α = 0.3, η = 1.5 / 1.000277 (Mitsuba's air): reflection and
    // transmission (the light below) for each pair.
    let glass = Bsdf::Dielectric(Dielectric {
        eta: 1.5 / 1.000_277,
        mf: Microfacet::isotropic(Distribution::Beckmann, 0.3),
    });
    let expected = [
        1.2362185e-02,
        0.0,
        1.8955983e-01,
        2.7783321e-05,
        8.7701455e-02,
        2.4629658e-01,
        9.4994836e-02,
        4.6160773e-07,
    ];
    for (k, (wo, wi)) in pairs.iter().enumerate() {
        for (j, wi) in [*wi, Vec3::new(wi.x, wi.y, -wi.z)].into_iter().enumerate() {
            let got = glass.eval(*wo, wi).x;
            let e = expected[2 * k + j];
            let rel = (got - e).abs() / e.max(1e-3);
            worst = worst.max(rel);
            assert!(
                rel < 0.01,
                "roughdielectric wo {wo} wi {wi}: lumo {got} Mitsuba {e}"
            );
        }
    }
    println!("worst relative difference from Mitsuba's eval: {worst:.2e}");
}

#[test]
fn lossless_rough_mirror_albedo_matches_its_integral() {
    // A conductor with F ≡ 1 (k huge) loses only what Smith shadowing removes: its sampled
    // albedo (mean of the weights G1) equals ∫ f cos θ dω by quadrature of `eval`, and stays
    // ≤ 1. A D or Λ that is not normalised, or a sampler that does not follow its pdf, breaks
    // the equality.
    for mf in [
        Microfacet::isotropic(Distribution::Beckmann, 0.3),
        Microfacet::isotropic(Distribution::Beckmann, 0.8),
        Microfacet::ggx(0.5),
        BECKMANN_ANISO,
        GGX_ANISO,
    ] {
        let bsdf = Bsdf::Conductor(Conductor {
            eta: Vec3::ONE,
            k: Vec3::splat(1e4),
            mf,
        });
        for c in [0.9f32, 0.5, 0.2] {
            let wo = dir(c, 0.7);
            let sampled = chi2::sampled_albedo(&bsdf, wo, 400_000, 17).x;
            let (nt, np) = (600, 600);
            let mut integral = 0.0f64;
            for i in 0..nt {
                let ct = (i as f32 + 0.5) / nt as f32;
                for j in 0..np {
                    let phi = (j as f32 + 0.5) / np as f32 * 2.0 * PI;
                    integral += bsdf.eval(wo, dir(ct, phi)).x as f64;
                }
            }
            integral *= 2.0 * std::f64::consts::PI / (nt * np) as f64;
            println!("{mf:?} cos θo {c}: sampled {sampled:.4}, integral {integral:.4}");
            assert!(
                sampled <= 1.0 && integral <= 1.0 + 2e-3,
                "{mf:?}: gains energy"
            );
            assert!(
                (sampled as f64 - integral).abs() < 5e-3,
                "{mf:?} cos θo {c}: sampled {sampled}, integral {integral}"
            );
        }
    }
}

/// The G-buffer albedo of a plastic (`Bsdf::albedo_towards`: the coat's reflectance plus the
/// base through it) is its directional albedo, which the sample weights measure: it must
/// explain the coat's reflection, which grows towards grazing views, or a denoiser dividing by
/// a dark base channel turns that reflection into coloured fringes (docs/filters.md, issue 47).
#[test]
fn a_plastics_gbuffer_albedo_is_its_directional_albedo() {
    let smooth = Bsdf::Plastic(Plastic {
        diffuse: Vec3::new(0.8, 0.2, 0.007),
        eta: 1.5,
        mf: Microfacet::ggx(0.0),
        fdr_int: fresnel_diffuse_reflectance(1.0 / 1.5),
        coat: None,
        nonlinear: false,
    });
    for (name, bsdf) in [
        ("smooth", smooth),
        ("ggx coat", rough_plastic(Distribution::Ggx, 0.3, false)),
        (
            "ggx coat, nonlinear",
            rough_plastic(Distribution::Ggx, 0.3, true),
        ),
    ] {
        for c in [1.0f32, 0.5, 0.2, 0.08] {
            let wo = dir(c, 0.5);
            let measured = chi2::sampled_albedo(&bsdf, wo, 400_000, 11);
            let g = bsdf.albedo_towards(wo);
            for k in 0..3 {
                assert!(
                    (g[k] - measured[k]).abs() <= 0.03 * measured[k] + 0.005,
                    "{name} at cos {c}: G-buffer albedo {g:?}, directional albedo {measured:?}"
                );
            }
        }
    }
}
