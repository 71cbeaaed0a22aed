//! The integrator rows of `lumo bench quality`: the light tracer, bidirectional path tracing
//! and photon mapping at **equal time** with the unfiltered path tracer (`none`) of each scene
//! and spp, scored against the same converged reference.
//!
//! Each integrator gets the wall time of the `none` render of its scene and spp: a 1-spp
//! image is timed, and the image that is scored uses `round(time of none / time of that
//! probe)` samples (at least 1; the probe itself when that is 1). Sample counts depend on
//! timing, so these rows are not bit-reproducible like the pipelines' (the per-scene tables
//! hold only pipelines for that reason).

use std::fmt::Write as _;

use anyhow::{Context, Result};
use lumo_image::metrics::{compare, CompareSettings, Metrics};
use lumo_image::Image;

use super::integrators::{render_image, skipped};
use super::scenes::BenchScene;
use lumo_render::Integrator;

/// One integrator's image at equal time with the path tracer's `none` row.
pub struct IntegratorScored {
    /// Scene name.
    pub scene: String,
    /// The spp of the `none` row whose time it was given.
    pub path_spp: u32,
    /// The integrator.
    pub integrator: Integrator,
    /// Samples it rendered in that time (light paths per pixel for the light tracer).
    pub spp: u32,
    /// Seconds its scored image took.
    pub seconds: f64,
    /// The time budget (seconds of the `none` render).
    pub budget: f64,
    /// Scores against the reference.
    pub metrics: Metrics,
}

/// The integrators that get rows: every one asked for (none asked: every one of the table)
/// but the path tracer (the `none` rows are its images), each once.
pub fn row_integrators(asked: &[Integrator]) -> Vec<Integrator> {
    let asked = if asked.is_empty() {
        &Integrator::ALL[..]
    } else {
        asked
    };
    let mut out: Vec<Integrator> = Vec::new();
    for &i in asked {
        if i != Integrator::Path && !out.contains(&i) {
            out.push(i);
        }
    }
    out
}

/// The row label of an integrator in the summary tables.
pub fn label(i: Integrator) -> String {
    format!("{} (equal time)", i.name())
}

/// Renders and scores `integrator` on `scene` in `budget` seconds (see the module doc).
/// `None` when the integrator cannot render the scene (the light tracer without particles).
#[allow(clippy::too_many_arguments)]
pub fn score(
    integrator: Integrator,
    scene: &BenchScene,
    settings: &lumo_render::RenderSettings,
    budget: f64,
    reference: &Image,
    compare_settings: &CompareSettings,
    pool: &rayon::ThreadPool,
) -> Result<Option<IntegratorScored>> {
    if skipped(integrator, &scene.rs, settings).is_some() {
        return Ok(None);
    }
    let probe = lumo_render::RenderSettings {
        spp: 1,
        ..*settings
    };
    let (mut image, _, mut seconds) = render_image(integrator, &scene.rs, &probe, pool);
    let spp = (budget / seconds.max(1e-6)).round().clamp(1.0, 1e6) as u32;
    if spp > 1 {
        let s = lumo_render::RenderSettings { spp, ..*settings };
        (image, _, seconds) = render_image(integrator, &scene.rs, &s, pool);
    }
    let metrics = compare(reference, &image, compare_settings)
        .with_context(|| format!("scoring {} {}", scene.name, integrator.name()))?;
    Ok(Some(IntegratorScored {
        scene: scene.name.clone(),
        path_spp: settings.spp,
        integrator,
        spp,
        seconds,
        budget,
        metrics,
    }))
}

/// The cell of `integrator` on `scene` at `spp` in a summary table, if it was scored.
pub fn cell<'a>(
    rows: &'a [IntegratorScored],
    integrator: Integrator,
    scene: &str,
    spp: u32,
) -> Option<&'a IntegratorScored> {
    rows.iter()
        .find(|r| r.integrator == integrator && r.scene == scene && r.path_spp == spp)
}

/// `## Integrators at equal time`: every integrator row with its sample count and times.
pub fn section(md: &mut String, rows: &[IntegratorScored]) {
    if rows.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "## Integrators at equal time\n\n\
         Each integrator renders in the wall time of the path tracer's unfiltered image \
         (`none`) of the same scene and spp, its sample count sized from a timed 1-spp image \
         (at least 1 sample, so it can overrun small budgets); scores against the same \
         reference. Sample counts follow the timing, so these rows vary from run to run.\n\n\
         | scene | none spp | integrator | spp | budget ms | time ms | relMSE | FLIP | SSIM |\n\
         |---|---:|---|---:|---:|---:|---:|---:|---:|"
    );
    for r in rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {:.0} | {:.0} | {:.2e} | {:.4} | {:.4} |",
            r.scene,
            r.path_spp,
            r.integrator.name(),
            r.spp,
            r.budget * 1e3,
            r.seconds * 1e3,
            r.metrics.relmse,
            r.metrics.flip,
            r.metrics.ssim,
        );
    }
    md.push('\n');
}
