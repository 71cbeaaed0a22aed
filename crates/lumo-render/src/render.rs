//! Renders whole images: runs the integrator for every pixel and sample, rows in parallel.
//! This is the only place in the crate that knows about threads.

use std::sync::atomic::{AtomicU64, Ordering};

use glam::{Vec2, Vec3};
use lumo_image::{luminance, Image};
use rayon::prelude::*;

use crate::camera::CameraRays;
use crate::frame::Frame;
use crate::integrator::{trace_path, FirstHit, PathSettings};
use crate::render_scene::RenderScene;
use crate::sampler::PixelSampler;

/// What to render.
#[derive(Clone, Copy, Debug)]
pub struct RenderSettings {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// Samples per pixel (the first goes through the pixel centre).
    pub spp: u32,
    /// Seed; the image is a pure function of (scene, settings, seed).
    pub seed: u32,
    /// Integrator parameters.
    pub path: PathSettings,
}

/// Work counters of a render.
#[derive(Clone, Copy, Debug, Default)]
pub struct RenderStats {
    /// Camera samples traced.
    pub samples: u64,
    /// Rays traced (closest-hit and shadow).
    pub rays: u64,
}

/// One pixel's estimates.
#[derive(Clone, Copy, Debug, Default)]
pub struct PixelEstimate {
    /// Mean direct radiance.
    pub direct: Vec3,
    /// Mean indirect radiance.
    pub indirect: Vec3,
    /// Sample variance of luminance (Welford); 0 with one sample.
    pub luminance_variance: f32,
    /// The pixel-centre ray's first hit.
    pub first_hit: FirstHit,
    /// Rays traced.
    pub rays: u64,
}

/// Renders samples `0..spp` of pixel (x, y): a pure function of its arguments.
pub fn render_pixel(
    rs: &RenderScene,
    camera: &CameraRays,
    settings: &RenderSettings,
    x: usize,
    y: usize,
) -> PixelEstimate {
    let mut est = PixelEstimate::default();
    let (mut sum_d, mut sum_i) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
    let (mut mean, mut m2) = (0.0f64, 0.0f64);
    for i in 0..settings.spp {
        let mut sampler = PixelSampler::new(x as u32, y as u32, i, settings.seed);
        let jitter = sampler.next_2d();
        // Sample 0 is the guide ray through the pixel centre (guided-filter paper §3.2).
        let offset = if i == 0 { Vec2::splat(0.5) } else { jitter };
        let dir = camera.direction(Vec2::new(x as f32, y as f32) + offset);
        let first = if i == 0 {
            Some(&mut est.first_hit)
        } else {
            None
        };
        let r = trace_path(
            rs,
            camera.origin(),
            dir,
            &mut sampler,
            &settings.path,
            first,
        );
        est.rays += r.rays as u64;
        sum_d += r.direct.as_dvec3();
        sum_i += r.indirect.as_dvec3();
        let l = luminance((r.direct + r.indirect).into()) as f64;
        let delta = l - mean;
        mean += delta / (i + 1) as f64;
        m2 += delta * (l - mean);
    }
    let n = settings.spp.max(1) as f64;
    est.direct = (sum_d / n).as_vec3();
    est.indirect = (sum_i / n).as_vec3();
    est.luminance_variance = if settings.spp > 1 {
        (m2 / (n - 1.0)) as f32
    } else {
        0.0
    };
    est
}

/// Renders the full frame. `progress` is called with the number of rows finished so far.
pub fn render(
    rs: &RenderScene,
    settings: &RenderSettings,
    progress: &(dyn Fn(usize) + Sync),
) -> (Frame, RenderStats) {
    let (w, h) = (settings.width, settings.height);
    let camera = CameraRays::new(&rs.scene.camera, w, h);
    let done = AtomicU64::new(0);
    let rows: Vec<Vec<PixelEstimate>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let row = (0..w)
                .map(|x| render_pixel(rs, &camera, settings, x, y))
                .collect();
            let finished = done.fetch_add(1, Ordering::Relaxed) + 1;
            progress(finished as usize);
            row
        })
        .collect();
    let mut stats = RenderStats {
        samples: (w * h) as u64 * settings.spp as u64,
        rays: 0,
    };
    let mut frame = Frame {
        spp: settings.spp,
        color: Image::new(w, h, 3, 0.0),
        direct: Image::new(w, h, 3, 0.0),
        indirect: Image::new(w, h, 3, 0.0),
        albedo: Image::new(w, h, 3, 0.0),
        normal: Image::new(w, h, 3, 0.0),
        position: Image::new(w, h, 3, 0.0),
        depth: Image::new(w, h, 1, 0.0),
        variance: Image::new(w, h, 1, 0.0),
    };
    for (y, row) in rows.iter().enumerate() {
        for (x, e) in row.iter().enumerate() {
            stats.rays += e.rays;
            let put = |img: &mut Image, v: Vec3| img.pixel_mut(x, y).copy_from_slice(&v.to_array());
            put(&mut frame.direct, e.direct);
            put(&mut frame.indirect, e.indirect);
            put(&mut frame.color, e.direct + e.indirect);
            put(&mut frame.albedo, e.first_hit.albedo);
            put(&mut frame.normal, e.first_hit.normal);
            put(&mut frame.position, e.first_hit.position);
            frame.depth.pixel_mut(x, y)[0] = e.first_hit.depth;
            frame.variance.pixel_mut(x, y)[0] = e.luminance_variance / settings.spp.max(1) as f32;
        }
    }
    if settings.spp == 1 {
        frame.variance = neighbourhood_variance(&frame.color);
    }
    (frame, stats)
}

/// Luminance variance over each pixel's 3×3 neighbourhood: a one-sample stand-in for the
/// per-pixel variance (as SVGF does before it has temporal history).
fn neighbourhood_variance(color: &Image) -> Image {
    let (w, h) = (color.width, color.height);
    let lum: Vec<f32> = (0..w * h)
        .map(|i| luminance(color.rgb(i % w, i / w)))
        .collect();
    let mut out = Image::new(w, h, 1, 0.0);
    for y in 0..h {
        for x in 0..w {
            let (mut s, mut s2, mut n) = (0.0f32, 0.0f32, 0.0f32);
            for yy in y.saturating_sub(1)..(y + 2).min(h) {
                for xx in x.saturating_sub(1)..(x + 2).min(w) {
                    let l = lum[yy * w + xx];
                    s += l;
                    s2 += l * l;
                    n += 1.0;
                }
            }
            let m = s / n;
            out.data[y * w + x] = (s2 / n - m * m).max(0.0);
        }
    }
    out
}
