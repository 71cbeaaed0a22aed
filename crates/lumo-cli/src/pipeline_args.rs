//! The `--pipeline` options of `lumo render`: which of the papers' filtered-GI pipelines turns
//! traced paths into the image, and its knobs.

use crate::cli_common::errln;
use anyhow::{anyhow, bail, Result};
use lumo_pipeline::{Pipeline, PipelineError, PipelineOptions};

/// Pipeline selection and parameters.
#[derive(clap::Args, Debug, Clone)]
pub struct PipelineArgs {
    /// How traced paths become the image: auto (guided filters at several radii and the
    /// À-Trous blended per pixel by their estimated error, as `lumo denoise --filter auto`;
    /// the default, see docs/pipelines.md), atrous (À-Trous on the demodulated image: about
    /// a tenth of auto's filter time), none (plain path tracing), guided (guided filter on
    /// indirect light), jbu (sparse indirect + joint bilateral upsampling), bilateral
    /// (cross-bilateral reference) [default: auto; none with --integrator light].
    #[arg(long, value_parser = parse_pipeline)]
    pub pipeline: Option<Pipeline>,
    /// atrous: trace every n-th pixel in x and y only (1, 2 or 4) and in-paint the rest.
    #[arg(long, default_value_t = 1)]
    pub subsample: usize,
    /// guided: guide dimensions, 1 (grey), 3 (normal) or 4 (normal + depth).
    #[arg(long, default_value_t = DEFAULT_GUIDE_DIMS)]
    pub guide_dims: usize,
    /// guided: filter window radius in pixels.
    #[arg(long, default_value_t = lumo_filter::DEFAULT_RADIUS)]
    pub radius: usize,
    /// jbu: one indirect sample point per k×k pixel block.
    #[arg(long, default_value_t = DEFAULT_BLOCK)]
    pub block: usize,
    /// jbu: indirect paths per sample point.
    #[arg(long, default_value_t = DEFAULT_PATHS)]
    pub paths: u32,
    /// jbu: bilateral pre-filter of the low-resolution buffer.
    #[arg(long)]
    pub prefilter: bool,
}

const DEFAULT_GUIDE_DIMS: usize = 4;
const DEFAULT_BLOCK: usize = 16;
const DEFAULT_PATHS: u32 = 100;

/// Largest image side (`--size`), which also bounds `--radius` and `--block`.
pub const MAX_SIDE: usize = 16384;

/// Most `--paths` per JBU sample point (each point traces them all; 2^20 at the default
/// block size is already more work than 64 spp per pixel).
pub const MAX_PATHS: u32 = 1 << 20;

/// Samples per pixel of filtered pipelines when `--spp` is not given: 4 spp at 512×512 is a
/// clean image in about half a second on 2 cores (docs/pipelines.md).
pub const FILTERED_DEFAULT_SPP: u32 = 4;

impl PipelineArgs {
    /// The pipeline asked for, or the default (`auto`).
    pub fn pipeline(&self) -> Pipeline {
        self.pipeline.unwrap_or(Pipeline::Auto)
    }

    /// Checks the options, naming each as the command line spells it (the filters' own
    /// errors use their internal names). `effective` is the pipeline the run uses, and
    /// `integrator` the integrator's name when it renders without one (light, bdpt, ppm).
    pub fn check(&self, effective: Pipeline, integrator: Option<&str>) -> Result<()> {
        if ![1, 2, 4].contains(&self.subsample) {
            bail!("--subsample {}: use 1, 2 or 4", self.subsample);
        }
        // A pipeline's knob given to a run of another is said in one line, not dropped
        // silently (a value other than the default counts as given).
        let ignored = [
            (
                self.guide_dims != DEFAULT_GUIDE_DIMS,
                "--guide-dims",
                Pipeline::Guided,
            ),
            (
                self.radius != lumo_filter::DEFAULT_RADIUS,
                "--radius",
                Pipeline::Guided,
            ),
            (self.block != DEFAULT_BLOCK, "--block", Pipeline::Jbu),
            (self.paths != DEFAULT_PATHS, "--paths", Pipeline::Jbu),
            (self.prefilter, "--prefilter", Pipeline::Jbu),
        ];
        for (given, flag, owner) in ignored {
            if given && effective != owner {
                errln!(
                    "warning: {flag} applies to --pipeline {}; this run uses --pipeline {}, \
                     ignored",
                    owner.name(),
                    effective.name()
                );
            }
        }
        if self.subsample != 1 && effective != Pipeline::Atrous {
            match integrator {
                Some(i) => bail!(
                    "--subsample {} applies to the path tracer's --pipeline atrous; --integrator \
                     {i} renders without a pipeline: drop --subsample",
                    self.subsample
                ),
                None => bail!(
                    "--subsample {} applies to --pipeline atrous only (this run uses --pipeline \
                     {}): add --pipeline atrous",
                    self.subsample,
                    effective.name()
                ),
            }
        }
        if ![1, 3, 4].contains(&self.guide_dims) {
            bail!("--guide-dims {}: use 1, 3 or 4", self.guide_dims);
        }
        // Bounded by the largest image side: a larger window or block covers any image
        // whole, and the guided filter's buffers grow with the radius (1e8 asked for 819 GB).
        if self.radius == 0 || self.radius > MAX_SIDE {
            bail!("--radius {}: use 1 to {MAX_SIDE}", self.radius);
        }
        if self.block == 0 || self.block > lumo_pipeline::MAX_BLOCK {
            bail!(
                "--block {}: use 1 to {} pixels (the paper uses 16)",
                self.block,
                lumo_pipeline::MAX_BLOCK
            );
        }
        if self.paths == 0 || self.paths > MAX_PATHS {
            bail!("--paths {}: use 1 to {MAX_PATHS}", self.paths);
        }
        Ok(())
    }

    /// The library's options for a `width`×`height` image.
    pub fn options(&self, width: usize, height: usize) -> PipelineOptions {
        PipelineOptions {
            subsample: self.subsample,
            guide_dims: self.guide_dims,
            // A window wider than the image already covers all of it: the same result, with
            // buffers sized by the image instead of the radius.
            radius: self.radius.min(width.max(height)),
            block: self.block,
            paths: self.paths,
            prefilter: self.prefilter,
        }
    }
}

/// A pipeline's error in the command line's words: an out-of-range [`PipelineOptions`] field
/// is named by the flag that set it (`guide_dims` → `--guide-dims`).
pub fn describe_pipeline_error(e: PipelineError) -> anyhow::Error {
    match e {
        PipelineError::Option { option, value, fix } => {
            anyhow!("--{} {value}: {fix}", option.replace('_', "-"))
        }
        other => other.into(),
    }
}

/// Parses a pipeline name, listing the valid ones on error.
pub fn parse_pipeline(s: &str) -> Result<Pipeline> {
    Pipeline::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = Pipeline::ALL.iter().map(|p| p.name()).collect();
        anyhow!("unknown pipeline {s:?}; use one of {}", names.join(", "))
    })
}
