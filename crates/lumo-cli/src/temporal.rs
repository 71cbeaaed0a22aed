//! `lumo render --frames … --temporal`: each traced frame goes through lumo-filter's temporal
//! filter (SVGF) instead of a per-frame pipeline, its history reprojected with the motion of
//! the camera and of the scene's instances.
//!
//! Motion vectors: a pixel's first-hit point (the frame's position plane, traced through the
//! pixel centre) is carried back to where it was on the previous frame — through the inverse of
//! its instance's transform now and that transform then, when instances move — and projected
//! with the previous camera. The instance under each pixel centre is found by one ray per
//! pixel, only when the scene animates (a camera orbit needs none); the same ids also reject
//! history that belonged to another object.

use std::time::{Duration, Instant};

use glam::Mat4;
use lumo_filter::{
    object_motion, object_motion_vectors, pinhole_view_projection, with_emitted, FilterError,
    Resample, TemporalAntialias, TemporalFilter, TemporalFrame, TemporalParams,
};
use lumo_image::Image;
use lumo_render::camera::PinholeCamera;
use lumo_render::{instance_ids, Frame, PathSettings, RenderScene};
use lumo_scene::Camera;

use crate::reshade::{reshade, Pose, ShadedFrame};

/// What the previous frame looked like, for its motion vectors.
struct View {
    view_proj: Mat4,
    /// The frame's sub-pixel jitter (pixels).
    jitter: [f32; 2],
    /// Instance transforms (object → world).
    transforms: Vec<Mat4>,
    /// The instance under each pixel centre, when instances move.
    ids: Option<Vec<u32>>,
    /// The traced frame, for re-shading (when on).
    shaded: Option<ShadedFrame>,
}

/// Time spent on one frame's temporal filtering.
#[derive(Clone, Copy, Debug, Default)]
pub struct TemporalTimes {
    /// Instance ids and motion vectors.
    pub motion: Duration,
    /// Re-shading one point per 3×3 block of the previous frame (history rejection).
    pub reshade: Duration,
    /// The filter itself (reprojection, accumulation, variance, À-Trous).
    pub filter: Duration,
}

/// The temporal filter of one sequence with its memory of the previous frame.
pub struct TemporalSequence {
    filter: TemporalFilter,
    /// Temporal anti-aliasing of the filtered image (with the lights), when on.
    taa: Option<TemporalAntialias>,
    prev: Option<View>,
    /// Jitter the camera by a sub-pixel offset every frame (see [`jitter`]).
    jitter: bool,
    /// Instances move (an animated scene): trace ids and follow each instance's motion.
    object_motion: bool,
    /// The path settings frames are traced with, when the history rejection re-shades
    /// samples of the previous frame (`crate::reshade`); `None`: the windowed test.
    reshade: Option<PathSettings>,
}

impl TemporalSequence {
    /// A sequence with SVGF's parameters; `object_motion` when the scene's instances move.
    /// With `reshade` (the path settings of frames traced at one sample per pixel) the history
    /// rejection re-traces a few of the previous frame's samples (A-SVGF), unless the tuning
    /// hook turns that off (`rs=0`); without, it uses the windowed statistical test.
    pub fn new(object_motion: bool, reshade: Option<PathSettings>) -> Result<Self, FilterError> {
        let (params, taa) = sequence_params();
        Ok(Self {
            filter: TemporalFilter::new(params)?,
            taa: match taa {
                Some((alpha, gamma)) => Some(TemporalAntialias::new(alpha, gamma)?),
                None => None,
            },
            prev: None,
            jitter: tuned("jit").is_some_and(|v| v != 0.0),
            object_motion,
            reshade: reshade.filter(|_| tuned("rs") != Some(0.0)),
        })
    }

    /// The camera to trace frame number `i` of the sequence (counting from 0) with, and its
    /// jitter: `camera` turned by [`jitter`]`(i)` when jittering is on (as a real-time renderer
    /// jitters its projection for temporal anti-aliasing), else `camera` and no jitter.
    pub fn camera(&self, camera: &Camera, w: usize, h: usize, i: usize) -> (Camera, [f32; 2]) {
        if !self.jitter {
            return (camera.clone(), [0.0; 2]);
        }
        let j = jitter(i);
        (jittered_camera(camera, w, h, j), j)
    }

