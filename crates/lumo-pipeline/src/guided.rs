//! The guided-filter pipeline (papers/README §2, Bauszat et al. 2011). Direct light is traced
//! for every sample and never filtered. Indirect light is traced once per pixel, along the
//! pixel-centre guide ray, demodulated by albedo and filtered with the guided filter steered by
//! normals and depth. Further samples of a pixel take their indirect light from the filtered
//! map at the neighbouring guide pixel on the same surface (geometry-aware lookup, eqs 3–5),
//! times their own albedo; a box filter averages the samples.

use std::time::Instant;

use glam::{Vec2, Vec3};
use std::borrow::Cow;

use lumo_filter::{
    demodulate, most_similar_in_grid, neighbour_cells, surface_albedo, Denoiser, DepthNorm,
    Features, FilterInput, GuideKind, GuidedDenoiser, GuidedParams, DEFAULT_EPS_DEPTH,
    DEFAULT_EPS_NORMAL,
};
use lumo_image::Image;

use super::compose::{depth_scale, direct_only, frame_with_variance, recompose};
use super::{PipelineError, PipelineOptions, PipelineOutput, Timings};
use lumo_render::camera::PinholeCamera;
use lumo_render::integrators::path::wavefront::render_pixels;
use lumo_render::{map_pixels, map_rows, trace_sample};
use lumo_render::{FirstHit, Frame, PixelEstimate, RenderScene, RenderSettings, RenderStats};

/// A pixel's guide-ray estimate plus its extra direct-light samples.
struct GuidedPixel {
    guide: PixelEstimate,
    extra: Vec<ExtraSample>,
}

/// A sample beyond the guide ray: direct light, where it landed and what it hit.
struct ExtraSample {
    direct: Vec3,
    offset: Vec2,
    hit: FirstHit,
    rays: u32,
}

