//! Noise per sample of the light choices: by power, and by the light pilot at several mixes,
//! grids and depths (docs/results/peers.md, "Light selection"). `cargo run --release -p
//! lumo-render --example light_pilot_sweep -- SCENE.xml|BUILTIN RES SPP`.
//!
//! Each choice renders the scene twice (seeds 1 and 2) with the path tracer; its relMSE is
//! the mean of (a − b)² / 2 / (ref² + 0.01) over pixels, as `tools/peers/render_peers.py`
//! computes it, `ref` being the mean of every render (all are unbiased). Also prints each
//! choice's image mean and the pilot's time and group probabilities.

use std::path::Path;
use std::time::Instant;

use lumo_render::{LightPilot, PathSettings, RenderScene, RenderSettings};
use lumo_scene::load::{load_scene, LoadOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map(String::as_str).unwrap_or("cornell");
    let res: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(128);
    let spp: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(64);
    let (scene, max_depth) = if name.ends_with(".xml") {
        let options = LoadOptions {
            defines: vec![("res".into(), res.to_string())],
            ..Default::default()
        };
        let loaded = load_scene(Path::new(name), &options)?;
        (loaded.scene, loaded.settings.max_depth)
    } else {
        (lumo_scene::builtin_scene(name)?, None)
    };
    let mut rs = RenderScene::new(scene)?;
    let path = PathSettings {
        max_depth: max_depth.unwrap_or(PathSettings::default().max_depth),
        ..Default::default()
    };
    // (label, pilot, shares: 0 = √ of the second moment (the default), 1 = mean, 2 = mean
    // weighted by MIS)
    let mut choices: Vec<(String, Option<LightPilot>, u8)> = vec![("power".into(), None, 0)];
    for (mix, grid, vertices, by) in [
        (0.2, 64, 3, 0),
        (0.2, 64, 3, 1),
        (0.1, 64, 3, 2),
        (0.2, 64, 3, 2),
        (0.3, 64, 3, 2),
        (0.2, 32, 3, 2),
    ] {
        let pilot = LightPilot {
            mix,
            grid,
            vertices,
            ..Default::default()
        };
        let name = ["sqrt M", "mean", "MIS mean"][by as usize];
        let label = format!("pilot ({name}) mix {mix} grid {grid} vertices {vertices}");
        choices.push((label, Some(pilot), by));
    }
    let mut images = Vec::new();
    for (label, pilot, by) in &choices {
        match pilot {
            None => rs.lights.select_by_power(),
            Some(p) if *by > 0 => {
                rs.lights.select_by_power();
                let sums = lumo_render::light_pilot::measure(&rs, res, res, p);
                let shares = if *by == 1 { sums.first } else { sums.weighted };
                rs.lights.select_by_groups(&shares, p.mix)?;
                println!("{label}: groups {:?}", rs.lights.group_pmf());
            }
            Some(p) => {
                let report = rs.select_lights_by_pilot(res, res, p);
                println!(
                    "{label}: pilot {:.1} ms, groups {:?}",
                    report.time.as_secs_f64() * 1e3,
                    report.group_pmf
                );
            }
        }
        let pair: Vec<Vec<f32>> = [1, 2]
            .iter()
            .map(|&seed| {
                let settings = RenderSettings {
                    width: res,
                    height: res,
                    spp,
                    seed,
                    path,
                };
                let t = Instant::now();
                let (frame, _) = lumo_render::render(&rs, &settings, &|_| {});
                eprintln!("{label} seed {seed}: {:.2} s", t.elapsed().as_secs_f64());
                frame.color.data
            })
            .collect();
        images.push(pair);
    }
    rs.lights.select_by_power();
    println!("power: groups {:?}", rs.lights.group_pmf());
    let n = images.len() as f32 * 2.0;
    let len = images[0][0].len();
    let reference: Vec<f32> = (0..len)
        .map(|i| images.iter().map(|p| p[0][i] + p[1][i]).sum::<f32>() / n)
        .collect();
    for ((label, ..), pair) in choices.iter().zip(&images) {
        let (a, b) = (&pair[0], &pair[1]);
        let rel: f64 = (0..len)
            .map(|i| {
                let d = (a[i] - b[i]) as f64;
                let r = reference[i] as f64;
                d * d / 2.0 / (r * r + 0.01)
            })
            .sum::<f64>()
            / len as f64;
        let mean: f64 = a.iter().chain(b).map(|&v| v as f64).sum::<f64>() / (2 * len) as f64;
        println!("{label}: relMSE {rel:.4e}, mean {mean:.6}");
    }
    Ok(())
}
