//! `lumo bench speed`: the papers' Table 1 (render time per scene × indirect bounces × spp,
//! per pipeline and stage) and Table 2 (filter time per resolution × filter settings) on this
//! machine, as medians of repeated runs after warm-up runs → `speed.md`.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{bail, Result};
use indicatif::{ProgressBar, ProgressStyle};
use lumo_filter::{
    atrous, bilateral, build_guide, guided, synthetic_frame, AtrousParams, BilateralParams,
    DepthNorm, Features, GuideKind, GuidedParams, SyntheticFrame,
};
use lumo_render::{run_pipeline, Pipeline, PipelineOptions, Timings};

use super::atomic::{check_dir_writable, write_bytes};
use super::scenes::{load_all, scene_names, settings};
use super::speed_report::{speed_markdown, FilterRow, RenderRow, SpeedContext};
use crate::pipeline_args::parse_pipeline;
use crate::render_cmd::parse_size;

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
    #[arg(long, value_delimiter = ',', default_value = "1,4")]
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
    #[arg(long)]
    pub no_filters: bool,
    /// Where speed.md goes.
    #[arg(long, default_value = "docs/results")]
    pub out_dir: PathBuf,
    /// A line added to the header (e.g. what else the machine was doing).
    #[arg(long)]
    pub note: Option<String>,
    /// Worker threads [default: all cores].
    #[arg(long)]
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
    check_dir_writable(&args.out_dir)?;
    let pool = crate::cli_common::worker_pool(args.threads)?;
    let names = scene_names(&args.scenes);
    let scenes = if args.no_render {
        vec![]
    } else {
        load_all(&names, &pool)?
    };
    let configs = if args.no_filters {
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
        for c in &configs {
            bar.set_message(format!("{w}x{h} {} {}", c.filter, c.label));
            let (t, runs) = measure(&args, || {
                let t = Instant::now();
                pool.install(|| (c.run)(&frame))?;
                Ok(Timings {
                    filter: t.elapsed(),
                    ..Timings::default()
                })
            })?;
            filter_rows.push(FilterRow {
                filter: c.filter,
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
    let path = args.out_dir.join("speed.md");
    write_bytes(&path, md.as_bytes())?;
    println!("wrote {}", path.display());
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

/// The most timed runs a cell whose single run takes `d` gets.
fn cap(d: Duration) -> usize {
    if d > Duration::from_secs(20) {
        1
    } else if d > Duration::from_secs(4) {
        3
    } else {
        usize::MAX
    }
}

/// Filters one synthetic frame.
type FilterRun = Box<dyn Fn(&SyntheticFrame) -> Result<()> + Sync>;

/// One Table 2 configuration.
struct FilterConfig {
    filter: &'static str,
    label: String,
    run: FilterRun,
}

/// The configurations of crates/lumo-filter/benches/filters.rs (the papers' Table 2 shape):
/// À-Trous at 1, 5 and 10 iterations with 1–3 edge-stopping weights and the variance-guided
/// default; the guided filter with 1, 3 and 4 guide dimensions, exact and fast; the
/// cross-bilateral filter at r = 16, 24, 32. Times include input conversion and guide building.
fn filter_configs() -> Vec<FilterConfig> {
    let mut v = Vec::new();
    let weights = ["colour", "colour+normal", "colour+normal+position"];
    for it in [1usize, 5, 10] {
        for (k, name) in weights.iter().enumerate() {
            let p = AtrousParams {
                iterations: it,
                sigma_color: Some(4.0),
                sigma_luminance: None,
                sigma_normal: (k >= 1).then_some(0.3),
                sigma_position: (k >= 2).then_some(0.1),
                ..AtrousParams::default()
            };
            v.push(FilterConfig {
                filter: "À-Trous",
                label: format!("{it} it, {name}"),
                run: Box::new(move |fr| {
                    let f = Features {
                        normal: Some(&fr.normal),
                        position: Some(&fr.position),
                        depth: Some(&fr.depth),
                        ..Features::default()
                    };
                    std::hint::black_box(atrous(&fr.noisy, &f, &p)?);
                    Ok(())
                }),
            });
        }
    }
    v.push(FilterConfig {
        filter: "À-Trous",
        label: "5 it, variance-guided + normal + position (lumo's default)".into(),
        run: Box::new(|fr| {
            let f = Features {
                normal: Some(&fr.normal),
                position: Some(&fr.position),
                depth: Some(&fr.depth),
                variance: Some(&fr.variance),
                ..Features::default()
            };
            std::hint::black_box(atrous(&fr.noisy, &f, &AtrousParams::default())?);
            Ok(())
        }),
    });
    for (kind, d) in [
        (GuideKind::Grey, 1),
        (GuideKind::Normal, 3),
        (GuideKind::NormalDepth, 4),
    ] {
        for s in [1usize, 4] {
            let mode = if s == 1 {
                "exact".to_string()
            } else {
                format!("fast s={s}")
            };
            v.push(FilterConfig {
                filter: "guided",
                label: format!("{d} dims, r=24, {mode}"),
                run: Box::new(move |fr| {
                    let f = Features {
                        normal: Some(&fr.normal),
                        depth: Some(&fr.depth),
                        ..Features::default()
                    };
                    let g = build_guide(kind, &f, DepthNorm::Range, 0.003, 0.003)?;
                    let p = GuidedParams {
                        radius: 24,
                        fast_subsample: s,
                    };
                    std::hint::black_box(guided(&fr.noisy, &g, &p)?);
                    Ok(())
                }),
            });
        }
    }
    for r in [16usize, 24, 32] {
        let p = BilateralParams {
            radius: r,
            sigma_spatial: r as f32 / 2.0,
            ..BilateralParams::default()
        };
        v.push(FilterConfig {
            filter: "cross bilateral",
            label: format!("r={r}, normal + depth"),
            run: Box::new(move |fr| {
                let f = Features {
                    normal: Some(&fr.normal),
                    depth: Some(&fr.depth),
                    ..Features::default()
                };
                std::hint::black_box(bilateral(&fr.noisy, &f, &p)?);
                Ok(())
            }),
        });
    }
    v
}
