//! `lumo bench speed`: the papers' Table 1 (render time per scene × indirect bounces × spp,
//! per pipeline and stage) and Table 2 (filter time per resolution × filter settings) on this
//! machine, as medians of repeated runs after warm-up runs → `speed.md`.

use crate::cli_common::outln;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{bail, Result};
use indicatif::{ProgressBar, ProgressStyle};
use lumo_filter::synthetic_frame;
use lumo_filter::table2::{self, Table2Config};
use lumo_pipeline::{run_pipeline, Pipeline, PipelineOptions, Timings};

use super::atomic::{check_dir_writable, write_bytes};
use super::scenes::{load_all, scene_names, settings};
use super::speed_report::{speed_markdown, FilterRow, RenderRow, SpeedContext};
use crate::arguments::parse_size;
use crate::pipeline_args::parse_pipeline;

/// Arguments of `lumo bench speed`.
#[derive(clap::Args, Debug)]
pub struct SpeedArgs {
    /// Scenes (built-in names or scene files), comma-separated [default: every built-in].
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Image size of the Table 1 renders.
    #[arg(long, value_parser = parse_size, default_value = "256x256")]
    pub size: (usize, usize),
    /// Samples per pixel, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,4", value_parser = crate::cli_common::parse_spp)]
    pub spp: Vec<u32>,
    /// Indirect bounces, comma-separated (max depth = bounces + 2, Mitsuba's convention).
    #[arg(long, value_delimiter = ',', default_value = "0,1,2")]
    pub bounces: Vec<u32>,
    /// Pipelines, comma-separated.
    #[arg(long, value_delimiter = ',', value_parser = parse_pipeline,
          default_value = "none,bilateral,atrous,guided,jbu")]
    pub pipelines: Vec<Pipeline>,
    /// Table 2 resolutions, comma-separated.
    #[arg(long, value_delimiter = ',', value_parser = parse_size,
          default_value = "512x512,1024x1024")]
    pub filter_sizes: Vec<(usize, usize)>,
    /// Timed runs per cell (the median is reported); a cell whose warm-up run takes over 4 s
    /// is timed at most 3 times, over 20 s once.
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// Untimed runs before the timed ones.
    #[arg(long, default_value_t = 1)]
    pub warmup: usize,
    /// Skip Table 1 (rendering).
    #[arg(long)]
    pub no_render: bool,
    /// Skip Table 2 (filters).
    #[arg(long, conflicts_with = "no_render")]
    pub no_filters: bool,
    /// Where speed.md go [default: target/lumo-bench, or docs/results with --publish].
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
    /// Write into docs/results, replacing the committed results (without it, nothing under
    /// docs/ is touched unless --out-dir names it).
    #[arg(long, conflicts_with = "out_dir")]
    pub publish: bool,
    /// A line added to the header (e.g. what else the machine was doing).
    #[arg(long)]
    pub note: Option<String>,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = crate::cli_common::parse_threads)]
    pub threads: Option<usize>,
}

