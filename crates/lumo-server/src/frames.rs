//! Filtered-frame mode: instead of sample streams the server renders whole 1-spp frames,
//! keeps their running mean, per-pixel luminance variance and the first frame's G-buffer, and
//! sends the mean filtered by a lumo-filter pipeline (À-Trous or the guided filter) after every
//! frame. The viewer shows these frames through the same tone mapping as the streams.

use glam::Vec3;
use lumo_filter::{AtrousDenoiser, AtrousParams, Denoiser, Features, FilterInput, GuidedDenoiser};
use lumo_image::{luminance, Image};
use lumo_render::integrators::path::wavefront::render_pixels;
use lumo_render::{camera::PinholeCamera, RenderScene, RenderSettings};
use rayon::prelude::*;

use crate::protocol::Mode;
use crate::streams::rgb_to_xyz;
use crate::worker::{FilteredFrame, Job};

/// Running statistics of the 1-spp frames of one render.
pub struct FrameAccumulator {
    width: usize,
    height: usize,
    rays: PinholeCamera,
    settings: RenderSettings,
    frames: u32,
    /// Sum of colours, 3 per pixel.
    sum: Vec<Vec3>,
    /// Welford mean and M2 of luminance per pixel.
    lum_mean: Vec<f32>,
    lum_m2: Vec<f32>,
    albedo: Image,
    normal: Image,
    position: Image,
    depth: Image,
    /// The À-Trous filter; it keeps its working memory from frame to frame.
    atrous: AtrousDenoiser,
    /// The guided filter (4-dimensional guide: normal and depth over its range).
    guided: GuidedDenoiser,
}

impl FrameAccumulator {
    /// An empty accumulator for `job`'s camera and size.
    pub fn new(job: &Job) -> Self {
        let (w, h) = (job.width, job.height);
        Self {
            width: w,
            height: h,
            rays: PinholeCamera::new(&job.camera, w, h),
            settings: RenderSettings {
                width: w,
                height: h,
                spp: 1,
                seed: job.seed,
                path: job.path,
            },
            frames: 0,
            sum: vec![Vec3::ZERO; w * h],
            lum_mean: vec![0.0; w * h],
            lum_m2: vec![0.0; w * h],
            albedo: Image::new(w, h, 3, 0.0),
            normal: Image::new(w, h, 3, 0.0),
            position: Image::new(w, h, 3, 0.0),
            depth: Image::new(w, h, 1, 0.0),
            atrous: AtrousDenoiser::new(AtrousParams::default()),
            guided: GuidedDenoiser::default(),
        }
    }

    /// Renders frame `index` (1 spp) row-parallel on the current pool and adds it. Returns the
    /// rays traced, or None if `abort` said stop (checked before every row).
    pub fn add_frame(
        &mut self,
        rs: &RenderScene,
        index: u32,
        abort: &(dyn Fn() -> bool + Sync),
    ) -> Option<u64> {
        let (w, h) = (self.width, self.height);
        let settings = RenderSettings {
            // A new seed per frame decorrelates the frames' noise.
            seed: self.settings.seed ^ index.wrapping_mul(0x9e37_79b9),
            ..self.settings
        };
        let rays = &self.rays;
        let rows: Option<Vec<Vec<_>>> = (0..h)
            .into_par_iter()
            .map(|y| {
                if abort() {
                    return None;
                }
                // A whole row through the wavefront renderer (fuller ray packets).
                Some(render_pixels(rs, rays, &settings, y, 0..w))
            })
            .collect();
        let rows = rows?;
        let first = self.frames == 0;
        self.frames += 1;
        let n = self.frames as f32;
        let mut traced = 0;
        for (y, row) in rows.iter().enumerate() {
            for (x, e) in row.iter().enumerate() {
                let i = y * w + x;
                let c = e.direct + e.indirect;
                traced += e.rays;
                self.sum[i] += c;
                let l = luminance(c.into());
                let d = l - self.lum_mean[i];
                self.lum_mean[i] += d / n;
                self.lum_m2[i] += d * (l - self.lum_mean[i]);
                if first {
                    let f = &e.first_hit;
                    self.albedo
                        .pixel_mut(x, y)
                        .copy_from_slice(&f.albedo.to_array());
                    self.normal
                        .pixel_mut(x, y)
                        .copy_from_slice(&f.normal.to_array());
                    self.position
                        .pixel_mut(x, y)
                        .copy_from_slice(&f.position.to_array());
                    self.depth.pixel_mut(x, y)[0] = f.depth;
                }
            }
        }
        Some(traced)
    }

    /// Frames added so far.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// The mean of the frames so far, filtered as `mode` says, converted to XYZ.
    pub fn filtered(&mut self, mode: Mode) -> Option<FilteredFrame> {
        if self.frames == 0 {
            return None;
        }
        let (w, h) = (self.width, self.height);
        let n = self.frames as f32;
        let mean: Vec<f32> = self.sum.iter().flat_map(|c| (*c / n).to_array()).collect();
        let color = Image::from_vec(w, h, 3, mean);
        // Variance of the mean; one frame has none, and the filters then rely on geometry.
        let variance = (self.frames > 1).then(|| {
            let v = self.lum_m2.iter().map(|m2| m2 / (n - 1.0) / n).collect();
            Image::from_vec(w, h, 1, v)
        });
        let features = Features {
            normal: Some(&self.normal),
            position: Some(&self.position),
            depth: Some(&self.depth),
            albedo: Some(&self.albedo),
            variance: variance.as_ref(),
        };
        let image = match mode {
            Mode::Progressive => color,
            Mode::Atrous => {
                let input = FilterInput::new(&color, features);
                self.atrous.denoise(&input).ok()?.image
            }
            Mode::Guided => {
                let input = FilterInput::new(&color, features);
                self.guided.denoise(&input).ok()?.image
            }
        };
        let xyz = image
            .data
            .chunks_exact(3)
            .flat_map(|p| rgb_to_xyz(Vec3::new(p[0], p[1], p[2])))
            .collect();
        Some(FilteredFrame {
            width: w,
            height: h,
            xyz,
            frames: self.frames,
            mode,
        })
    }
}
