//! Filter timings in the shape of the papers' Table 2: median wall time (ms) of several runs on
//! the synthetic scene at 512², 1024² and 1920×1080. Plain std::time, no harness.
//! `cargo bench -p lumo-filter` runs everything; pass `atrous`, `guided`, `bilateral` or
//! `emitters` (the light search, on the frame with a light pasted in) after `--` to run one
//! group. Results are recorded in docs/filter-benchmarks.md.

use std::time::Instant;

use lumo_filter::table2;
use lumo_filter::{
    detect_emitters, synthetic_frame, EmitterParams, Features, FilterKind, SyntheticFrame,
};
use lumo_image::Image;

const RESOLUTIONS: [(usize, usize); 3] = [(512, 512), (1024, 1024), (1920, 1080)];

/// Median time in ms. Up to 5 runs; a first run over 4 s drops to 3 runs and one over 20 s
/// to that single run (the repeat count is printed beside the time).
fn time<F: FnMut()>(mut f: F) -> (f64, usize) {
    let t = Instant::now();
    f();
    let first = t.elapsed().as_secs_f64() * 1e3;
    let runs = table2::timed_runs_cap(first).min(5);
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
    let row = |name: &str, cfg: &str, f: &mut dyn FnMut(&SyntheticFrame)| {
        let cells: Vec<String> = frames.iter().map(|fr| cell(time(|| f(fr)))).collect();
        println!("| {name} | {cfg} | {} |", cells.join(" | "));
    };
    for mut c in table2::table2_configs() {
        let info = c.filter.info();
        let cfg = match c.filter {
            FilterKind::Guided => format!("{} (incl. guide build)", c.label),
            _ => c.label.clone(),
        };
        if wants(info.name) {
            row(info.title, &cfg, &mut |fr| {
                c.run(fr).expect("filter on a synthetic frame")
            });
        }
    }
    if wants("emitters") {
        let lit: Vec<(Image, Image)> = frames.iter().map(with_light).collect();
        let cells: Vec<String> = frames
            .iter()
            .zip(&lit)
            .map(|(fr, (color, albedo))| {
                let f = Features {
                    albedo: Some(albedo),
                    normal: Some(&fr.normal),
                    position: Some(&fr.position),
                    depth: Some(&fr.depth),
                    variance: None,
                };
                let p = EmitterParams::default();
                cell(time(|| {
                    detect_emitters(color, &f, &p).expect("light search on a synthetic frame");
                }))
            })
            .collect();
        println!(
            "| light search | defaults, a light pasted in | {} |",
            cells.join(" | ")
        );
    }
}

/// The frame's noisy colour and albedo with a light of radiance 20 (albedo 0.75) on a tenth
/// of its width and height, up in the frame's left half.
fn with_light(fr: &SyntheticFrame) -> (Image, Image) {
    let (mut color, mut albedo) = (fr.noisy.clone(), fr.albedo.clone());
    let (w, h) = (color.width, color.height);
    for y in h * 6 / 10..h * 7 / 10 {
        for x in w / 5..w * 3 / 10 {
            color.pixel_mut(x, y).fill(20.0);
            albedo.pixel_mut(x, y).fill(0.75);
        }
    }
    (color, albedo)
}
