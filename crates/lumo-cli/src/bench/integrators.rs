//! `lumo bench integrators`: the light-transport algorithms (path, light, bdpt, ppm) side by
//! side at equal time —
//! relMSE against a converged reference after each time budget, per scene, and the cost of
//! one sample of each relative to the path tracer's.
//!
//! Every integrator renders whole images at a sample count calibrated so that the image
//! takes the budget: a probe image of about a tenth of the largest budget is timed first,
//! then `spp = budget / (probe time per sample)`. The reference
//! is a long bidirectional render with another seed, cached as EXR in the output directory.

use crate::cli_common::{err, errln, outln};
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use lumo_image::metrics::relmse;
use lumo_image::Image;
use lumo_render::camera::PinholeCamera;
use lumo_render::{Integrator, IntegratorOptions, RenderScene, RenderSettings, RenderStats};

use super::scenes::{load_all, scene_names, settings, BenchScene};
use super::{atomic, machine_description};
use crate::arguments::parse_size;

/// Arguments of `lumo bench integrators`.
#[derive(clap::Args, Debug)]
pub struct IntegratorsArgs {
    /// Scenes (built-in names or files) [default: all built-in scenes].
    pub scenes: Vec<String>,
    /// Image size.
    #[arg(long, value_parser = parse_size, default_value = "512x512")]
    size: (usize, usize),
    /// Time budgets in seconds, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,5,30")]
    budgets: Vec<f64>,
    /// Integrators to compare, comma-separated [default: every integrator of the table].
    #[arg(
        long,
        value_parser = crate::integrator_arg::integrators(),
        value_delimiter = ',',
    )]
    integrators: Vec<Integrator>,
    /// Seconds of bidirectional rendering for each scene's reference (cached).
    #[arg(long, default_value_t = 600.0, value_parser = crate::cli_common::parse_seconds)]
    reference_seconds: f64,
    /// A region of interest as fractions of the image `X0,Y0,X1,Y1`: its relMSE gets its own
    /// column (e.g. the caustic under a glass sphere).
    #[arg(long, value_delimiter = ',')]
    region: Option<Vec<f64>>,
    /// Output directory (table, references).
    #[arg(long, default_value = "target/lumo-bench-integrators")]
    out_dir: PathBuf,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = crate::cli_common::parse_threads)]
    threads: Option<usize>,
}

/// Why `integrator` is skipped on `rs` (it cannot render it), as one line; `None` where it
/// renders.
pub fn skipped(integrator: Integrator, rs: &RenderScene, s: &RenderSettings) -> Option<String> {
    let camera = PinholeCamera::new(&rs.scene.camera, s.width, s.height);
    integrator
        .scene_refusal(rs, &camera)
        .map(|why| format!("{} skipped: {why}", integrator.info().label))
}

/// Renders `scene` with `integrator` at `spp` samples (light paths per pixel for the light
/// tracer; photon mapping at its default settings); returns the image with its work
/// counters, and the seconds it took.
pub fn render_image(
    integrator: Integrator,
    rs: &RenderScene,
    s: &RenderSettings,
    pool: &rayon::ThreadPool,
) -> (Image, RenderStats, f64) {
    let t = Instant::now();
    let options = IntegratorOptions::default();
    let out = pool.install(|| integrator.render_image(rs, s, &options, &|_| {}));
    let (image, stats) = (out.image, out.stats);
    (image, stats, t.elapsed().as_secs_f64())
}

/// [`render_image`] for timing: the work counters and the seconds.
pub fn render_with(
    integrator: Integrator,
    rs: &RenderScene,
    s: &RenderSettings,
    pool: &rayon::ThreadPool,
) -> (RenderStats, f64) {
    let (_, stats, secs) = render_image(integrator, rs, s, pool);
    (stats, secs)
}

/// The sample count that makes one image take about `budget` seconds, from a 1-spp timing.
fn calibrated_spp(seconds_per_spp: f64, budget: f64) -> u32 {
    (budget / seconds_per_spp.max(1e-6)).round().clamp(1.0, 1e6) as u32
}

/// The pixels of `region` (fractions) as an image of their own.
fn crop(image: &Image, region: &[f64]) -> Image {
    let (w, h) = (image.width, image.height);
    let x0 = ((region[0] * w as f64) as usize).min(w - 1);
    let y0 = ((region[1] * h as f64) as usize).min(h - 1);
    let x1 = ((region[2] * w as f64).ceil() as usize).clamp(x0 + 1, w);
    let y1 = ((region[3] * h as f64).ceil() as usize).clamp(y0 + 1, h);
    let mut data = Vec::with_capacity((x1 - x0) * (y1 - y0) * image.channels);
    for y in y0..y1 {
        for x in x0..x1 {
            data.extend_from_slice(image.pixel(x, y));
        }
    }
    Image::from_vec(x1 - x0, y1 - y0, image.channels, data)
}

