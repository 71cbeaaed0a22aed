//! `lumo bench render`: samples/s and rays/s of the integrators (the path tracer by default)
//! on every built-in scene, with each integrator's cost per sample relative to the path
//! tracer's when it is measured too.

use crate::cli_common::{err, errln, outln};
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use lumo_render::{PathSettings, RenderScene, RenderSettings};

use super::integrators::{render_with, skipped};
use lumo_render::Integrator;

use super::{machine_description, median};
use crate::arguments::parse_size;
use crate::output::si;

/// Arguments of `lumo bench render`.
#[derive(clap::Args, Debug)]
pub struct RenderBenchArgs {
    /// Scenes to measure [default: all built-in scenes].
    pub scenes: Vec<String>,
    /// Image size.
    #[arg(long, value_parser = parse_size, default_value = "512x512")]
    size: (usize, usize),
    /// Samples per pixel per run.
    #[arg(long, default_value_t = 4, value_parser = crate::cli_common::parse_spp)]
    spp: u32,
    /// Maximum path depth.
    #[arg(long, default_value_t = 5)]
    max_depth: u32,
    /// Timed runs per scene (the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = crate::cli_common::parse_threads)]
    threads: Option<usize>,
    /// Integrators to measure, comma-separated (samples are light paths for `light`).
    #[arg(long, value_parser = crate::integrator_arg::integrators(), value_delimiter = ',', default_value = "path")]
    integrators: Vec<Integrator>,
    /// Also measure the path tracer with spectral transport (a row after each `path` row; the
    /// RGB-to-spectrum table is fitted before timing starts).
    #[arg(long)]
    spectral: bool,
    /// Also write the Markdown table to this file.
    #[arg(long)]
    markdown: Option<PathBuf>,
}

/// Runs `lumo bench render`.
pub fn run(args: RenderBenchArgs) -> Result<()> {
    run_render(args)
}

fn run_render(args: RenderBenchArgs) -> Result<()> {
    if args.repeats == 0 {
        bail!(
            "--repeats must be at least 1: each scene is timed that many times (e.g. --repeats 3)"
        );
    }
    crate::cli_common::check_max_depth(Some(args.max_depth))?;
    if let Some(path) = &args.markdown {
        // Found before the benchmark runs, not after.
        crate::output::check_output_file(path).context("--markdown")?;
    }
    let names = super::scenes::scene_names(&args.scenes);
    let pool = crate::cli_common::worker_pool(args.threads)?;
    if args.spectral {
        let t0 = Instant::now();
        pool.install(lumo_spectrum::coefficient_table);
        errln!(
            "RGB-to-spectrum table fitted in {:.2} s",
            t0.elapsed().as_secs_f64()
        );
    }
    let threads = pool.current_num_threads();
    let (w, h) = args.size;
    let mut table = format!(
        "Machine: {}. {w}x{h}, {} spp, max depth {}, median of {} runs.\n\n\
         | scene | integrator | triangles | BVH build ms | samples/s | rays/s | rays/sample | time/sample vs path |\n\
         |---|---|---:|---:|---:|---:|---:|---:|\n",
        machine_description(threads),
        args.spp,
        args.max_depth,
        args.repeats.max(1)
    );
    for name in &names {
        let scene = crate::scene_load::load_scene(name)?;
        let tris = scene.triangle_count();
        let t0 = Instant::now();
        let rs = pool.install(|| RenderScene::new(scene))?;
        let build_ms = t0.elapsed().as_secs_f64() * 1e3;
        let settings = RenderSettings {
            width: w,
            height: h,
            spp: args.spp,
            seed: 0,
            path: PathSettings {
                max_depth: args.max_depth,
                ..Default::default()
            },
        };
        let mut path_rate = None;
        // Each integrator, and the spectral path tracer after the RGB one.
        let mut runs: Vec<(Integrator, bool)> = Vec::new();
        for &integrator in &args.integrators {
            runs.push((integrator, false));
            if integrator == Integrator::Path && args.spectral {
                runs.push((integrator, true));
            }
        }
        for (integrator, spectral) in runs {
            if let Some(why) = skipped(integrator, &rs, &settings) {
                errln!("{why}");
                continue;
            }
            let mut settings = settings;
            settings.path.spectral = spectral;
            let (mut sps, mut rps) = (vec![], vec![]);
            let mut rays_per_sample = 0.0;
            for _ in 0..args.repeats {
                let (stats, s) = render_with(integrator, &rs, &settings, &pool);
                sps.push(stats.samples as f64 / s);
                rps.push(stats.rays as f64 / s);
                rays_per_sample = stats.rays as f64 / stats.samples.max(1) as f64;
            }
            let rate = median(sps);
            if integrator == Integrator::Path && !spectral {
                path_rate = Some(rate);
            }
            let relative = path_rate.map_or("–".to_string(), |p| format!("{:.2}×", p / rate));
            let line = format!(
                "| {name} | {}{} | {tris} | {build_ms:.1} | {}samples/s | {}rays/s | {rays_per_sample:.2} | {relative} |\n",
                integrator.name(),
                if spectral { " (spectral)" } else { "" },
                si(rate),
                si(median(rps))
            );
            err!("{line}");
            table.push_str(&line);
        }
    }
    outln!("\n{table}");
    if let Some(path) = &args.markdown {
        super::atomic::write_bytes(path, table.as_bytes())?;
    }
    Ok(())
}
