//! `lumo bench quality`: every scene × spp × pipeline rendered, timed and scored against a
//! converged reference; the tables go to `quality.md`, the images to the `quality.png`
//! contact sheet. Both are written only once everything is done (temporary name + rename),
//! so an interrupted run leaves the previous results untouched.

use crate::cli_common::outln;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use lumo_image::metrics::{compare, CompareSettings, Metrics};
use lumo_image::Image;
use lumo_pipeline::{run_pipeline, Pipeline, PipelineOptions, Timings};

use super::atomic::{check_dir_writable, write_bytes, write_image_atomic};
use super::contact_sheet::{contact_sheet, crop_side, hardest_window, Row, Tile};
use super::quality_integrators::{row_integrators, score, IntegratorScored};
use super::reference::{ensure_reference, reference_key};
use super::report::{quality_markdown, QualityContext};
use super::scenes::{load_all, scene_names, settings, BenchScene};
use crate::arguments::parse_size;
use crate::pipeline_args::parse_pipeline;
use lumo_render::Integrator;

/// Arguments of `lumo bench quality`.
#[derive(clap::Args, Debug)]
pub struct QualityArgs {
    /// Scenes (built-in names or scene files), comma-separated [default: every built-in].
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Image size of every render [default: 256x256; 512x512 with --set].
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(usize, usize)>,
    /// Samples per pixel of the test images, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,4", value_parser = crate::cli_common::parse_spp)]
    pub spp: Vec<u32>,
    /// Pipelines, comma-separated, in column order.
    #[arg(long, value_delimiter = ',', value_parser = parse_pipeline,
          default_value = "none,bilateral,atrous,guided,jbu")]
    pub pipelines: Vec<Pipeline>,
    /// Other integrators scored at equal time with each `none` image (rows of the relMSE and
    /// FLIP tables and a table of their own), comma-separated; `path` is the `none` row itself.
    /// Not with --set. [default: every integrator of the table but path]
    #[arg(
        long,
        value_parser = crate::integrator_arg::integrators(),
        value_delimiter = ',',
        conflicts_with = "set"
    )]
    pub integrators: Vec<Integrator>,
    /// Samples per pixel of the converged reference (`--pipeline none`) [default: 1024; 512
    /// with --set].
    #[arg(long, value_parser = crate::cli_common::parse_spp)]
    pub reference_spp: Option<u32>,
    /// Seed of the test images; the reference uses SEED + 1 so its noise is independent.
    #[arg(long, default_value_t = 0, value_parser = crate::cli_common::parse_seed)]
    pub seed: u32,
    /// Longest path depth [default: the scene's, 8 for the built-ins].
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Exposure in stops for the scores on display values (PSNR, SSIM, FLIP) and the sheet.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// Directory of cached references.
    #[arg(long, default_value = "target/lumo-bench-cache")]
    pub cache: PathBuf,
    /// Where quality.md and quality.png go [default: target/lumo-bench, or docs/results with --publish].
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
    /// Write into docs/results, replacing the committed results (without it, nothing under
    /// docs/ is touched unless --out-dir names it).
    #[arg(long, conflicts_with = "out_dir")]
    pub publish: bool,
    /// A line added to the report's header (e.g. what else the machine was doing).
    #[arg(long)]
    pub note: Option<String>,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = crate::cli_common::parse_threads)]
    pub threads: Option<usize>,
    /// Score lumo's filters (`lumo denoise` defaults, no emission plane) on whole frames of
    /// the scenes in scenes/SET/ (`heldout` or `tuning`) instead of the pipelines; writes
    /// SET.md and SET.json (docs/bench.md, "Held-out evaluation").
    #[arg(long, conflicts_with_all = ["scenes", "pipelines"])]
    pub set: Option<String>,
    /// With --set: folder of frames from another renderer (tools/heldout/mitsuba_inputs.py)
    /// [default: CACHE/mitsuba for the held-out set, when it exists].
    #[arg(long, requires = "set")]
    pub external: Option<PathBuf>,
}

/// Size of the renders when --size is not given (without --set).
const DEFAULT_SIZE: (usize, usize) = (256, 256);
/// Reference samples when --reference-spp is not given (without --set).
const DEFAULT_REFERENCE_SPP: u32 = 1024;

/// One scored render.
pub struct Scored {
    /// Scene name.
    pub scene: String,
    /// Samples per pixel.
    pub spp: u32,
    /// The pipeline.
    pub pipeline: Pipeline,
    /// Scores against the reference.
    pub metrics: Metrics,
    /// Stage times.
    pub timings: Timings,
    /// The image (kept for the contact sheet).
    pub image: Image,
}

