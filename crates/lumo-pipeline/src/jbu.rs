//! The joint-bilateral-upsampling pipeline (papers/README §3): the G-buffer and direct light at
//! full resolution; indirect light only at one pixel per k×k block, with many paths each;
//! outlier removal, optional bilateral pre-filter, joint bilateral upsampling steered by the
//! full-resolution depth and normals; `L = L_dir + albedo · E_ind`.
//!
//! The paper splits the low-resolution buffer into diffuse irradiance and specular radiance;
//! lumo demodulates by the G-buffer's albedo instead (diffuse reflectance, or the specular
//! albedo of specular materials), which is the same thing for diffuse surfaces and a
//! first-order approximation for glossy ones.

use std::time::Instant;

use glam::Vec3;
use lumo_filter::{Denoiser, Features, FilterInput, JbuDenoiser, JbuParams, ALBEDO_EPS};
use lumo_image::Image;

use super::compose::{direct_only, trace_full};
use super::{PipelineError, PipelineOptions, PipelineOutput, Timings};
use lumo_render::camera::PinholeCamera;
use lumo_render::{map_pixels, render_pixel};
use lumo_render::{RenderScene, RenderSettings};

/// Largest block side of the sparse indirect trace, in pixels (the paper uses 16).
pub const MAX_BLOCK: usize = 64;

pub(super) fn run(
    rs: &RenderScene,
    settings: &RenderSettings,
    options: &PipelineOptions,
    progress: &(dyn Fn(f32) + Sync),
) -> Result<PipelineOutput, PipelineError> {
    let k = options.block;
    if !(1..=MAX_BLOCK).contains(&k) {
        return Err(PipelineError::Option {
            option: "block",
            value: k.to_string(),
            fix: "use a block size from 1 to 64 pixels (the paper uses 16)",
        });
    }
    if options.paths == 0 {
        return Err(PipelineError::Option {
            option: "paths",
            value: "0".into(),
            fix: "trace at least one indirect path per block",
        });
    }
    let (w, h) = (settings.width, settings.height);
    // Pass 1: G-buffer and direct light for every pixel (half the progress bar).
    let half = |f: f32| progress(0.5 * f);
    let (_, mut frame, mut stats, gbuffer) = trace_full(rs, &direct_only(settings), &half, None);

    // Pass 2: indirect light at the centre pixel of every block.
    let t = Instant::now();
    let (lw, lh) = (w.div_ceil(k), h.div_ceil(k));
    let camera = PinholeCamera::new(&rs.scene.camera, w, h);
    let mut grid_settings = *settings;
    grid_settings.spp = options.paths;
    let rows = |done: usize| progress(0.5 + 0.5 * done as f32 / lh.max(1) as f32);
    let grid = map_pixels(lw, lh, &rows, |i, j| {
        let (x, y) = ((i * k + k / 2).min(w - 1), (j * k + k / 2).min(h - 1));
        let e = render_pixel(rs, &camera, &grid_settings, x, y);
        let a = e.first_hit.albedo;
        // Irradiance-like illumination: indirect radiance / albedo. Blocks whose sample point
        // has no albedo carry nothing to upsample and are marked missing.
        let illum = if a.max_element() < ALBEDO_EPS {
            Vec3::NAN
        } else {
            e.indirect / a.max(Vec3::splat(ALBEDO_EPS))
        };
        (illum, e.indirect, e.rays)
    });
    stats.samples += (lw * lh) as u64 * options.paths as u64;
    stats.rays += grid.iter().map(|g| g.2).sum::<u64>();
    let low = Image::from_vec(
        lw,
        lh,
        3,
        grid.iter().flat_map(|g| g.0.to_array()).collect(),
    );
    let low_radiance = Image::from_vec(
        lw,
        lh,
        3,
        grid.iter().flat_map(|g| g.1.to_array()).collect(),
    );
    let trace = t.elapsed();

    let t = Instant::now();
    let features = Features {
        normal: Some(&frame.normal),
        depth: Some(&frame.depth),
        ..Features::default()
    };
    let mut upsampler = JbuDenoiser {
        params: JbuParams {
            factor: k,
            prefilter: options.prefilter,
            ..JbuParams::default()
        },
    };
    let up = upsampler.denoise(&FilterInput::new(&low, features))?.image;
    let filter = t.elapsed();

    let t = Instant::now();
    let mut image = frame.direct.clone();
    for i in 0..w * h {
        for c in 0..3 {
            let v = frame.albedo.data[i * 3 + c] * up.data[i * 3 + c];
            if v.is_finite() {
                image.data[i * 3 + c] += v;
            }
        }
    }
    // The frame's indirect plane holds the upsampled indirect light the image used.
    for i in 0..w * h * 3 {
        let ind = image.data[i] - frame.direct.data[i];
        frame.indirect.data[i] = ind;
        frame.color.data[i] = image.data[i];
    }
    let compose = t.elapsed();
    Ok(PipelineOutput {
        image,
        planes: vec![
            ("low_illumination", low),
            ("low_indirect", low_radiance),
            ("illumination_upsampled", up),
        ],
        frame,
        timings: Timings {
            trace,
            gbuffer,
            filter,
            compose,
        },
        stats,
    })
}
