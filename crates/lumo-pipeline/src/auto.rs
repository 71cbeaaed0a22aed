//! The `auto` pipeline: trace full paths at every pixel, then lumo-filter's `auto` estimator
//! (guided filters at several radii on the albedo-demodulated colour, blended per pixel by
//! their leave-one-out error; docs/filters.md). Lights seen directly pass through untouched,
//! as in the À-Trous pipeline: the renderer knows exactly where they are, and on a light's rim
//! how much of each pixel's colour the light is.

use std::time::Instant;

use lumo_filter::{with_emitted, AutoDenoiser, Denoiser, Features, FilterInput};

use super::compose::trace_full;
use super::{PipelineError, PipelineOutput, Timings};
use lumo_render::{PixelSums, RenderScene, RenderSettings};

pub(super) fn run(
    rs: &RenderScene,
    settings: &RenderSettings,
    progress: &(dyn Fn(f32) + Sync),
    given: Option<Vec<PixelSums>>,
) -> Result<PipelineOutput, PipelineError> {
    let (estimates, frame, stats, trace) = trace_full(rs, settings, progress, given);
    let t = Instant::now();
    let emitter: Vec<bool> = estimates
        .iter()
        .map(|e| e.first_hit.is_visible_emitter())
        .collect();
    let features = Features {
        normal: Some(&frame.normal),
        depth: Some(&frame.depth),
        albedo: Some(&frame.albedo),
        ..Features::default()
    };
    let mut denoiser = AutoDenoiser::default();
    // The light's share of its rim pixels stays out too (`with_emitted`).
    let filtered = with_emitted(&frame.color, &emitter, &frame.emitted, |c| {
        denoiser.denoise(&FilterInput::new(c, features))
    })?;
    Ok(PipelineOutput {
        image: filtered.image,
        frame,
        planes: vec![],
        timings: Timings {
            trace,
            filter: t.elapsed(),
            ..Timings::default()
        },
        stats,
    })
}