/// Runs `lumo bench quality`.
pub fn run(args: QualityArgs) -> Result<()> {
    validate(&args)?;
    if let Some(set) = &args.set {
        return super::heldout::run(&args, set);
    }
    let size = args.size.unwrap_or(DEFAULT_SIZE);
    let reference_spp = args.reference_spp.unwrap_or(DEFAULT_REFERENCE_SPP);
    let out_dir = super::out_dir(args.out_dir.as_deref(), args.publish);
    check_dir_writable(&out_dir)?;
    let pool = crate::cli_common::worker_pool(args.threads)?;
    let scenes = load_all(&scene_names(&args.scenes), &pool)?;
    let compare_settings = CompareSettings {
        exposure: args.exposure,
        ..CompareSettings::default()
    };
    let mut references = Vec::with_capacity(scenes.len());
    for s in &scenes {
        let key = reference_key(
            s,
            size,
            reference_spp,
            args.seed.wrapping_add(1),
            depth(&args, s),
        );
        references.push(ensure_reference(&args.cache, &key, s, &pool)?.0);
    }
    let extra = row_integrators(&args.integrators);
    let jobs = scenes.len() * args.spp.len() * (args.pipelines.len() + extra.len());
    let bar = ProgressBar::new(jobs as u64).with_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} {msg}  {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut scored = Vec::with_capacity(jobs);
    let mut integrator_rows: Vec<IntegratorScored> = Vec::new();
    for (s, reference) in scenes.iter().zip(&references) {
        for &spp in &args.spp {
            for &pipeline in &args.pipelines {
                bar.set_message(format!("{} {spp} spp {pipeline}", s.name));
                let rs = settings(size, spp, args.seed, depth(&args, s), s.rr_depth);
                let out = pool.install(|| {
                    run_pipeline(&s.rs, pipeline, &rs, &PipelineOptions::default(), &|_| {})
                })?;
                let metrics = compare(reference, &out.image, &compare_settings)
                    .with_context(|| format!("scoring {} {spp} spp {pipeline}", s.name))?;
                scored.push(Scored {
                    scene: s.name.clone(),
                    spp,
                    pipeline,
                    metrics,
                    timings: out.timings,
                    image: out.image,
                });
                bar.inc(1);
            }
            // The other integrators in the time of this spp's unfiltered path-traced image
            // (timed here if `none` is not among the pipelines).
            if extra.is_empty() {
                continue;
            }
            let rs = settings(size, spp, args.seed, depth(&args, s), s.rr_depth);
            let budget = match scored
                .iter()
                .find(|r| r.scene == s.name && r.spp == spp && r.pipeline == Pipeline::None)
            {
                Some(r) => r.timings.total().as_secs_f64(),
                None => super::integrators::render_with(Integrator::Path, &s.rs, &rs, &pool).1,
            };
            for &integrator in &extra {
                bar.set_message(format!("{} {spp} spp {}", s.name, integrator.name()));
                let r = score(
                    integrator,
                    s,
                    &rs,
                    budget,
                    reference,
                    &compare_settings,
                    &pool,
                )?;
                integrator_rows.extend(r);
                bar.inc(1);
            }
        }
    }
    bar.finish_and_clear();

    let threads = pool.current_num_threads();
    let ctx = QualityContext {
        command: command_line(),
        machine: super::machine_description(threads),
        note: args.note.clone(),
        size,
        spp: args.spp.clone(),
        reference_spp,
        seed: args.seed,
        max_depths: scenes
            .iter()
            .map(|s| (s.name.clone(), depth(&args, s)))
            .collect(),
        exposure: args.exposure,
        pipelines: args.pipelines.clone(),
        integrators: extra.clone(),
        scenes: scenes.iter().map(|s| s.name.clone()).collect(),
    };
    let markdown = quality_markdown(&ctx, &scored, &integrator_rows);
    let sheet = sheet(&args, &scenes, &references, &scored);
    // Everything is computed: only now touch the output files, each all-or-nothing.
    let png = out_dir.join("quality.png");
    let md = out_dir.join("quality.md");
    write_image_atomic(&png, &sheet)?;
    write_bytes(&md, markdown.as_bytes())?;
    outln!("wrote {} and {}", md.display(), png.display());
    Ok(())
}

fn validate(args: &QualityArgs) -> Result<()> {
    if args.spp.is_empty() || args.spp.contains(&0) {
        bail!("--spp: give one or more sample counts, each at least 1 (e.g. --spp 1,4)");
    }
    if args.pipelines.is_empty() {
        bail!("--pipelines: give at least one pipeline");
    }
    if args.reference_spp == Some(0) {
        bail!("--reference-spp must be at least 1");
    }
    crate::cli_common::check_max_depth(args.max_depth)?;
    if !args.exposure.is_finite() {
        bail!("--exposure must be a finite number of stops");
    }
    Ok(())
}

