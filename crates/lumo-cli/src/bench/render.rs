//! `lumo bench render`: samples/s and rays/s of the path tracer on every built-in scene, and
//! with `--integrator ppm` of the photon mapper too (samples/s and photon paths/s).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Result;
use lumo_render::{render, render_ppm, PathSettings, PpmSettings, RenderScene, RenderSettings};

use super::{machine_description, median};
use crate::render_cmd::{parse_size, si};

/// Arguments of `lumo bench render`.
#[derive(clap::Args, Debug)]
pub struct RenderBenchArgs {
    /// Scenes to measure [default: all built-in scenes].
    pub scenes: Vec<String>,
    /// Image size.
    #[arg(long, value_parser = parse_size, default_value = "512x512")]
    size: (usize, usize),
    /// Samples per pixel per run.
    #[arg(long, default_value_t = 4)]
    spp: u32,
    /// Maximum path depth.
    #[arg(long, default_value_t = 5)]
    max_depth: u32,
    /// Timed runs per scene (the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Worker threads [default: all cores].
    #[arg(long)]
    threads: Option<usize>,
    /// Also write the Markdown table to this file.
    #[arg(long)]
    markdown: Option<PathBuf>,
    /// Integrators to time, one row each per scene (comma-separated): path, ppm.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "path")]
    integrator: Vec<BenchIntegrator>,
}

/// An integrator `lumo bench render` times.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchIntegrator {
    /// The path tracer (`render`).
    Path,
    /// One-pass photon mapping (`render_ppm`, default settings: one photon path per camera
    /// sample).
    Ppm,
}

/// Runs `lumo bench render`.
pub fn run(args: RenderBenchArgs) -> Result<()> {
    run_render(args)
}

fn run_render(args: RenderBenchArgs) -> Result<()> {
    if args.repeats == 0 {
        eprintln!("warning: --repeats 0: timing each scene once");
    }
    let names = super::scenes::scene_names(&args.scenes);
    let pool = crate::cli_common::worker_pool(args.threads)?;
    let threads = pool.current_num_threads();
    let (w, h) = args.size;
    // The integrator and photon columns only appear when something besides the path tracer
    // is timed, so the path tracer's table keeps its form.
    let wide = args.integrator.iter().any(|i| *i != BenchIntegrator::Path);
    let mut table = format!(
        "Machine: {}. {w}x{h}, {} spp, max depth {}, median of {} runs.\n\n",
        machine_description(threads),
        args.spp,
        args.max_depth,
        args.repeats.max(1)
    );
    table.push_str(if wide {
        "| scene | integrator | triangles | BVH build ms | samples/s | photon paths/s | rays/s | rays/sample |\n\
         |---|---|---:|---:|---:|---:|---:|---:|\n"
    } else {
        "| scene | triangles | BVH build ms | samples/s | rays/s | rays/sample |\n\
         |---|---:|---:|---:|---:|---:|\n"
    });
    for name in &names {
        let scene = crate::render_cmd::load_scene(name)?;
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
        for &integrator in &args.integrator {
            let (mut sps, mut pps, mut rps) = (vec![], vec![], vec![]);
            let mut rays_per_sample = 0.0;
            for _ in 0..args.repeats.max(1) {
                let t = Instant::now();
                let (samples, photon_paths, rays) = match integrator {
                    BenchIntegrator::Path => {
                        let (_, st) = pool.install(|| render(&rs, &settings, &|_| {}));
                        (st.samples, 0, st.rays)
                    }
                    BenchIntegrator::Ppm => {
                        let ppm = PpmSettings::default();
                        let (_, st) = pool.install(|| render_ppm(&rs, &settings, &ppm, &|_| {}));
                        (st.samples, st.photon_paths, st.rays)
                    }
                };
                let s = t.elapsed().as_secs_f64();
                sps.push(samples as f64 / s);
                pps.push(photon_paths as f64 / s);
                rps.push(rays as f64 / s);
                rays_per_sample = rays as f64 / samples.max(1) as f64;
            }
            let line = if wide {
                format!(
                    "| {name} | {} | {tris} | {build_ms:.1} | {}samples/s | {} | {}rays/s | {rays_per_sample:.2} |\n",
                    format!("{integrator:?}").to_lowercase(),
                    si(median(sps)),
                    match integrator {
                        BenchIntegrator::Path => "–".to_string(),
                        BenchIntegrator::Ppm => format!("{}paths/s", si(median(pps))),
                    },
                    si(median(rps))
                )
            } else {
                format!(
                    "| {name} | {tris} | {build_ms:.1} | {}samples/s | {}rays/s | {rays_per_sample:.2} |\n",
                    si(median(sps)),
                    si(median(rps))
                )
            };
            eprint!("{line}");
            table.push_str(&line);
        }
    }
    println!("\n{table}");
    if let Some(path) = &args.markdown {
        super::atomic::write_bytes(path, table.as_bytes())?;
    }
    Ok(())
}
