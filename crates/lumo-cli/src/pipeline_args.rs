//! The `--pipeline` options of `lumo render`: which of the papers' filtered-GI pipelines turns
//! traced paths into the image, and its knobs.

use anyhow::{anyhow, Result};
use lumo_render::{Pipeline, PipelineOptions};

/// Pipeline selection and parameters.
#[derive(clap::Args, Debug, Clone)]
pub struct PipelineArgs {
    /// How traced paths become the image: atrous (À-Trous on the demodulated image; the
    /// default, see docs/pipelines.md), none (plain path tracing), guided (guided filter on
    /// indirect light), jbu (sparse indirect + joint bilateral upsampling), bilateral
    /// (cross-bilateral reference).
    #[arg(long, default_value = "atrous", value_parser = parse_pipeline)]
    pub pipeline: Pipeline,
    /// atrous: trace every n-th pixel in x and y only (1, 2 or 4) and in-paint the rest.
    #[arg(long, default_value_t = 1)]
    pub subsample: usize,
    /// guided: guide dimensions, 1 (grey), 3 (normal) or 4 (normal + depth).
    #[arg(long, default_value_t = 4)]
    pub guide_dims: usize,
    /// guided: filter window radius in pixels.
    #[arg(long, default_value_t = lumo_filter::DEFAULT_RADIUS)]
    pub radius: usize,
    /// jbu: one indirect sample point per k×k pixel block.
    #[arg(long, default_value_t = 16)]
    pub block: usize,
    /// jbu: indirect paths per sample point.
    #[arg(long, default_value_t = 100)]
    pub paths: u32,
    /// jbu: bilateral pre-filter of the low-resolution buffer.
    #[arg(long)]
    pub prefilter: bool,
}

/// Samples per pixel of filtered pipelines when `--spp` is not given: with À-Trous, 4 spp at
/// 512×512 is a clean image in about a second on 2 cores (docs/pipelines.md).
pub const FILTERED_DEFAULT_SPP: u32 = 4;

impl PipelineArgs {
    /// The library's options.
    pub fn options(&self) -> PipelineOptions {
        PipelineOptions {
            subsample: self.subsample,
            guide_dims: self.guide_dims,
            radius: self.radius,
            block: self.block,
            paths: self.paths,
            prefilter: self.prefilter,
        }
    }
}

/// Parses a pipeline name, listing the valid ones on error.
pub fn parse_pipeline(s: &str) -> Result<Pipeline> {
    Pipeline::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = Pipeline::ALL.iter().map(|p| p.name()).collect();
        anyhow!("unknown pipeline {s:?}; use one of {}", names.join(", "))
    })
}