fn depth(args: &QualityArgs, s: &BenchScene) -> u32 {
    args.max_depth.unwrap_or(s.max_depth)
}

/// The command as typed, for the report header (the binary's path dropped; a `--note`'s text
/// is shown in the header itself, so it is elided here).
pub fn command_line() -> String {
    let mut parts = vec!["lumo".to_string()];
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        if a == "--note" {
            args.next();
            parts.push("--note …".into());
        } else if a.starts_with("--note=") {
            parts.push("--note …".into());
        } else {
            parts.push(a);
        }
    }
    parts.join(" ")
}

/// Per-pixel display-value error of the filtered methods (all of them if only `none` ran),
/// summed over a scene's rows: where the filters struggle is the interesting crop. Pixels
/// that are saturated on the display in the reference (emitters, and two pixels around them)
/// are left out: their anti-aliased edges are the largest errors at low spp in every method
/// and would always win, telling nothing about the filters.
fn error_map(reference: &Image, rows: &[&Scored], exposure: f32) -> Vec<f64> {
    let filtered: Vec<&&Scored> = rows
        .iter()
        .filter(|r| r.pipeline != Pipeline::None)
        .collect();
    let used: Vec<&&Scored> = if filtered.is_empty() {
        rows.iter().collect()
    } else {
        filtered
    };
    let tm = |x: f32| lumo_image::metrics::tone_map(x, exposure) as f64;
    let (w, h) = (reference.width, reference.height);
    let gain = exposure.exp2();
    let saturated: Vec<bool> = (0..w * h)
        .map(|i| {
            reference.data[i * 3..i * 3 + 3]
                .iter()
                .any(|&v| v * gain >= 1.0)
        })
        .collect();
    let near_saturated = |x: usize, y: usize| {
        (y.saturating_sub(2)..(y + 3).min(h))
            .any(|yy| (x.saturating_sub(2)..(x + 3).min(w)).any(|xx| saturated[yy * w + xx]))
    };
    let mut err = vec![0.0; w * h];
    for r in used {
        for (i, e) in err.iter_mut().enumerate() {
            for c in 0..3 {
                let k = i * 3 + c;
                *e += (tm(r.image.data[k]) - tm(reference.data[k])).abs();
            }
        }
    }
    for (i, e) in err.iter_mut().enumerate() {
        if near_saturated(i % w, i / w) {
            *e = 0.0;
        }
    }
    err
}

fn sheet(args: &QualityArgs, scenes: &[BenchScene], refs: &[Image], scored: &[Scored]) -> Image {
    let (w, h) = args.size.unwrap_or(DEFAULT_SIZE);
    let side = crop_side(w, h);
    let mut columns = vec!["REFERENCE".to_string()];
    columns.extend(args.pipelines.iter().map(|p| p.name().to_uppercase()));
    let mut rows = Vec::new();
    for (s, reference) in scenes.iter().zip(refs) {
        let mine: Vec<&Scored> = scored.iter().filter(|r| r.scene == s.name).collect();
        let (cx, cy) = hardest_window(&error_map(reference, &mine, args.exposure), w, h, side);
        for &spp in &args.spp {
            let mut tiles = vec![Tile {
                image: reference,
                lines: vec![
                    s.name.clone(),
                    format!("{spp} SPP"),
                    format!(
                        "REF {}",
                        args.reference_spp.unwrap_or(DEFAULT_REFERENCE_SPP)
                    ),
                ],
            }];
            for r in mine.iter().filter(|r| r.spp == spp) {
                tiles.push(Tile {
                    image: &r.image,
                    lines: tile_lines(r),
                });
            }
            rows.push(Row {
                tiles,
                crop: (cx, cy, side),
            });
        }
    }
    contact_sheet(&columns, &rows, args.exposure)
}

/// The numbers under a tile: relMSE, FLIP, SSIM, PSNR and the total time.
fn tile_lines(r: &Scored) -> Vec<String> {
    let m = &r.metrics;
    vec![
        "RELMSE".into(),
        format!("{:.2e}", m.relmse),
        format!("FLIP {:.3}", m.flip),
        format!("SSIM {:.3}", m.ssim),
        if m.psnr.is_finite() {
            format!("PSNR {:.1}", m.psnr)
        } else {
            "PSNR INF".into()
        },
        format!("{:.0} MS", r.timings.total().as_secs_f64() * 1e3),
    ]
}
