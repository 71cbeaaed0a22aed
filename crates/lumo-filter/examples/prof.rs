//! Profiling driver: runs one filter five times on the 1024² synthetic scene and prints each
//! call's wall time, a steady loop to attach a profiler to (`perf record`, callgrind).
//! `cargo run --release -p lumo-filter --example prof -- guided` profiles the exact guided
//! filter (normal + depth guide); any other argument, or none, the À-Trous filter (5
//! iterations, colour + normal + position). For timings to report, use the `speed` example.
use lumo_filter::*;
fn main() {
    let fr = synthetic_frame(1024, 1024, 1, 7);
    let f = Features {
        normal: Some(&fr.normal),
        position: Some(&fr.position),
        depth: Some(&fr.depth),
        ..Features::default()
    };
    let which = std::env::args().nth(1).unwrap_or_default();
    for _ in 0..5 {
        let t = std::time::Instant::now();
        match which.as_str() {
            "guided" => {
                let g = build_guide(GuideKind::NormalDepth, &f, DepthNorm::Range, 0.003, 0.003)
                    .unwrap();
                std::hint::black_box(guided(&fr.noisy, &g, &GuidedParams::default()).unwrap());
            }
            _ => {
                let p = AtrousParams {
                    iterations: 5,
                    sigma_color: Some(4.0),
                    sigma_luminance: None,
                    ..AtrousParams::default()
                };
                std::hint::black_box(atrous(&fr.noisy, &f, &p).unwrap());
            }
        }
        eprintln!("{:.1} ms", t.elapsed().as_secs_f64() * 1e3);
    }
}
