//! Pieces the pipelines share: the full-resolution trace, indirect-light demodulation and
//! recomposition, and the fixed depth scale of the guide.

use std::time::{Duration, Instant};

use lumo_filter::Demodulated;
use lumo_image::Image;

use super::{PipelineOutput, Timings};
use lumo_render::{frame_from_estimates, render_estimates};
use lumo_render::{Frame, PixelEstimate, PixelSums, RenderScene, RenderSettings, RenderStats};

/// Traces every pixel with `settings`, reporting progress as a fraction of rows, or takes the
/// exact sums of the same samples traced elsewhere (`given`: a distributed render's chunks,
/// added up).
pub(super) fn trace_full(
    rs: &RenderScene,
    settings: &RenderSettings,
    progress: &(dyn Fn(f32) + Sync),
    given: Option<Vec<PixelSums>>,
) -> (Vec<PixelEstimate>, Frame, RenderStats, Duration) {
    let t = Instant::now();
    let (w, h) = (settings.width, settings.height);
    // Traced here, the estimates are written in place without the exact sums (which only a
    // distributed render's chunks need to add up): the same bits, a third of the memory.
    let estimates: Vec<PixelEstimate> = match given {
        Some(sums) => sums.iter().map(PixelSums::estimate).collect(),
        None => render_estimates(rs, settings, progress),
    };
    let frame = frame_with_variance(w, h, settings.spp, &estimates);
    let stats = RenderStats {
        samples: (w * h) as u64 * settings.spp as u64,
        rays: estimates.iter().map(|e| e.rays).sum(),
    };
    (estimates, frame, stats, t.elapsed())
}

/// [`frame_from_estimates`] with a variance plane filters can use at one sample per pixel: a
/// single sample has no per-pixel variance (the renderer leaves 0), so it is estimated from
/// 3×3 neighbourhoods instead, as SVGF does before it has history.
pub(super) fn frame_with_variance(
    w: usize,
    h: usize,
    spp: u32,
    estimates: &[PixelEstimate],
) -> Frame {
    let mut frame = frame_from_estimates(w, h, spp, estimates);
    if spp == 1 {
        frame.variance = lumo_filter::spatial_variance(&frame.color);
    }
    frame
}

/// The `none` pipeline: the traced colour as it is.
pub(super) fn plain(
    rs: &RenderScene,
    settings: &RenderSettings,
    progress: &(dyn Fn(f32) + Sync),
    given: Option<Vec<PixelSums>>,
) -> PipelineOutput {
    let (_, frame, stats, trace) = trace_full(rs, settings, progress, given);
    PipelineOutput {
        image: frame.color.clone(),
        frame,
        planes: vec![],
        timings: Timings {
            trace,
            ..Timings::default()
        },
        stats,
    }
}

/// `direct + albedo × illumination`, where `illumination` is filtered demodulated indirect
/// light; pixels the demodulation passed through (albedo ≈ 0) keep their raw indirect light.
pub(super) fn recompose(
    direct: &Image,
    raw_indirect: &Image,
    demod: &Demodulated,
    illumination: &Image,
) -> Image {
    let mut out = direct.clone();
    for (i, &pass) in demod.passthrough.iter().enumerate() {
        for c in 0..3 {
            let k = i * 3 + c;
            let ind = if pass {
                raw_indirect.data[k]
            } else {
                demod.albedo.data[k] * illumination.data[k]
            };
            if ind.is_finite() {
                out.data[k] += ind;
            }
        }
    }
    out
}

/// The constant that maps camera distance to the guide's [0, 1] depth: the diagonal of the
/// scene's bounds, fixed for the whole render so the guide does not change meaning between
/// frames (the guided-filter paper's choice).
pub(super) fn depth_scale(rs: &RenderScene) -> f32 {
    let (lo, hi) = rs.scene.bounds();
    let d = (hi - lo).length();
    if d.is_finite() && d > 0.0 {
        d
    } else {
        1.0
    }
}

/// A copy of `settings` whose paths stop after direct light (Mitsuba depth 2), or earlier if
/// the user asked for less.
pub(super) fn direct_only(settings: &RenderSettings) -> RenderSettings {
    let mut s = *settings;
    s.path.max_depth = s.path.max_depth.min(2);
    s
}