    /// Filters `frame`, traced from `rs` as it is posed now with a camera jittered by `jitter`
    /// pixels (see [`Self::camera`]) and random-number seed `seed`, one sample per pixel;
    /// returns the filtered image, which the TAA stage puts back on the unjittered pixel grid.
    pub fn filter(
        &mut self,
        rs: &RenderScene,
        frame: &Frame,
        jitter: [f32; 2],
        seed: u32,
    ) -> Result<(Image, TemporalTimes), FilterError> {
        let (w, h) = (frame.width(), frame.height());
        let start = Instant::now();
        let c = &rs.scene.camera;
        let (hw, hh) = c.half_extent(w, h);
        let mut view = View {
            view_proj: pinhole_view_projection(c.origin, c.target, c.up, [hw, hh]),
            jitter,
            transforms: rs.scene.instances.iter().map(|i| i.transform).collect(),
            ids: self
                .object_motion
                .then(|| instance_ids(rs, &PinholeCamera::new(c, w, h), w, h)),
            shaded: None,
        };
        let ids = view.ids.as_deref();
        let motion = self.prev.as_ref().map(|prev| {
            let back = object_motion(&prev.transforms, &view.transforms);
            let ids = ids.unwrap_or_default();
            object_motion_vectors(
                &prev.view_proj,
                &view.view_proj,
                &frame.position,
                ids,
                &back,
            )
        });
        let motion_time = start.elapsed();
        let t = Instant::now();
        let changes = match (&self.reshade, &self.prev) {
            (Some(path), Some(prev)) => prev.shaded.as_ref().map(|before| {
                let camera = PinholeCamera::new(c, w, h);
                let then = Pose {
                    view_proj: prev.view_proj,
                    transforms: &prev.transforms,
                    ids: prev.ids.as_deref(),
                };
                let now = Pose {
                    view_proj: view.view_proj,
                    transforms: &view.transforms,
                    ids,
                };
                reshade(rs, &camera, path, before, &then, &now)
            }),
            _ => None,
        };
        let reshade_time = t.elapsed();
        // Emitters seen directly pass through unfiltered, as in every pipeline.
        let emitter: Vec<bool> = frame
            .emission
            .data
            .chunks_exact(3)
            .zip(frame.albedo.data.chunks_exact(3))
            .map(|(e, a)| e.iter().any(|&v| v != 0.0) && a.iter().any(|&v| v != 0.0))
            .collect();
        let t = Instant::now();
        // With several samples per frame a light's rim pixels hold a share of it: kept out too.
        let filtered = with_emitted(&frame.color, &emitter, &frame.emitted, |c| {
            self.filter.filter_reshaded(
                &TemporalFrame {
                    color: c,
                    albedo: Some(&frame.albedo),
                    normal: &frame.normal,
                    depth: &frame.depth,
                    position: Some(&frame.position),
                    ids,
                    motion: motion.as_ref(),
                },
                changes.as_deref(),
            )
        })?;
        // The TAA history lives on the unjittered grid. A jittered pixel x shows the unjittered
        // image at x + j, so the surface at unjittered x was at jittered x − j + motion in the
        // previous frame, which is unjittered x + motion + j_prev − j.
        let image = match &mut self.taa {
            Some(taa) => {
                let unjittered = match (&motion, &self.prev) {
                    (Some(m), Some(prev)) => {
                        let mut m = m.clone();
                        let d = [prev.jitter[0] - jitter[0], prev.jitter[1] - jitter[1]];
                        for v in m.data.chunks_exact_mut(2) {
                            v[0] += d[0];
                            v[1] += d[1];
                        }
                        Some(m)
                    }
                    _ => None,
                };
                taa.apply(&filtered.image, unjittered.as_ref())?
            }
            None => filtered.image,
        };
        let times = TemporalTimes {
            motion: motion_time,
            reshade: reshade_time,
            filter: t.elapsed(),
        };
        if self.reshade.is_some() {
            view.shaded = Some(ShadedFrame::new(frame, seed));
        }
        self.prev = Some(view);
        Ok((image, times))
    }
}

