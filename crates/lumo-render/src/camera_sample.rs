//! A camera sample: the sampler, film offset and ray of sample `index` of a pixel, shared by
//! the path tracer's loops, the wavefront renderer and the photon mapper's camera passes.

use glam::{Vec2, Vec3};

use crate::camera::PinholeCamera;
use crate::sampler::PixelSampler;

/// Camera sample `index` of pixel (x, y): its sampler (past the jitter and lens point it
/// drew), its offset from the pixel's corner and its ray (origin, direction). Sample 0 goes
/// through the pixel centre (the guided-filter paper's guide ray, §3.2), the others through a
/// point placed by the camera's pixel filter (inside the pixel for the box filter; a tent or
/// Gaussian reaches into the neighbours).
#[inline]
pub(crate) fn camera_sample(
    camera: &PinholeCamera,
    (x, y): (usize, usize),
    index: u32,
    seed: u32,
) -> (PixelSampler, Vec2, Vec3, Vec3) {
    let sampler = PixelSampler::new(x as u32, y as u32, index, seed);
    camera_sample_with(camera, (x, y), index, sampler)
}

/// [`camera_sample`] for a sampler already made (by [`PixelSampler::run`]).
#[inline]
pub(crate) fn camera_sample_with(
    camera: &PinholeCamera,
    (x, y): (usize, usize),
    index: u32,
    mut sampler: PixelSampler,
) -> (PixelSampler, Vec2, Vec3, Vec3) {
    let jitter = sampler.next_2d();
    let offset = if index == 0 {
        Vec2::splat(0.5)
    } else {
        camera.filter_offset((x, y), jitter)
    };
    // Only a thin lens draws a lens point: pinhole images keep their sample dimensions.
    let lens = if camera.needs_lens_sample() {
        sampler.next_2d()
    } else {
        Vec2::splat(0.5)
    };
    let (origin, dir) = camera.ray(Vec2::new(x as f32, y as f32) + offset, lens);
    (sampler, offset, origin, dir)
}
