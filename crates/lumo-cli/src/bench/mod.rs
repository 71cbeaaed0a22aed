//! `lumo bench`: benchmarks with stated inputs and machine. `render` measures the path
//! tracer's throughput; `quality` scores every pipeline against a converged reference
//! (docs/results/quality.md + quality.png); `speed` times rendering and filtering in the shape
//! of the papers' Tables 1 and 2 (docs/results/speed.md); `reference` prints (rendering if
//! needed) the cached reference that `quality` uses and `inputs` writes its noisy inputs, for
//! tools such as tools/peers.

mod atomic;
mod cache;
mod contact_sheet;
mod font;
mod heldout;
mod inputs;
mod integrators;
mod quality;
mod quality_integrators;
mod reference;
mod render;
mod report;
mod scenes;
mod speed;
mod speed_report;

use anyhow::Result;

/// Arguments of `lumo bench`.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    #[command(subcommand)]
    what: BenchWhat,
}

#[derive(clap::Subcommand, Debug)]
enum BenchWhat {
    /// Path-tracer throughput (samples/s, rays/s) on the built-in scenes.
    Render(render::RenderBenchArgs),
    /// Error and time of every pipeline against a converged reference → quality.md, quality.png.
    Quality(quality::QualityArgs),
    /// Render time per scene × bounces × spp and filter time per resolution → speed.md.
    Speed(speed::SpeedArgs),
    /// Print the path of the cached reference of a scene, rendering it first if needed.
    Reference(reference::ReferenceArgs),
    /// Write the noisy frame and AOVs that `quality` scores as `none`, as PFM (for peers).
    Inputs(inputs::InputsArgs),
    /// The integrators (path, light, bdpt) at equal time: relMSE after each time budget.
    Integrators(integrators::IntegratorsArgs),
}

/// Runs `lumo bench`.
pub fn run(args: BenchArgs) -> Result<()> {
    match args.what {
        BenchWhat::Render(a) => render::run(a),
        BenchWhat::Quality(a) => quality::run(a),
        BenchWhat::Speed(a) => speed::run(a),
        BenchWhat::Reference(a) => reference::run(a),
        BenchWhat::Inputs(a) => inputs::run(a),
        BenchWhat::Integrators(a) => integrators::run(a),
    }
}

/// "CPU model, N cores, T threads" of this machine, for benchmark tables.
pub fn machine_description(threads: usize) -> String {
    format!(
        "{}, {} cores, {threads} threads",
        cpu_model(),
        std::thread::available_parallelism().map_or(1, |n| n.get())
    )
}

/// The CPU model from /proc/cpuinfo ("unknown CPU" elsewhere).
pub fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

/// The median (upper median for an even count); NaN for no values.
pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Where `bench quality` and `bench speed` write their reports: `--out-dir`, else
/// docs/results with `--publish`, else target/lumo-bench, so that a trial run never replaces
/// the committed results.
pub fn out_dir(out_dir: Option<&std::path::Path>, publish: bool) -> std::path::PathBuf {
    match out_dir {
        Some(d) => d.to_path_buf(),
        None if publish => "docs/results".into(),
        None => "target/lumo-bench".into(),
    }
}