/// The sequence's parameters, tuned on a 24-frame 20° Cornell orbit at 128² (references at
/// 512 spp) and a 24-frame, 96×64 run of `scenes/animated.gltf` (seed 7), never on the reported
/// sequences (docs/results/temporal.md). Round 1: α = 0.1 and a 2-level À-Trous (SVGF: 0.2
/// and 5), the accumulated rather than the filtered colour as history (SVGF's feedback of the first
/// À-Trous level compounds its blur: 0.70 → 0.59 of per-frame À-Trous on the Cornell orbit),
/// and history rejection where the lighting changes (2 standard errors, gain 10: the animated
/// scene went from 2.3× to 0.97× per-frame À-Trous). A second round (also on a 64-frame, 16°
/// cornell-spheres orbit at 96², references 256 spp) added the variance of the accumulated
/// colour rather than of one sample to steer the À-Trous (0.71 → 0.66 on that orbit), a longer
/// history (α = 0.05, up to 128 frames) and a rejection radius of 6 (Cornell 0.61 → 0.59,
/// spheres 0.65, animated 0.97 → 0.96). A third round re-shades one sample per 3×3 block of the
/// previous frame with its own random numbers (A-SVGF's temporal gradients, `crate::reshade`)
/// and rejects history by that change (gain 3, radius 4) while scaling what is kept by it
/// (animated 0.96 → 0.78, Cornell 0.59 → 0.57, spheres 0.65 → 0.66). Camera jitter, TAA,
/// Catmull-Rom history reads, the neighbourhood clamp and the short-history levels are off:
/// measured, they did not lower FLIP (docs/results/temporal.md).
fn sequence_params() -> (TemporalParams, Option<(f32, f32)>) {
    let mut p = TemporalParams::sequence();
    let mut taa = None;
    tune(&mut p, &mut taa);
    (p, taa)
}

/// The sub-pixel jitter of frame `i`: the Halton (2, 3) point i + 1, less 0.5, in pixels
/// (x right, y down), repeating every 16 frames.
pub fn jitter(i: usize) -> [f32; 2] {
    let k = (i % 16) as u32 + 1;
    [halton(k, 2) - 0.5, halton(k, 3) - 0.5]
}

fn halton(mut i: u32, base: u32) -> f32 {
    let (mut f, mut r) = (1.0f32, 0.0f32);
    while i > 0 {
        f /= base as f32;
        r += f * (i % base) as f32;
        i /= base;
    }
    r
}

/// `camera` turned so that the centre of its pixel x sees what the centre of `camera`'s pixel
/// x + `j` sees (exactly at the image centre; about a tenth of a pixel off near the corners at a
/// 40° field of view): the target moves along the image plane, the eye stays.
pub fn jittered_camera(camera: &Camera, w: usize, h: usize, j: [f32; 2]) -> Camera {
    let (right, up, _) = camera.basis();
    let (hw, hh) = camera.half_extent(w, h);
    let dist = (camera.target - camera.origin).length();
    let shift = right * (j[0] * 2.0 * hw / w as f32) - up * (j[1] * 2.0 * hh / h as f32);
    Camera {
        target: camera.target + shift * dist,
        ..camera.clone()
    }
}

/// A tuning value of `LUMO_TEMPORAL_TUNE` (see [`tune`]).
pub fn tuned(key: &str) -> Option<f32> {
    let spec = std::env::var("LUMO_TEMPORAL_TUNE").ok()?;
    spec.split(',').find_map(|kv| {
        let (k, v) = kv.split_once('=')?;
        (k.trim() == key).then(|| v.trim().parse().ok()).flatten()
    })
}

