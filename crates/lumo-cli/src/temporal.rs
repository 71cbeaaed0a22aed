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

use glam::{Mat4, Vec2, Vec3};
use lumo_filter::{
    pinhole_view_projection, project_to_pixel, with_passthrough, FilterError, TemporalAntialias,
    TemporalFilter, TemporalFrame, TemporalParams,
};
use lumo_image::Image;
use lumo_render::camera::PinholeCamera;
use lumo_render::{Frame, RenderScene};
use rayon::prelude::*;

/// Id of pixels whose centre ray hits nothing.
const NO_INSTANCE: u32 = u32::MAX;

/// What the previous frame looked like, for its motion vectors.
struct View {
    view_proj: Mat4,
    /// Instance transforms (object → world).
    transforms: Vec<Mat4>,
}

/// Time spent on one frame's temporal filtering.
#[derive(Clone, Copy, Debug, Default)]
pub struct TemporalTimes {
    /// Instance ids and motion vectors.
    pub motion: Duration,
    /// The filter itself (reprojection, accumulation, variance, À-Trous).
    pub filter: Duration,
}

/// The temporal filter of one sequence with its memory of the previous frame.
pub struct TemporalSequence {
    filter: TemporalFilter,
    /// Temporal anti-aliasing of the filtered image (with the lights), when on.
    taa: Option<TemporalAntialias>,
    prev: Option<View>,
    /// Instances move (an animated scene): trace ids and follow each instance's motion.
    object_motion: bool,
}

impl TemporalSequence {
    /// A sequence with SVGF's parameters; `object_motion` when the scene's instances move.
    pub fn new(object_motion: bool) -> Result<Self, FilterError> {
        let (params, taa) = sequence_params();
        Ok(Self {
            filter: TemporalFilter::new(params)?,
            taa: match taa {
                Some((alpha, gamma)) => Some(TemporalAntialias::new(alpha, gamma)?),
                None => None,
            },
            prev: None,
            object_motion,
        })
    }

    /// Filters `frame`, traced from `rs` as it is posed now; returns the filtered image.
    pub fn filter(
        &mut self,
        rs: &RenderScene,
        frame: &Frame,
    ) -> Result<(Image, TemporalTimes), FilterError> {
        let (w, h) = (frame.width(), frame.height());
        let start = Instant::now();
        let c = &rs.scene.camera;
        let (hw, hh) = c.half_extent(w, h);
        let view = View {
            view_proj: pinhole_view_projection(c.origin, c.target, c.up, [hw, hh]),
            transforms: rs.scene.instances.iter().map(|i| i.transform).collect(),
        };
        let ids = self.object_motion.then(|| instance_ids(rs, w, h));
        let motion = self
            .prev
            .as_ref()
            .map(|prev| motion_vectors(prev, &view, &frame.position, ids.as_deref()));
        let motion_time = start.elapsed();
        // Emitters seen directly pass through unfiltered, as in every pipeline.
        let emitter: Vec<bool> = frame
            .emission
            .data
            .chunks_exact(3)
            .zip(frame.albedo.data.chunks_exact(3))
            .map(|(e, a)| e.iter().any(|&v| v != 0.0) && a.iter().any(|&v| v != 0.0))
            .collect();
        let t = Instant::now();
        let filtered = with_passthrough(&frame.color, &emitter, |c| {
            self.filter.filter(&TemporalFrame {
                color: c,
                albedo: Some(&frame.albedo),
                normal: &frame.normal,
                depth: &frame.depth,
                position: Some(&frame.position),
                ids: ids.as_deref(),
                motion: motion.as_ref(),
            })
        })?;
        let image = match &mut self.taa {
            Some(taa) => taa.apply(&filtered.image, motion.as_ref())?,
            None => filtered.image,
        };
        let times = TemporalTimes {
            motion: motion_time,
            filter: t.elapsed(),
        };
        self.prev = Some(view);
        Ok((image, times))
    }
}

/// SVGF's parameters with a longer history (α = 0.1) and a 2-level À-Trous instead of 5: on
/// the 24-frame Cornell orbit at 128² and 1 spp (references at 512 spp) the mean FLIP after
/// frame 8 fell from 0.78 to 0.70 of per-frame À-Trous and the flicker from 0.41 to 0.39
/// (docs/results/temporal.md): accumulated colour needs less spatial blur, and each level's
/// blur otherwise stays in the image.
fn sequence_params() -> (TemporalParams, Option<(f32, f32)>) {
    let mut p = TemporalParams {
        alpha: 0.1,
        alpha_moments: 0.1,
        ..TemporalParams::default()
    };
    p.atrous.iterations = 2;
    let mut taa = None;
    tune(&mut p, &mut taa);
    (p, taa)
}

