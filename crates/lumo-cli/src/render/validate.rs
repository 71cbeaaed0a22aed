//! `lumo render`'s options checked against each other, before the scene is loaded.

use anyhow::{bail, Result};
use lumo_pipeline::Pipeline;
use lumo_render::integrators::photon::DEFAULT_MAX_PHOTONS;
use lumo_render::{Integrator, PpmSettings};

use super::args::RenderArgs;
use crate::arguments::{ppm_map_bytes, MAX_PHOTONS, MAX_SPP};

/// What the options decide on their own, before the scene is read.
pub struct Valid {
    /// The pipeline (`None` for the unfiltered integrators and the temporal filter).
    pub pipeline: Pipeline,
    /// Photon-mapping settings.
    pub ppm: PpmSettings,
    /// Whether the frames are filtered temporally (`--temporal` or `--temporal-eval`).
    pub temporal: bool,
}

/// Checks the options of `args` against each other; reads no file and writes nothing.
pub fn validate(args: &RenderArgs) -> Result<Valid> {
    let integrator = args.integrator.name();
    let unfiltered = !args.integrator.caps().gbuffer;
    let temporal = args.temporal || args.temporal_eval.is_some();
    // The option as typed, for the messages below.
    let temporal_flag = if args.temporal_eval.is_some() {
        "--temporal-eval"
    } else {
        "--temporal"
    };
    let pipeline = match args.pipeline.pipeline {
        Some(p) if unfiltered && p != Pipeline::None => bail!(
            "--integrator {integrator} renders without a filtering pipeline: drop --pipeline {p} (or use --pipeline none)"
        ),
        _ if unfiltered && temporal => bail!(
            "{temporal_flag}: --integrator {integrator} makes no G-buffer for the temporal filter; use --integrator path"
        ),
        Some(p) if temporal && p != Pipeline::None => bail!(
            "{temporal_flag} filters each frame with the temporal filter itself: drop --pipeline {p}"
        ),
        // Traced without a pipeline; the temporal filter takes its place.
        _ if args.temporal => Pipeline::None,
        _ if unfiltered => Pipeline::None,
        _ => args.pipeline.pipeline(),
    };
    if unfiltered && args.aovs.is_some() {
        bail!("--aovs: --integrator {integrator} makes no G-buffer; use --integrator path for AOV planes");
    }
    if args.spectral && !args.integrator.caps().spectral {
        let modes: Vec<(&str, bool)> = Integrator::ALL
            .iter()
            .map(|i| (i.name(), i.caps().spectral))
            .collect();
        bail!(crate::integrator_arg::spectral_refusal(&modes));
    }
    if args.spectral {
        // Fitted once per process (about a second on two cores), before the progress bar.
        lumo_spectrum::coefficient_table();
    }
    if args.integrator != Integrator::Ppm
        && (args.max_photons.is_some()
            || args.photons_per_pass.is_some()
            || args.photon_radius.is_some())
    {
        bail!("--max-photons, --photons-per-pass and --photon-radius apply to --integrator ppm");
    }
    let ppm = ppm_settings(args)?;
    match args.spp {
        Some(0) => bail!("--spp must be at least 1"),
        Some(n) if n > MAX_SPP => bail!("--spp {n}: at most {MAX_SPP} samples per pixel"),
        _ => {}
    }
    crate::cli_common::check_max_depth(args.max_depth)?;
    crate::cli_common::check_rr_depth(args.rr_depth)?;
    args.pipeline
        .check(pipeline, unfiltered.then_some(integrator))?;
    Ok(Valid {
        pipeline,
        ppm,
        temporal,
    })
}

/// The photon-mapping settings of `lumo render`, checked.
pub(super) fn ppm_settings(args: &RenderArgs) -> Result<PpmSettings> {
    let max_photons = args.max_photons.unwrap_or(DEFAULT_MAX_PHOTONS);
    if max_photons == 0 || max_photons > MAX_PHOTONS {
        bail!("--max-photons {max_photons}: expected 1..={MAX_PHOTONS}");
    }
    if args.photons_per_pass == Some(0) {
        bail!("--photons-per-pass must be at least 1");
    }
    let radius = args.photon_radius.unwrap_or(PpmSettings::default().radius);
    if !(radius > 0.0 && radius <= 1.0) {
        bail!("--photon-radius {radius}: expected a fraction of the scene diagonal in (0, 1]");
    }
    if args.integrator == Integrator::Ppm {
        crate::cli_common::check_memory(
            ppm_map_bytes(max_photons),
            &format!("a photon map of {max_photons} photons"),
            "use a smaller --max-photons",
        )?;
    }
    Ok(PpmSettings {
        photons_per_pass: args.photons_per_pass.unwrap_or(0),
        max_photons,
        radius,
        ..Default::default()
    })
}
