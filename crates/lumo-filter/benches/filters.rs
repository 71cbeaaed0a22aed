//! Filter timings in the shape of the papers' Table 2: median wall time (ms) of several runs on
//! the synthetic scene at 512², 1024² and 1920×1080. Plain std::time, no harness.
//! `cargo bench -p lumo-filter` runs everything; pass `atrous`, `guided` or `bilateral` after
//! `--` to run one group. Results are recorded in docs/filter-benchmarks.md.

use std::time::Instant;

use lumo_filter::*;

const RESOLUTIONS: [(usize, usize); 3] = [(512, 512), (1024, 1024), (1920, 1080)];

/// Median time in ms. Up to 5 runs; a first run over 4 s drops to 3 runs and one over 20 s
/// to that single run (the repeat count is printed beside the time).
fn time<F: FnMut()>(mut f: F) -> (f64, usize) {
    let t = Instant::now();
    f();
    let first = t.elapsed().as_secs_f64() * 1e3;
    let runs = if first > 20_000.0 {
        1
    } else if first > 4_000.0 {
        3
    } else {
        5
    };
    let mut times = vec![first];
    for _ in 1..runs {
        let t = Instant::now();
        f();
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(|a, b| a.total_cmp(b));
    (times[times.len() / 2], runs)
}

fn cell((ms, runs): (f64, usize)) -> String {
    if runs == 5 {
        format!("{ms:.1}")
    } else {
        format!("{ms:.1} ({runs}×)")
    }
}

fn main() {
    let which: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let wants = |g: &str| which.is_empty() || which.iter().any(|w| w == g);
    let frames: Vec<SyntheticFrame> = RESOLUTIONS
        .iter()
        .map(|&(w, h)| synthetic_frame(w, h, 1, 7))
        .collect();
    println!("threads: {}", rayon::current_num_threads());
    println!();
    println!("| filter | configuration | 512×512 ms | 1024×1024 ms | 1920×1080 ms |");
    println!("|---|---|---|---|---|");
    let row = |name: &str, cfg: &str, f: &dyn Fn(&SyntheticFrame)| {
        let cells: Vec<String> = frames.iter().map(|fr| cell(time(|| f(fr)))).collect();
        println!("| {name} | {cfg} | {} |", cells.join(" | "));
    };
    if wants("atrous") {
        for it in [1usize, 5, 10] {
            for weights in 0..=3 {
                let p = AtrousParams {
                    iterations: it,
                    sigma_color: (weights >= 1).then_some(4.0),
                    sigma_luminance: None,
                    sigma_normal: (weights >= 2).then_some(0.3),
                    sigma_position: (weights >= 3).then_some(0.1),
                    ..AtrousParams::default()
                };
                let names = ["none", "colour", "colour+normal", "colour+normal+position"];
                row(
                    "À-Trous",
                    &format!("{it} it, {weights} weights ({})", names[weights]),
                    &|fr| {
                        let f = Features {
                            normal: Some(&fr.normal),
                            position: Some(&fr.position),
                            depth: Some(&fr.depth),
                            ..Features::default()
                        };
                        std::hint::black_box(atrous(&fr.noisy, &f, &p).unwrap());
                    },
                );
            }
        }
        let p = AtrousParams::default();
        row(
            "À-Trous",
            "5 it, variance-guided + normal + position",
            &|fr| {
                let f = Features {
                    normal: Some(&fr.normal),
                    position: Some(&fr.position),
                    depth: Some(&fr.depth),
                    variance: Some(&fr.variance),
                    ..Features::default()
                };
                std::hint::black_box(atrous(&fr.noisy, &f, &p).unwrap());
            },
        );
    }
    if wants("guided") {
        for (kind, d) in [
            (GuideKind::Grey, 1),
            (GuideKind::Normal, 3),
            (GuideKind::NormalDepth, 4),
        ] {
            for s in [1usize, 4] {
                let label = if s == 1 {
                    "exact".to_string()
                } else {
                    format!("fast s={s}")
                };
                row(
                    "guided",
                    &format!("{d} dims, r=24, {label} (incl. guide build)"),
                    &|fr| {
                        let f = Features {
                            normal: Some(&fr.normal),
                            depth: Some(&fr.depth),
                            ..Features::default()
                        };
                        let g = build_guide(kind, &f, DepthNorm::Range, 0.003, 0.003).unwrap();
                        let p = GuidedParams {
                            radius: 24,
                            fast_subsample: s,
                        };
                        std::hint::black_box(guided(&fr.noisy, &g, &p).unwrap());
                    },
                );
            }
        }
    }
    if wants("bilateral") {
        for r in [16usize, 24, 32] {
            let p = BilateralParams {
                radius: r,
                sigma_spatial: r as f32 / 2.0,
                ..BilateralParams::default()
            };
            row(
                "cross bilateral",
                &format!("r={r}, normal + depth"),
                &|fr| {
                    let f = Features {
                        normal: Some(&fr.normal),
                        depth: Some(&fr.depth),
                        ..Features::default()
                    };
                    std::hint::black_box(bilateral(&fr.noisy, &f, &p).unwrap());
                },
            );
        }
    }
}
