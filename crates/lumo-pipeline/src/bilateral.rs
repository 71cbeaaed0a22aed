//! The cross-bilateral pipeline: the papers' quality reference. Full-resolution path tracing,
//! then a brute-force cross-bilateral filter (normal + depth range terms) on the demodulated
//! indirect light; direct light stays unfiltered.

use std::time::Instant;

use std::borrow::Cow;

use lumo_filter::{demodulate, surface_albedo, BilateralDenoiser, Denoiser, Features, FilterInput};

use super::compose::{recompose, trace_full};
use super::{PipelineError, PipelineOutput, Timings};
use lumo_render::{PixelSums, RenderScene, RenderSettings};

pub(super) fn run(
    rs: &RenderScene,
    settings: &RenderSettings,
    progress: &(dyn Fn(f32) + Sync),
    given: Option<Vec<PixelSums>>,
) -> Result<PipelineOutput, PipelineError> {
    let (_, frame, stats, trace) = trace_full(rs, settings, progress, given);
    let t = Instant::now();
    let features = Features {
        normal: Some(&frame.normal),
        depth: Some(&frame.depth),
        albedo: Some(&frame.albedo),
        ..Features::default()
    };
    // Background pixels (the centre ray missed) keep their raw light, as in `lumo denoise`.
    let albedo = surface_albedo(&features).unwrap_or(Cow::Borrowed(&frame.albedo));
    let demod = demodulate(&frame.indirect, &albedo)?;
    let filtered =
        BilateralDenoiser::default().denoise(&FilterInput::new(&demod.illumination, features))?;
    let filter = t.elapsed();
    let t = Instant::now();
    let image = recompose(&frame.direct, &frame.indirect, &demod, &filtered.image);
    let compose = t.elapsed();
    Ok(PipelineOutput {
        image,
        planes: vec![
            ("indirect_raw", frame.indirect.clone()),
            ("illumination_filtered", filtered.image),
        ],
        frame,
        timings: Timings {
            trace,
            filter,
            compose,
            ..Timings::default()
        },
        stats,
    })
}
