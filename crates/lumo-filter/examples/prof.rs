//! Profiling driver: runs one filter in a steady loop on a synthetic scene and prints each
//! call's wall time and the CPU time per call, a loop to attach a profiler to (`perf record`, callgrind).
//! `cargo run --release -p lumo-filter --example prof -- guided` profiles the exact guided
//! filter (normal + depth guide, 1024², 5 calls); `-- emitters` the light search (512², a
//! light pasted in as the `filters` bench does, 200 calls); any other argument, or none, the
//! À-Trous filter (1024², 5 calls; 5 iterations, colour + normal + position). For timings to
//! report, use the `speed` example or `cargo bench -p lumo-filter`.
use lumo_filter::*;
fn main() {
    let which = std::env::args().nth(1).unwrap_or_default();
    let size = if which == "emitters" { 512 } else { 1024 };
    let fr = synthetic_frame(size, size, 1, 7);
    let (mut lit, mut lit_albedo) = (fr.noisy.clone(), fr.albedo.clone());
    for y in size * 6 / 10..size * 7 / 10 {
        for x in size / 5..size * 3 / 10 {
            lit.pixel_mut(x, y).fill(20.0);
            lit_albedo.pixel_mut(x, y).fill(0.75);
        }
    }
    let f = Features {
        normal: Some(&fr.normal),
        position: Some(&fr.position),
        depth: Some(&fr.depth),
        ..Features::default()
    };
    let calls = if which == "emitters" { 200 } else { 5 };
    let mut times = Vec::with_capacity(calls);
    let cpu0 = cpu_ns();
    for _ in 0..calls {
        let t = std::time::Instant::now();
        match which.as_str() {
            "guided" => {
                let g = build_guide(GuideKind::NormalDepth, &f, DepthNorm::Range, 0.003, 0.003)
                    .unwrap();
                std::hint::black_box(guided(&fr.noisy, &g, &GuidedParams::default()).unwrap());
            }
            "emitters" => {
                let f = Features {
                    albedo: Some(&lit_albedo),
                    ..f
                };
                let p = EmitterParams::default();
                let mask = detect_emitters(&lit, &f, &p).unwrap();
                if times.is_empty() {
                    let count = |m: &[bool]| m.iter().filter(|&&b| b).count();
                    eprintln!(
                        "{} light and {} rim pixels",
                        count(&mask.light),
                        count(&mask.rim)
                    );
                }
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
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    if calls <= 5 {
        for ms in &times {
            eprintln!("{ms:.1} ms");
        }
    }
    let cpu = (cpu_ns() - cpu0) as f64 * 1e-6 / calls as f64;
    times.sort_by(f64::total_cmp);
    eprintln!(
        "median of {calls}: {:.2} ms wall; {cpu:.2} ms CPU per call (all threads)",
        times[calls / 2]
    );
}

/// CPU time the process's threads have run, in ns (Linux: `/proc/self/task/*/schedstat`, whose
/// first field is each thread's time on a CPU; 0 elsewhere). On a loaded machine wall times
/// swing with the other load, CPU times much less.
fn cpu_ns() -> u64 {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return 0;
    };
    tasks
        .flatten()
        .filter_map(|t| std::fs::read_to_string(t.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .sum()
}
