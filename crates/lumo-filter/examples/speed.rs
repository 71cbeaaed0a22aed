//! Times one filter configuration on the synthetic scene, for A/B comparisons of kernels:
//! `speed W H WHAT N` runs WHAT N times and prints the median wall time. WHAT is one of
//! a3 (À-Trous 5 it, colour + normal + position), a10 (the same, 10 it), av (5 it,
//! variance-guided + normal + position), g1 / g3 / g4 (exact guided filter, 1 / 3 / 4 dims,
//! r = 24), gf3 (fast guided, 3 dims, s = 4), t (one `TemporalFilter` step: reprojection with
//! a (0.5, 0.25) px motion, accumulation, variance and the variance-guided À-Trous, in the
//! steady state after 4 frames), tv (that step's À-Trous alone, to subtract), none (only build
//! the frame, to subtract its cost). Also prints ms per megapixel.
//! On a shared machine, compare CPU time instead of wall time:
//! `RAYON_NUM_THREADS=1 perf stat -e task-clock speed 512 512 a3 5` minus the `none` run.

use std::time::Instant;

use lumo_filter::*;
use lumo_image::Image;

fn median_ms<F: FnMut()>(n: usize, mut f: F) -> f64 {
    let mut t: Vec<f64> = (0..n)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(|a, b| a.total_cmp(b));
    t[n / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let num =
        |i: usize, default: usize| args.get(i).and_then(|s| s.parse().ok()).unwrap_or(default);
    let (w, h, n) = (num(1, 512), num(2, 512), num(4, 7).max(1));
    let what = args.get(3).map_or("a3", |s| s.as_str());
    let fr = synthetic_frame(w, h, 1, 7);
    let f = Features {
        normal: Some(&fr.normal),
        position: Some(&fr.position),
        depth: Some(&fr.depth),
        ..Features::default()
    };
    let fixed = |iterations| AtrousParams {
        iterations,
        sigma_color: Some(4.0),
        sigma_luminance: None,
        sigma_normal: Some(0.3),
        sigma_position: Some(0.1),
        ..AtrousParams::default()
    };
    let guided_run = |kind, s| {
        let Ok(g) = build_guide(kind, &f, DepthNorm::Range, 0.003, 0.003) else {
            return f64::NAN;
        };
        let p = GuidedParams {
            radius: 24,
            fast_subsample: s,
        };
        median_ms(n, || {
            std::hint::black_box(guided(&fr.noisy, &g, &p).ok());
        })
    };
    let ms = match what {
        "a3" | "a10" => {
            let p = fixed(if what == "a3" { 5 } else { 10 });
            median_ms(n, || {
                std::hint::black_box(atrous(&fr.noisy, &f, &p).ok());
            })
        }
        "av" => {
            let fv = Features {
                variance: Some(&fr.variance),
                ..f
            };
            let p = AtrousParams::default();
            median_ms(n, || {
                std::hint::black_box(atrous(&fr.noisy, &fv, &p).ok());
            })
        }
        "t" | "tv" => {
            let frames = [fr.clone(), synthetic_frame(w, h, 1, 8)];
            let mut motion = Image::new(w, h, 2, 0.0);
            for m in motion.data.chunks_exact_mut(2) {
                m[0] = 0.5;
                m[1] = 0.25;
            }
            let mut filter = TemporalFilter::new(TemporalParams::default()).expect("defaults");
            let mut k = 0;
            let mut step = |filter: &mut TemporalFilter| {
                let f = &frames[k % 2];
                k += 1;
                let input = TemporalFrame {
                    color: &f.noisy,
                    albedo: Some(&f.albedo),
                    normal: &f.normal,
                    depth: &f.depth,
                    position: Some(&f.position),
                    ids: None,
                    motion: Some(&motion),
                };
                std::hint::black_box(filter.filter(&input).ok());
            };
            for _ in 0..4 {
                step(&mut filter);
            }
            if what == "t" {
                median_ms(n, || step(&mut filter))
            } else {
                let var = filter.variance().clone();
                let fv = Features {
                    variance: Some(&var),
                    ..f
                };
                let mut p = filter.params().atrous.clone();
                p.demodulate = false;
                let mut a = AtrousFilter::new();
                median_ms(n, || {
                    std::hint::black_box(a.filter(&fr.noisy, &fv, &p).ok());
                })
            }
        }
        "g1" => guided_run(GuideKind::Grey, 1),
        "g3" => guided_run(GuideKind::Normal, 1),
        "g4" => guided_run(GuideKind::NormalDepth, 1),
        "gf3" => guided_run(GuideKind::Normal, 4),
        "none" => 0.0,
        other => {
            eprintln!(
                "unknown configuration {other}: use a3, a10, av, g1, g3, g4, gf3, t, tv or none"
            );
            std::process::exit(2);
        }
    };
    let mp = (w * h) as f64 / 1e6;
    println!(
        "{what} {w}x{h}: {ms:.1} ms (median of {n}), {:.1} ms per megapixel, {} threads",
        ms / mp,
        rayon::current_num_threads()
    );
}