/// The cached reference of `scene`, rendered first if missing.
fn reference(
    args: &IntegratorsArgs,
    scene: &BenchScene,
    pool: &rayon::ThreadPool,
) -> Result<Image> {
    let (w, h) = args.size;
    let path = args.out_dir.join(format!(
        "reference-{}-{w}x{h}-{}s.exr",
        scene.name, args.reference_seconds
    ));
    if let Ok(img) = lumo_image::read_image(&path) {
        if img.width == w && img.height == h {
            return Ok(img);
        }
    }
    let base = settings(args.size, 1, 1000, scene.max_depth, scene.rr_depth);
    let (_, t1) = render_with(Integrator::Bdpt, &scene.rs, &base, pool);
    let spp = calibrated_spp(t1, args.reference_seconds);
    errln!(
        "{}: reference, bdpt {spp} spp (about {:.0} s)",
        scene.name,
        t1 * spp as f64
    );
    let s = RenderSettings { spp, ..base };
    let (img, _, _) = render_image(Integrator::Bdpt, &scene.rs, &s, pool);
    atomic::write_image_atomic(&path, &img)
        .with_context(|| format!("cannot cache the reference {}", path.display()))?;
    Ok(img)
}

/// Runs `lumo bench integrators`.
pub fn run(args: IntegratorsArgs) -> Result<()> {
    if args.budgets.is_empty() || args.budgets.iter().any(|b| !(*b > 0.0 && b.is_finite())) {
        bail!("--budgets: give positive seconds, e.g. --budgets 1,5,30");
    }
    if let Some(r) = &args.region {
        if r.len() != 4
            || r.iter().any(|v| !(0.0..=1.0).contains(v))
            || r[0] >= r[2]
            || r[1] >= r[3]
        {
            bail!("--region X0,Y0,X1,Y1: fractions in [0, 1] with X0 < X1 and Y0 < Y1");
        }
    }
    atomic::check_dir_writable(&args.out_dir)?;
    let pool = crate::cli_common::worker_pool(args.threads)?;
    let names = scene_names(&args.scenes);
    let scenes = load_all(&names, &pool)?;
    let (w, h) = args.size;
    let region_col = if args.region.is_some() {
        " relMSE in region |"
    } else {
        ""
    };
    let mut table = format!(
        "Machine: {}. {w}x{h}; equal-time relMSE against a {} s bidirectional reference; \
         spp calibrated from a probe image.\n\n\
         | scene | integrator | cost/sample vs path | budget s | spp | time s | relMSE |{region_col}\n\
         |---|---|---:|---:|---:|---:|---:|{}\n",
        machine_description(pool.current_num_threads()),
        args.reference_seconds,
        if args.region.is_some() { "---:|" } else { "" }
    );
    for scene in &scenes {
        let reference = reference(&args, scene, &pool)?;
        let base = settings(args.size, 1, 0, scene.max_depth, scene.rr_depth);
        let mut path_cost = None;
        let chosen = if args.integrators.is_empty() {
            &Integrator::ALL[..]
        } else {
            &args.integrators
        };
        for &integrator in chosen {
            if let Some(why) = skipped(integrator, &scene.rs, &base) {
                errln!("{why}");
                continue;
            }
            // One sample per pixel warms up (pages in the BVH) and sizes a probe of about a
            // tenth of the largest budget, whose time per sample sets the sample counts: a
            // 1-spp image alone overstates the cost of fast integrators (fixed overheads).
            let (_, t1) = render_with(integrator, &scene.rs, &base, &pool);
            let largest = args.budgets.iter().cloned().fold(0.0, f64::max);
            let probe = calibrated_spp(t1, 0.1 * largest);
            let probe_settings = RenderSettings { spp: probe, ..base };
            let (_, tp) = render_with(integrator, &scene.rs, &probe_settings, &pool);
            let per_spp = tp / probe as f64;
            let cost = *path_cost.get_or_insert(per_spp);
            for &budget in &args.budgets {
                let spp = calibrated_spp(per_spp, budget);
                let s = RenderSettings { spp, ..base };
                let (img, _, secs) = render_image(integrator, &scene.rs, &s, &pool);
                let err = relmse(&reference, &img)?;
                let region = match &args.region {
                    Some(r) => format!(" {:.5} |", relmse(&crop(&reference, r), &crop(&img, r))?),
                    None => String::new(),
                };
                let line = format!(
                    "| {} | {} | {:.2}× | {budget} | {spp} | {secs:.2} | {err:.5} |{region}\n",
                    scene.name,
                    integrator.name(),
                    per_spp / cost
                );
                err!("{line}");
                table.push_str(&line);
            }
        }
    }
    outln!("\n{table}");
    let out = args.out_dir.join("integrators.md");
    atomic::write_bytes(&out, table.as_bytes())?;
    errln!("→ {}", out.display());
    Ok(())
}