/// Runs `lumo bench speed`.
pub fn run(args: SpeedArgs) -> Result<()> {
    if args.spp.is_empty() || args.spp.contains(&0) {
        bail!("--spp: give one or more sample counts, each at least 1 (e.g. --spp 1,4)");
    }
    if args.repeats == 0 {
        bail!("--repeats must be at least 1");
    }
    if args.bounces.iter().any(|&b| b > 62) {
        bail!("--bounces: use at most 62 indirect bounces");
    }
    let out_dir = super::out_dir(args.out_dir.as_deref(), args.publish);
    check_dir_writable(&out_dir)?;
    let pool = crate::cli_common::worker_pool(args.threads)?;
    let names = scene_names(&args.scenes);
    let scenes = if args.no_render {
        vec![]
    } else {
        load_all(&names, &pool)?
    };
    let mut configs = if args.no_filters {
        vec![]
    } else {
        filter_configs()
    };
    let render_jobs = scenes.len() * args.bounces.len() * args.spp.len() * args.pipelines.len();
    let jobs = render_jobs + configs.len() * args.filter_sizes.len();
    let bar = ProgressBar::new(jobs as u64).with_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} {msg}  {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );

    let mut render_rows = Vec::with_capacity(render_jobs);
    for s in &scenes {
        for &b in &args.bounces {
            for &spp in &args.spp {
                for &p in &args.pipelines {
                    bar.set_message(format!("{} {b} bounces {spp} spp {p}", s.name));
                    let rs = settings(args.size, spp, 0, b + 2, s.rr_depth);
                    let opts = PipelineOptions::default();
                    let run_once = || -> Result<Timings> {
                        Ok(pool
                            .install(|| run_pipeline(&s.rs, p, &rs, &opts, &|_| {}))?
                            .timings)
                    };
                    let (timings, runs) = measure(&args, run_once)?;
                    render_rows.push(RenderRow {
                        scene: s.name.clone(),
                        bounces: b,
                        spp,
                        pipeline: p,
                        timings,
                        runs,
                    });
                    bar.inc(1);
                }
            }
        }
    }

    let mut filter_rows = Vec::new();
    for &(w, h) in &args.filter_sizes {
        let frame = synthetic_frame(w, h, 1, 7);
        for c in &mut configs {
            let title = c.filter.info().title;
            bar.set_message(format!("{w}x{h} {title} {}", c.label));
            let (t, runs) = measure(&args, || {
                let t = Instant::now();
                pool.install(|| c.run(&frame))?;
                Ok(Timings {
                    filter: t.elapsed(),
                    ..Timings::default()
                })
            })?;
            filter_rows.push(FilterRow {
                filter: title,
                config: c.label.clone(),
                size: (w, h),
                time: t.filter,
                runs,
            });
            bar.inc(1);
        }
    }
    bar.finish_and_clear();

    let ctx = SpeedContext {
        command: super::quality::command_line(),
        cpu: super::cpu_model(),
        cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
        threads: pool.current_num_threads(),
        note: args.note.clone(),
        size: args.size,
        repeats: args.repeats,
        warmup: args.warmup,
        scenes: scenes.iter().map(|s| s.name.clone()).collect(),
        bounces: args.bounces.clone(),
        spp: args.spp.clone(),
        pipelines: args.pipelines.clone(),
        filter_sizes: args.filter_sizes.clone(),
    };
    let md = speed_markdown(&ctx, &render_rows, &filter_rows);
    let path = out_dir.join("speed.md");
    write_bytes(&path, md.as_bytes())?;
    outln!("wrote {}", path.display());
    Ok(())
}

/// Runs `f` `warmup` times untimed, then times it; returns the run with the median total and
/// the number of timed runs. Slow cells get fewer runs (see `--repeats`), so a full run stays
/// bounded; the warm-up (or the first timed run, without warm-up) decides.
fn measure(args: &SpeedArgs, mut f: impl FnMut() -> Result<Timings>) -> Result<(Timings, usize)> {
    let mut probe = None;
    for _ in 0..args.warmup {
        let t = Instant::now();
        f()?;
        probe = Some(t.elapsed());
    }
    let mut runs = Vec::with_capacity(args.repeats);
    let mut want = args.repeats;
    while runs.len() < want {
        let t: Timings = f()?;
        if probe.is_none() {
            probe = Some(t.total());
        }
        want = want.min(cap(probe.unwrap_or_default()));
        runs.push(t);
    }
    runs.sort_by_key(Timings::total);
    let n = runs.len();
    Ok((runs[n / 2], n))
}

/// The most timed runs a cell whose single run takes `d` gets (the rule of `cargo bench`).
fn cap(d: Duration) -> usize {
    table2::timed_runs_cap(d.as_secs_f64() * 1e3)
}

/// The configurations of `lumo_filter::table2` (shared with `cargo bench -p lumo-filter`)
/// that speed.md lists: all but the unweighted À-Trous rows. Each is labelled by its filter's
/// title in `lumo_filter::FILTERS` and its own label.
fn filter_configs() -> Vec<Table2Config> {
    table2::table2_configs()
        .into_iter()
        .filter(|c| c.speed_table)
        .collect()
}