/// Tuning aid (undocumented in `--help`): `LUMO_TEMPORAL_TUNE="alpha=0.1,levels=2,…"`
/// overrides the parameters for parameter sweeps without a rebuild. Keys: alpha (colour and
/// moments), levels, sigma_l, gr / gk / gg (gradient radius, sigmas, gain), rg (re-shaded rejection gain), rr (1: rescale the history by the re-shaded change), rr_radius (its window radius), rs (0: no re-shading), fh (1: filtered
/// history), cr (1: Catmull-Rom history reads), clamp (neighbourhood clamp, σ), sl / sn
/// (short-history À-Trous levels and frames), mh (max history), vs (1: variance of
/// the accumulated colour), taa / taag (TAA blend weight, 0 = off, and clip
/// width), jit (1: camera jitter), jm (1: with jitter, motion on the unjittered grid).
/// Values that do not parse are ignored; the filter still checks ranges.
fn tune(p: &mut TemporalParams, taa: &mut Option<(f32, f32)>) {
    let Ok(spec) = std::env::var("LUMO_TEMPORAL_TUNE") else {
        return;
    };
    for kv in spec.split(',') {
        let Some((k, v)) = kv.split_once('=') else {
            continue;
        };
        let Ok(v) = v.trim().parse::<f32>() else {
            continue;
        };
        match k.trim() {
            "alpha" => {
                p.alpha = v;
                p.alpha_moments = v;
            }
            "levels" => p.atrous.iterations = v as usize,
            "sigma_l" => p.atrous.sigma_luminance = Some(v),
            "gr" => p.gradient_radius = v as usize,
            "gk" => p.gradient_sigmas = v,
            "gg" => p.gradient_gain = v,
            "rg" => p.reshade_gain = v,
            "rr" => p.reshade_rescale = v != 0.0,
            "rr_radius" => p.reshade_radius = v as usize,
            "fh" => p.filtered_history = v != 0.0,
            "cr" => {
                p.resample = if v != 0.0 {
                    Resample::CatmullRom
                } else {
                    Resample::Bilinear
                }
            }
            "clamp" => p.clamp_sigmas = v,
            "mh" => p.max_history = v as u32,
            "vs" => p.scale_variance = v != 0.0,
            "sl" => p.short_history_levels = v as usize,
            "sn" => p.short_history_frames = v as u32,
            "taa" if v > 0.0 => {
                *taa = Some((v, taa.map_or(lumo_filter::DEFAULT_TAA_GAMMA, |t| t.1)))
            }
            "taa" => *taa = None,
            "taag" => *taa = Some((taa.map_or(lumo_filter::DEFAULT_TAA_ALPHA, |t| t.0), v)),
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec2, Vec3};

    /// The jittered camera's pixel centre x looks where the nominal camera's x + j looks (at
    /// the image centre exactly; about a tenth of a pixel off near the corners at 40°), and the
    /// jitter sequence covers the pixel.
    #[test]
    fn jittered_camera_shifts_the_pixel_grid() {
        let nominal = Camera {
            origin: Vec3::new(0.0, 1.0, 4.0),
            target: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            fov: 40.0,
            fov_axis: lumo_scene::FovAxis::Y,
        };
        let (w, h) = (128, 96);
        let j = [0.3, -0.4];
        let a = PinholeCamera::new(&jittered_camera(&nominal, w, h, j), w, h);
        let b = PinholeCamera::new(&nominal, w, h);
        for (x, y) in [(64.0, 48.0), (10.5, 80.5)] {
            let d = a.direction(Vec2::new(x, y));
            let p = b.project(d).unwrap();
            assert!((p.x - (x + j[0])).abs() < 0.15, "{x}: {p}");
            assert!((p.y - (y + j[1])).abs() < 0.15, "{y}: {p}");
        }
        let js: Vec<[f32; 2]> = (0..16).map(jitter).collect();
        assert!(js.iter().all(|j| j.iter().all(|v| v.abs() < 0.5)));
        let mean = js.iter().fold(0.0, |s, j| s + j[0]) / 16.0;
        assert!(mean.abs() < 0.05, "{mean}");
        assert_eq!(jitter(3), jitter(19));
    }
}