pub(super) fn run(
    rs: &RenderScene,
    settings: &RenderSettings,
    options: &PipelineOptions,
    progress: &(dyn Fn(f32) + Sync),
) -> Result<PipelineOutput, PipelineError> {
    let kind = match options.guide_dims {
        1 => GuideKind::Grey,
        3 => GuideKind::Normal,
        4 => GuideKind::NormalDepth,
        d => {
            return Err(PipelineError::Option {
                option: "guide_dims",
                value: d.to_string(),
                fix: "use 1 (grey), 3 (normal) or 4 (normal + depth)",
            })
        }
    };
    let t = Instant::now();
    let (w, h) = (settings.width, settings.height);
    let camera = PinholeCamera::new(&rs.scene.camera, w, h);
    let mut guide_settings = *settings;
    guide_settings.spp = 1;
    let direct_settings = direct_only(settings);
    let rows = |done: usize| progress(done as f32 / h.max(1) as f32);
    // The guide rays (sample 0 of each pixel, full paths) a row at a time through the wavefront
    // renderer; each pixel's extra direct-light samples one at a time.
    let guides = map_rows(h, &rows, |y| {
        render_pixels(rs, &camera, &guide_settings, y, 0..w)
    });
    let pixels = map_pixels(w, h, &|_| {}, |x, y| {
        let guide = guides[y * w + x];
        let extra = (1..settings.spp)
            .map(|i| {
                let mut hit = FirstHit::default();
                let (r, offset) =
                    trace_sample(rs, &camera, &direct_settings, (x, y), i, Some(&mut hit));
                ExtraSample {
                    direct: r.direct,
                    offset,
                    hit,
                    rays: r.rays,
                }
            })
            .collect();
        GuidedPixel { guide, extra }
    });
    let mut frame = frame_with_variance(w, h, 1, &guides);
    let stats = RenderStats {
        samples: (w * h) as u64 * settings.spp.max(1) as u64,
        rays: guides.iter().map(|e| e.rays).sum::<u64>() + extra_rays(&pixels),
    };
    let trace = t.elapsed();

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
    let mut denoiser = GuidedDenoiser {
        guide: kind,
        depth_norm: DepthNorm::Scale(depth_scale(rs)),
        eps_normal: DEFAULT_EPS_NORMAL,
        eps_depth: DEFAULT_EPS_DEPTH,
        params: GuidedParams {
            radius: options.radius,
            fast_subsample: 1,
        },
        demodulate: false,
    };
    let filtered = denoiser
        .denoise(&FilterInput::new(&demod.illumination, features))?
        .image;
    let filter = t.elapsed();

    let t = Instant::now();
    // Sample 0 of each pixel: its own direct light plus its own filtered indirect light.
    let guide_image = recompose(&frame.direct, &frame.indirect, &demod, &filtered);
    let (normal, depth) = (&frame.normal, &frame.depth);
    let mut lookup_misses = None;
    let image = if settings.spp <= 1 {
        guide_image
    } else {
        let composed = map_pixels(w, h, &|_| {}, |x, y| {
            let p = &pixels[y * w + x];
            let mut sum = Vec3::from(guide_image.rgb(x, y));
            let mut misses = [0.0f32; 2];
            for s in &p.extra {
                let (sx, sy) = (x as f32 + s.offset.x, y as f32 + s.offset.y);
                let (gx, gy) = most_similar_in_grid(
                    s.hit.normal.to_array(),
                    s.hit.depth,
                    sx,
                    sy,
                    normal,
                    depth,
                );
                let g = gy * w + gx;
                misses[0] += surface_miss(&frame, &s.hit, g, sx, sy) as u32 as f32;
                misses[1] += surface_miss(&frame, &s.hit, y * w + x, sx, sy) as u32 as f32;
                let illum = if demod.passthrough[g] {
                    Vec3::ZERO
                } else {
                    Vec3::from(filtered.rgb(gx, gy))
                };
                sum += s.direct + s.hit.albedo * illum;
            }
            (sum / settings.spp as f32, misses)
        });
        let data = composed.iter().flat_map(|v| v.0.to_array()).collect();
        let misses = composed.iter().flat_map(|v| v.1).collect();
        // A third, empty channel so the plane is an RGB image every output format takes.
        lookup_misses = Some(Image::from_vec(w, h, 2, misses).to_channels(3));
        Image::from_vec(w, h, 3, data)
    };
    // The traced frame's direct plane holds all samples' direct light.
    for (i, p) in pixels.iter().enumerate() {
        let sum = p.extra.iter().fold(p.guide.direct, |acc, s| acc + s.direct);
        let d = sum / settings.spp.max(1) as f32;
        frame.direct.data[i * 3..i * 3 + 3].copy_from_slice(&d.to_array());
        let c = d + p.guide.indirect;
        frame.color.data[i * 3..i * 3 + 3].copy_from_slice(&c.to_array());
    }
    let compose = t.elapsed();
    let mut planes = vec![
        ("indirect_raw", frame.indirect.clone()),
        ("illumination_raw", demod.illumination.clone()),
        ("illumination_filtered", filtered),
    ];
    if let Some(m) = lookup_misses {
        planes.push(("lookup_misses", m));
    }
    Ok(PipelineOutput {
        image,
        planes,
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

/// True when guide pixel `g` lies on another surface than the sample `hit` although one of
/// the four guide pixels around the sample position (`sx`, `sy`) lies on the same one: the
/// lookup failures the geometry-aware lookup exists to avoid. "Same surface" means: normals
/// within ~25° and the guide point within 1 % of the sample's depth of the sample's tangent
/// plane; two misses are the same (background). Counted per pixel in the `lookup_misses`
/// plane (channel 0: the lookup used; channel 1: the sample's own pixel, for comparison;
/// channel 2: 0).
fn surface_miss(frame: &Frame, hit: &FirstHit, g: usize, sx: f32, sy: f32) -> bool {
    let same = |i: usize| {
        let d = frame.depth.data[i];
        if !hit.depth.is_finite() || !d.is_finite() {
            return !hit.depth.is_finite() && !d.is_finite();
        }
        let n = Vec3::from_slice(&frame.normal.data[i * 3..i * 3 + 3]);
        let p = Vec3::from_slice(&frame.position.data[i * 3..i * 3 + 3]);
        n.dot(hit.normal) > 0.9 && hit.normal.dot(p - hit.position).abs() <= 0.01 * hit.depth
    };
    if same(g) {
        return false;
    }
    neighbour_cells(sx, sy, frame.depth.width, frame.depth.height)
        .iter()
        .any(|&(x, y)| same(y * frame.depth.width + x))
}

fn extra_rays(pixels: &[GuidedPixel]) -> u64 {
    pixels
        .iter()
        .flat_map(|p| &p.extra)
        .map(|s| s.rays as u64)
        .sum()
}
