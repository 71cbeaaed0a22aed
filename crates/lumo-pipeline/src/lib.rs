//! The papers' filtered global-illumination pipelines (papers/README §1–3): each decides what to
//! trace, what to filter and how to put the image back together. Filters only ever see image
//! planes (lumo-filter); tracing goes through [`map_pixels`](lumo_render::map_pixels), the
//! crate's one parallel loop.

#![forbid(unsafe_code)]

mod atrous;
mod auto;
mod bilateral;
mod compose;
mod guided;
mod jbu;

pub use jbu::MAX_BLOCK;

use std::fmt;
use std::time::Duration;

use lumo_filter::FilterError;
use lumo_image::Image;
use thiserror::Error;

use lumo_render::{Frame, PixelSums, RenderScene, RenderSettings, RenderStats};

/// A way of turning traced paths into an image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pipeline {
    /// Plain path tracing, no filter.
    None,
    /// Edge-avoiding À-Trous on the whole demodulated image (§1).
    Atrous,
    /// Indirect light at the guide rays, 4-D guided filter, geometry-aware lookup (§2).
    Guided,
    /// Indirect light on a sparse grid, joint bilateral upsampling (§3).
    Jbu,
    /// Cross-bilateral filter on the demodulated indirect light (the papers' quality reference).
    Bilateral,
    /// Full paths, then guided filters at several radii blended per pixel by their estimated
    /// error (lumo-filter's `auto`).
    Auto,
}

impl Pipeline {
    /// Every pipeline, in the order tables list them.
    pub const ALL: [Pipeline; 6] = [
        Pipeline::None,
        Pipeline::Bilateral,
        Pipeline::Atrous,
        Pipeline::Guided,
        Pipeline::Jbu,
        Pipeline::Auto,
    ];

    /// Whether the pipeline traces nothing but full paths at every pixel, so that it can
    /// filter samples traced elsewhere ([`run_pipeline_on_sums`]).
    pub fn takes_sums(self, options: &PipelineOptions) -> bool {
        match self {
            Pipeline::None | Pipeline::Bilateral | Pipeline::Auto => true,
            Pipeline::Atrous => options.subsample == 1,
            Pipeline::Guided | Pipeline::Jbu => false,
        }
    }

    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Pipeline::None => "none",
            Pipeline::Atrous => "atrous",
            Pipeline::Guided => "guided",
            Pipeline::Jbu => "jbu",
            Pipeline::Bilateral => "bilateral",
            Pipeline::Auto => "auto",
        }
    }

    /// Parses a command-line name.
    pub fn from_name(name: &str) -> Option<Pipeline> {
        Pipeline::ALL.into_iter().find(|p| p.name() == name)
    }

    /// Working memory of a render through this pipeline per image pixel, in bytes: the
    /// frame's AOV planes, the pipeline's buffers and the output. Measured as peak RSS over a
    /// 1024x1024 `lumo render`, less that of an 8x8 one: none 199, jbu 199, bilateral 210,
    /// atrous 306, guided 408, auto 630 (four candidate images and their error maps); at
    /// 4096x4096 atrous: 294; rounded up. Callers refuse sizes that cannot fit before
    /// allocating.
    pub fn bytes_per_pixel(self) -> u64 {
        match self {
            Pipeline::None | Pipeline::Jbu => 220,
            Pipeline::Bilateral => 230,
            Pipeline::Atrous => 320,
            Pipeline::Guided => 430,
            Pipeline::Auto => 660,
        }
    }
}

impl fmt::Display for Pipeline {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Pipeline-specific knobs; each pipeline reads only its own.
#[derive(Clone, Debug, PartialEq)]
pub struct PipelineOptions {
    /// À-Trous: trace every n-th pixel in x and y only (1, 2 or 4) and in-paint the rest.
    pub subsample: usize,
    /// Guided: guide dimensions, 1 (grey normal), 3 (normal) or 4 (normal + depth).
    pub guide_dims: usize,
    /// Guided: window radius in pixels.
    pub radius: usize,
    /// JBU: one indirect sample point per `block`×`block` pixels.
    pub block: usize,
    /// JBU: paths traced at each sample point.
    pub paths: u32,
    /// JBU: bilateral pre-filter of the low-resolution buffer.
    pub prefilter: bool,
}

impl Default for PipelineOptions {
    fn default() -> Self {
        Self {
            subsample: 1,
            guide_dims: 4,
            radius: lumo_filter::DEFAULT_RADIUS,
            block: 16,
            paths: 100,
            prefilter: false,
        }
    }
}

/// Wall time per stage, in the shape of the papers' Table 1.
#[derive(Clone, Copy, Debug, Default)]
pub struct Timings {
    /// Path tracing (for pipelines with a separate G-buffer pass: the indirect paths only).
    pub trace: Duration,
    /// The separate G-buffer (and direct light) pass; zero where the trace fills the G-buffer.
    pub gbuffer: Duration,
    /// Filtering.
    pub filter: Duration,
    /// Recomposition (remodulation, lookups, adding direct light).
    pub compose: Duration,
}

impl Timings {
    /// Sum of the stages.
    pub fn total(&self) -> Duration {
        self.trace + self.gbuffer + self.filter + self.compose
    }
}

impl fmt::Display for Timings {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        write!(
            f,
            "trace {:.0} ms · G-buffer {:.0} ms · filter {:.0} ms · compose {:.0} ms · total {:.0} ms",
            ms(self.trace),
            ms(self.gbuffer),
            ms(self.filter),
            ms(self.compose),
            ms(self.total())
        )
    }
}