/// Tuning aid (undocumented in `--help`): `LUMO_TEMPORAL_TUNE="alpha=0.1,levels=2,…"`
/// overrides the parameters for parameter sweeps without a rebuild. Keys: alpha (colour and
/// moments), levels, sigma_l, gr / gk / gg (gradient radius, sigmas, gain). Values that do not
/// parse are ignored; the filter still checks ranges.
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
            "taa" if v > 0.0 => {
                *taa = Some((v, taa.map_or(lumo_filter::DEFAULT_TAA_GAMMA, |t| t.1)))
            }
            "taa" => *taa = None,
            "taag" => *taa = Some((taa.map_or(lumo_filter::DEFAULT_TAA_ALPHA, |t| t.0), v)),
            _ => {}
        }
    }
}

/// The instance each pixel centre's camera ray hits first ([`NO_INSTANCE`] on a miss): the
/// ray of the frame's G-buffer.
fn instance_ids(rs: &RenderScene, w: usize, h: usize) -> Vec<u32> {
    let cam = PinholeCamera::new(&rs.scene.camera, w, h);
    let origin = cam.origin();
    let mut ids = vec![NO_INSTANCE; w * h];
    ids.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, id) in row.iter_mut().enumerate() {
            let dir = cam.direction(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            if let Some(hit) = rs.accel.intersect(origin, dir, 0.0, f32::INFINITY) {
                *id = hit.instance;
            }
        }
    });
    ids
}

/// Motion vectors (2 channels, pixels, previous position = pixel + motion; NaN = no
/// history) of the current frame's first-hit `position`s: each point is moved back with its
/// instance (when `ids` are given) and projected with the previous camera.
fn motion_vectors(prev: &View, cur: &View, position: &Image, ids: Option<&[u32]>) -> Image {
    let (w, h) = (position.width, position.height);
    let mut out = Image::new(w, h, 2, f32::NAN);
    // Per instance: current world → previous world (identity where nothing moved or the
    // instance list changed).
    let back: Vec<Mat4> = if prev.transforms.len() == cur.transforms.len() {
        prev.transforms
            .iter()
            .zip(&cur.transforms)
            .map(|(p, c)| *p * c.inverse())
            .collect()
    } else {
        vec![Mat4::IDENTITY; cur.transforms.len()]
    };
    let pc = position.channels;
    out.data
        .par_chunks_mut(2 * w)
        .enumerate()
        .for_each(|(y, row)| {
            for x in 0..w {
                let q = &position.data[(y * w + x) * pc..][..3];
                let p = Vec3::new(q[0], q[1], q[2]);
                if !p.is_finite() {
                    continue;
                }
                let then = match ids.and_then(|ids| back.get(ids[y * w + x] as usize)) {
                    Some(m) => m.transform_point3(p),
                    None => p,
                };
                let (Some(a), Some(b)) = (
                    project_to_pixel(&prev.view_proj, then, w, h),
                    project_to_pixel(&cur.view_proj, p, w, h),
                ) else {
                    continue;
                };
                row[2 * x] = a[0] - b[0];
                row[2 * x + 1] = a[1] - b[1];
            }
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point on an instance that moved right by one unit comes from one unit left: its
    /// motion vector points there, while a static point under the same camera has none.
    #[test]
    fn object_motion_follows_the_instance() {
        let (w, h) = (64, 64);
        let vp = pinhole_view_projection(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, [0.5, 0.5]);
        let moved = Mat4::from_translation(Vec3::X);
        let prev = View {
            view_proj: vp,
            transforms: vec![Mat4::IDENTITY, Mat4::IDENTITY],
        };
        let cur = View {
            view_proj: vp,
            transforms: vec![Mat4::IDENTITY, moved],
        };
        let mut position = Image::new(w, h, 3, f32::NAN);
        let centre = 32 * w + 32;
        position.data[centre * 3..centre * 3 + 3].copy_from_slice(&[0.5, 0.0, 0.0]);
        position.data[(centre + 1) * 3..(centre + 1) * 3 + 3].copy_from_slice(&[0.5, 0.0, 0.0]);
        let mut ids = vec![NO_INSTANCE; w * h];
        ids[centre] = 1;
        ids[centre + 1] = 0;
        let m = motion_vectors(&prev, &cur, &position, Some(&ids));
        // One unit at distance 5 with a half extent of 0.5 is 64 / 2 / 0.5 / 5 = 12.8 pixels.
        assert!(
            (m.data[centre * 2] + 12.8).abs() < 1e-3,
            "{}",
            m.data[centre * 2]
        );
        assert!(m.data[centre * 2 + 1].abs() < 1e-4);
        assert_eq!(
            m.data[(centre + 1) * 2],
            0.0,
            "a static point does not move"
        );
        assert!(m.data[0].is_nan(), "background keeps no history");
    }
}
