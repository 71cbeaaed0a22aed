//! Parameter sweep on the synthetic scene (lumo_filter::synthetic): prints, per filter, the
//! error against the noise-free reference for a grid of parameters, at 1 and 4 spp.
//! Run: `cargo run --release -p lumo-filter --example sweep`. Results: docs/filters.md.

use lumo_filter::*;
use lumo_image::Image;

fn mse(a: &Image, b: &Image) -> f64 {
    a.data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| ((x - y) as f64).powi(2))
        .sum::<f64>()
        / a.data.len() as f64
}

/// Relative MSE: (x − ref)² / (ref² + 0.01), averaged.
fn rel_mse(a: &Image, b: &Image) -> f64 {
    a.data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| ((x - y) as f64).powi(2) / ((*y as f64).powi(2) + 0.01))
        .sum::<f64>()
        / a.data.len() as f64
}

fn feats(fr: &SyntheticFrame, var: bool) -> Features<'_> {
    Features {
        normal: Some(&fr.normal),
        position: Some(&fr.position),
        depth: Some(&fr.depth),
        albedo: Some(&fr.albedo),
        variance: if var { Some(&fr.variance) } else { None },
    }
}

struct Row {
    name: String,
    err: Vec<(f64, f64)>,
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let which = args.get(1).map(String::as_str).unwrap_or("all");
    let (w, h) = (320, 240);
    let frames: Vec<(usize, SyntheticFrame)> = [(1usize, 11u64), (1, 12), (4, 13)]
        .iter()
        .map(|&(spp, seed)| (spp, synthetic_frame(w, h, spp, seed)))
        .collect();
    let mut rows: Vec<Row> = Vec::new();
    let mut eval = |name: String, f: &dyn Fn(&SyntheticFrame) -> Image| {
        let err = frames
            .iter()
            .map(|(_, fr)| {
                let o = f(fr);
                (mse(&o, &fr.reference), rel_mse(&o, &fr.reference))
            })
            .collect();
        rows.push(Row { name, err });
    };
    eval("noisy input".into(), &|fr| fr.noisy.clone());
    if which == "all" || which == "atrous" {
        for it in [4usize, 5, 6] {
            for sc in [None, Some(4.0f32), Some(16.0), Some(64.0), Some(256.0)] {
                for sn in [0.1f32, 0.3, 1.0] {
                    for sx in [0.02f32, 0.05, 0.1, 0.2] {
                        let p = AtrousParams {
                            iterations: it,
                            sigma_color: sc,
                            sigma_luminance: None,
                            sigma_normal: Some(sn),
                            sigma_position: Some(sx),
                            demodulate: true,
                            ..AtrousParams::default()
                        };
                        eval(format!("atrous it={it} c={sc:?} n={sn} x={sx}"), &|fr| {
                            atrous(&fr.noisy, &feats(fr, false), &p).unwrap().image
                        });
                    }
                }
            }
        }
        for sc in [4.0f32, 16.0, 32.0, 64.0] {
            for sx in [0.05f32, 0.1, 0.2] {
                let p = AtrousParams {
                    sigma_luminance: Some(sc),
                    sigma_normal: Some(0.3),
                    sigma_position: Some(sx),
                    demodulate: true,
                    ..AtrousParams::default()
                };
                eval(format!("atrous+variance c={sc} n=0.3 x={sx}"), &|fr| {
                    atrous(&fr.noisy, &feats(fr, true), &p).unwrap().image
                });
            }
        }
    }
    if which == "all" || which == "guided" {
        for r in [8usize, 12, 16, 24, 32] {
            for eps in [1e-3f32, 3e-3, 1e-2, 3e-2, 0.1] {
                for (kind, kn) in [(GuideKind::Normal, 3), (GuideKind::NormalDepth, 4)] {
                    eval(format!("guided d={kn} r={r} eps={eps}"), &|fr| {
                        let f = feats(fr, false);
                        let g = build_guide(kind, &f, DepthNorm::Range, eps, eps).unwrap();
                        with_demodulation(&fr.noisy, &fr.albedo, |c| {
                            guided(
                                c,
                                &g,
                                &GuidedParams {
                                    radius: r,
                                    fast_subsample: 1,
                                },
                            )
                        })
                        .unwrap()
                        .image
                    });
                }
            }
        }
        for s in [2usize, 4, 8] {
            eval(format!("guided d=4 r=16 eps=0.01 fast s={s}"), &|fr| {
                let f = feats(fr, false);
                let g =
                    build_guide(GuideKind::NormalDepth, &f, DepthNorm::Range, 0.01, 0.01).unwrap();
                with_demodulation(&fr.noisy, &fr.albedo, |c| {
                    guided(
                        c,
                        &g,
                        &GuidedParams {
                            radius: 16,
                            fast_subsample: s,
                        },
                    )
                })
                .unwrap()
                .image
            });
        }
    }
    if which == "all" || which == "bilateral" {
        for r in [8usize, 16] {
            for ss in [r as f32 / 4.0, r as f32 / 2.0] {
                for sn in [0.1f32, 0.3, 1.0] {
                    for sd in [0.02f32, 0.05, 0.2] {
                        let p = BilateralParams {
                            radius: r,
                            sigma_spatial: ss,
                            sigma_normal: Some(sn),
                            sigma_depth: Some(sd),
                            sigma_position: None,
                            sigma_color: None,
                        };
                        eval(format!("bilateral r={r} s={ss} n={sn} d={sd}"), &|fr| {
                            with_demodulation(&fr.noisy, &fr.albedo, |c| {
                                bilateral(c, &feats(fr, false), &p)
                            })
                            .unwrap()
                            .image
                        });
                    }
                }
            }
        }
    }
    println!("| configuration | MSE 1spp (a) | MSE 1spp (b) | MSE 4spp | relMSE 1spp (a) | relMSE 4spp |");
    println!("|---|---|---|---|---|---|");
    for r in &rows {
        println!(
            "| {} | {:.5} | {:.5} | {:.5} | {:.5} | {:.5} |",
            r.name, r.err[0].0, r.err[1].0, r.err[2].0, r.err[0].1, r.err[2].1
        );
    }
}