/// Every name a pipeline's intermediate planes ([`PipelineOutput::planes`]) may have: `lumo
/// render --aovs` writes them as `<name>.exr` next to the frame's planes
/// ([`lumo_render::AOV_NAMES`]), and refuses an `-o` that one of them would overwrite.
pub const PLANE_NAMES: &[&str] = &[
    "indirect_raw",
    "illumination_raw",
    "illumination_filtered",
    "illumination_upsampled",
    "low_illumination",
    "low_indirect",
    "lookup_misses",
    // The Dirac lights' exact light (`auto`, and `render --aovs` for every pipeline).
    "dirac",
];

/// What a pipeline produced.
pub struct PipelineOutput {
    /// The final image (3 channels, linear RGB).
    pub image: Image,
    /// The traced frame (unfiltered colour, direct, indirect, G-buffer, variance).
    pub frame: Frame,
    /// Intermediate planes worth inspecting (e.g. raw and filtered indirect light).
    pub planes: Vec<(&'static str, Image)>,
    /// Time per stage.
    pub timings: Timings,
    /// Work counters (camera samples and rays of every pass).
    pub stats: RenderStats,
}

/// Why a pipeline could not run.
#[derive(Debug, Error)]
pub enum PipelineError {
    /// A filter rejected its input or parameters.
    #[error(transparent)]
    Filter(#[from] FilterError),
    /// A [`PipelineOptions`] field out of range.
    #[error("pipeline option {option} = {value}: {fix}")]
    Option {
        /// The [`PipelineOptions`] field's name.
        option: &'static str,
        /// The value given.
        value: String,
        /// What to use instead.
        fix: &'static str,
    },
}

/// Runs `pipeline` on `rs`. `progress` receives the fraction of tracing work done (0–1).
pub fn run_pipeline(
    rs: &RenderScene,
    pipeline: Pipeline,
    settings: &RenderSettings,
    options: &PipelineOptions,
    progress: &(dyn Fn(f32) + Sync),
) -> Result<PipelineOutput, PipelineError> {
    run(rs, pipeline, settings, options, progress, None)
}

/// Runs `pipeline` on samples traced elsewhere: `sums` holds, per pixel in row-major order,
/// the exact sums of samples `0..settings.spp` (a distributed render's chunks added up). The
/// output is bit for bit [`run_pipeline`]'s, which traces the same sums itself. Only pipelines
/// that trace one full frame of paths take this ([`Pipeline::takes_sums`]).
pub fn run_pipeline_on_sums(
    rs: &RenderScene,
    pipeline: Pipeline,
    settings: &RenderSettings,
    options: &PipelineOptions,
    sums: Vec<PixelSums>,
) -> Result<PipelineOutput, PipelineError> {
    if !pipeline.takes_sums(options) {
        return Err(PipelineError::Option {
            option: "pipeline",
            value: pipeline.name().to_owned(),
            fix: "this pipeline traces more than full paths per pixel (guide rays, a sparse or \
                  subsampled grid) and cannot take samples traced elsewhere; use none, atrous \
                  (without subsample), bilateral or auto",
        });
    }
    if sums.len() != settings.width * settings.height {
        return Err(PipelineError::Option {
            option: "sums",
            value: format!("{} pixels", sums.len()),
            fix: "give one PixelSums per pixel of the frame",
        });
    }
    run(rs, pipeline, settings, options, &|_| {}, Some(sums))
}

fn run(
    rs: &RenderScene,
    pipeline: Pipeline,
    settings: &RenderSettings,
    options: &PipelineOptions,
    progress: &(dyn Fn(f32) + Sync),
    given: Option<Vec<PixelSums>>,
) -> Result<PipelineOutput, PipelineError> {
    match pipeline {
        Pipeline::None => Ok(compose::plain(rs, settings, progress, given)),
        Pipeline::Atrous => atrous::run(rs, settings, options, progress, given),
        Pipeline::Guided => guided::run(rs, settings, options, progress),
        Pipeline::Jbu => jbu::run(rs, settings, options, progress),
        Pipeline::Bilateral => bilateral::run(rs, settings, progress, given),
        Pipeline::Auto => auto::run(rs, settings, progress, given),
    }
}
