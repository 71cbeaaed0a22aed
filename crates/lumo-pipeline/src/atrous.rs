//! The À-Trous pipeline (papers/README §1): trace at full resolution (or every n-th pixel),
//! demodulate by albedo, filter with colour, normal and position edge-stopping weights
//! (variance-guided), remodulate. Unlike the other pipelines it filters direct light too.

use std::time::Instant;

use lumo_filter::{
    spatial_variance, with_emitted, AtrousDenoiser, AtrousParams, Denoiser, Features, FilterInput,
};

use super::compose::{frame_with_variance, trace_full};
use super::{PipelineError, PipelineOptions, PipelineOutput, Timings};
use lumo_render::camera::PinholeCamera;
use lumo_render::integrators::path::wavefront::render_pixels;
use lumo_render::{map_pixels, map_rows, render_pixel};
use lumo_render::{PixelSums, RenderScene, RenderSettings, RenderStats};

pub(super) fn run(
    rs: &RenderScene,
    settings: &RenderSettings,
    options: &PipelineOptions,
    progress: &(dyn Fn(f32) + Sync),
    given: Option<Vec<PixelSums>>,
) -> Result<PipelineOutput, PipelineError> {
    let n = options.subsample;
    if ![1, 2, 4].contains(&n) {
        return Err(PipelineError::Option {
            option: "subsample",
            value: n.to_string(),
            fix: "use 1, 2 or 4",
        });
    }
    let (estimates, mut frame, stats, trace) = if n == 1 {
        trace_full(rs, settings, progress, given)
    } else {
        trace_sparse(rs, settings, n, progress)
    };
    let t = Instant::now();
    // Emitters seen directly are kept out of the filter: their radiance is orders of magnitude
    // above their surroundings and would bleed into every coplanar neighbour.
    let (w, h) = (settings.width, settings.height);
    let traced = |i: usize| (i % w).is_multiple_of(n) && (i / w).is_multiple_of(n);
    let emitter: Vec<bool> = estimates
        .iter()
        .map(|e| e.first_hit.is_visible_emitter())
        .collect();
    // The colour weight is steered by a spatial estimate of the noise in the mean image (see
    // `lumo_filter::spatial_variance`) at every spp: per-pixel variances of a few samples are zero
    // wherever those samples happen to agree, which pins such pixels against all smoothing.
    // At 1 spp the frame already holds exactly that estimate.
    let computed;
    let variance = if frame.spp == 1 {
        &frame.variance
    } else {
        computed = spatial_variance(&frame.color);
        &computed
    };
    let features = Features {
        normal: Some(&frame.normal),
        position: Some(&frame.position),
        depth: Some(&frame.depth),
        albedo: Some(&frame.albedo),
        variance: Some(variance),
    };
    let mut denoiser = AtrousDenoiser::new(AtrousParams {
        sparse: n,
        demodulate: true,
        ..AtrousParams::default()
    });
    // The light's share of its rim pixels (samples on the light, centre ray off it) stays out
    // as well: the mean emitted radiance is subtracted before the filter and added after.
    let filtered = with_emitted(&frame.color, &emitter, &frame.emitted, |c| {
        if n == 1 {
            return denoiser.denoise(&FilterInput::new(c, features));
        }
        // Only the traced pixels carry colour; the filter in-paints the others.
        let mut sparse = c.clone();
        for i in (0..w * h).filter(|&i| !traced(i)) {
            sparse.data[i * 3..i * 3 + 3].fill(f32::NAN);
        }
        denoiser.denoise(&FilterInput::new(&sparse, features))
    })?;
    let filter = t.elapsed();
    let t = Instant::now();
    let image = filtered.image;
    if n > 1 {
        // The traced frame's colour is meaningful only at the traced pixels.
        for i in (0..w * h).filter(|&i| !traced(i)) {
            frame.color.data[i * 3..i * 3 + 3].fill(f32::NAN);
        }
    }
    let compose = t.elapsed();
    Ok(PipelineOutput {
        image,
        frame,
        planes: vec![],
        timings: Timings {
            trace,
            filter,
            compose,
            ..Timings::default()
        },
        stats,
    })
}

/// Traces full paths at pixels with x ≡ y ≡ 0 (mod n) and only the G-buffer (camera ray, depth
/// 1) elsewhere.
fn trace_sparse(
    rs: &RenderScene,
    settings: &RenderSettings,
    n: usize,
    progress: &(dyn Fn(f32) + Sync),
) -> (
    Vec<lumo_render::PixelEstimate>,
    lumo_render::Frame,
    RenderStats,
    std::time::Duration,
) {
    let t = Instant::now();
    let (w, h) = (settings.width, settings.height);
    let camera = PinholeCamera::new(&rs.scene.camera, w, h);
    let mut gbuffer_only = *settings;
    gbuffer_only.spp = 1;
    gbuffer_only.path.max_depth = 1;
    let rows = |done: usize| progress(done as f32 / h.max(1) as f32);
    let estimates = if n == 1 {
        // Every pixel traced: whole rows through the wavefront renderer (fuller packets).
        map_rows(h, &rows, |y| render_pixels(rs, &camera, settings, y, 0..w))
    } else {
        map_pixels(w, h, &rows, |x, y| {
            let s = if x.is_multiple_of(n) && y.is_multiple_of(n) {
                settings
            } else {
                &gbuffer_only
            };
            render_pixel(rs, &camera, s, x, y)
        })
    };
    let frame = frame_with_variance(w, h, settings.spp, &estimates);
    let traced = w.div_ceil(n) * h.div_ceil(n);
    let stats = RenderStats {
        samples: (traced as u64) * settings.spp as u64 + (w * h - traced) as u64,
        rays: estimates.iter().map(|e| e.rays).sum(),
    };
    (estimates, frame, stats, t.elapsed())
}
