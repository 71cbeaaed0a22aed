//! The `auto` pipeline: trace full paths at every pixel, then lumo-filter's `auto` estimator
//! (guided filters at several radii on the albedo-demodulated colour, blended per pixel by
//! their leave-one-out error; docs/filters.md). Lights seen directly pass through untouched,
//! as in the À-Trous pipeline: the renderer knows exactly where they are, and on a light's rim
//! how much of each pixel's colour the light is.
//!
//! The light of point, spot and directional lights at each sample's first hit has no noise
//! but the pixel's own footprint, and it carries a sunlit frame's sharpest shadows, which no
//! guide shows: it is computed exactly (`lumo_render::dirac_direct`), left out of the
//! filter's input and added back unfiltered (docs/filters.md, "Dirac light skips the filter").

use std::time::Instant;

use lumo_filter::{with_emitted, AutoDenoiser, Denoiser, Features, FilterInput};

use super::compose::trace_full;
use super::{PipelineError, PipelineOutput, Timings};
use lumo_render::camera::PinholeCamera;
use lumo_render::{dirac_direct, PixelSums, RenderScene, RenderSettings};

pub(super) fn run(
    rs: &RenderScene,
    settings: &RenderSettings,
    progress: &(dyn Fn(f32) + Sync),
    given: Option<Vec<PixelSums>>,
) -> Result<PipelineOutput, PipelineError> {
    let (estimates, frame, stats, trace) = trace_full(rs, settings, progress, given);
    let t = Instant::now();
    let camera = PinholeCamera::new(&rs.scene.camera, settings.width, settings.height);
    let dirac = dirac_direct(rs, &camera, settings);
    let gbuffer = t.elapsed();
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
    let mut rest = frame.color.clone();
    if let Some(d) = &dirac {
        rest.add_scaled_finite(d, -1.0);
    }
    let filtered = with_emitted(&rest, &emitter, &frame.emitted, |c| {
        denoiser.denoise(&FilterInput::new(c, features))
    })?;
    let mut image = filtered.image;
    if let Some(d) = &dirac {
        image.add_scaled_finite(d, 1.0);
    }
    Ok(PipelineOutput {
        image,
        frame,
        planes: dirac.into_iter().map(|d| ("dirac", d)).collect(),
        timings: Timings {
            trace,
            gbuffer,
            filter: t.elapsed(),
            ..Timings::default()
        },
        stats,
    })
}
