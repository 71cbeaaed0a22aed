//! Motion vectors of a static scene seen by a moving pinhole camera: where each pixel's
//! surface point was on the previous frame's image.
//!
//! Conventions (those of lumo's camera, `lumo-render/src/camera.rs`): a view-projection matrix
//! maps world points to clip space with x right and y up, visible points having w > 0; a point
//! lands on pixel ((x/w + 1)/2 · width, (1 − y/w)/2 · height), x right and y down, pixel
//! (i, j) covering [i, i+1) × [j, j+1) (its centre at i + 0.5). Any OpenGL- or Vulkan-style
//! perspective × look-at product follows the x/y part of this (clip z is not used).

use glam::{Mat4, Vec3, Vec4};
use lumo_image::Image;
use rayon::prelude::*;

/// The view-projection matrix of lumo's pinhole camera: eye, target and up hint as in
/// `lumo_scene::Camera` (basis forward = target − eye, right = forward × up, up' = right ×
/// forward), and `half_extent` the image plane's half width and height at distance 1 (what
/// `Camera::half_extent(width, height)` returns). Clip z equals clip w (unused here).
pub fn pinhole_view_projection(eye: Vec3, target: Vec3, up: Vec3, half_extent: [f32; 2]) -> Mat4 {
    let forward = (target - eye).normalize();
    let right = forward.cross(up).normalize();
    let up = right.cross(forward);
    let row = |axis: Vec3, scale: f32| {
        let a = axis / scale;
        Vec4::new(a.x, a.y, a.z, -a.dot(eye))
    };
    let rx = row(right, half_extent[0]);
    let ry = row(up, half_extent[1]);
    let rw = row(forward, 1.0);
    // Rows in, so the matrix is their transpose's columns.
    Mat4::from_cols(rx, ry, rw, rw).transpose()
}

/// Pixel coordinates (x right, y down, continuous: pixel (i, j)'s centre is (i + 0.5, j + 0.5))
/// of world point `p` on a `width`×`height` image, or `None` when it is not in front of the
/// camera (clip w ≤ 0) or not finite.
pub fn project_to_pixel(
    view_proj: &Mat4,
    p: Vec3,
    width: usize,
    height: usize,
) -> Option<[f32; 2]> {
    let c = *view_proj * p.extend(1.0);
    if !(c.w > 0.0) {
        return None;
    }
    let (nx, ny) = (c.x / c.w, c.y / c.w);
    let px = [
        (nx + 1.0) * 0.5 * width as f32,
        (1.0 - ny) * 0.5 * height as f32,
    ];
    (px[0].is_finite() && px[1].is_finite()).then_some(px)
}

/// Motion vectors (2 channels: dx, dy in pixels) of a static scene: for each pixel, where
/// its surface point (`position`, the current frame's world-position plane, 3 or more
/// channels) lands under `prev_view_proj`, minus where it lands under `view_proj` — so the
/// previous position is pixel + motion, as [`super::TemporalFrame::motion`] expects. NaN
/// where the position is not finite (background) or behind either camera: such pixels keep
/// no history.
pub fn motion_vectors(prev_view_proj: &Mat4, view_proj: &Mat4, position: &Image) -> Image {
    moving_points(prev_view_proj, view_proj, position, None, None)
}

/// Id of a pixel that shows no object (its camera ray hit nothing), in the `ids` planes of
/// [`object_motion_vectors`] and [`super::TemporalFrame::ids`].
pub const NO_OBJECT: u32 = u32::MAX;

/// [`motion_vectors`] of a scene whose objects move too: pixel i's point belongs to object
/// `ids[i]` and is carried back to where it was with `back[ids[i]]` (current world → previous
/// world; see [`object_motion`]) before the previous camera projects it. A pixel whose id has
/// no entry in `back` ([`NO_OBJECT`], or an object that did not exist) is taken as static.
/// `ids` must have one entry per pixel; otherwise (empty: no ids traced) every point is taken
/// as static, which is [`motion_vectors`].
pub fn object_motion_vectors(
    prev_view_proj: &Mat4,
    view_proj: &Mat4,
    position: &Image,
    ids: &[u32],
    back: &[Mat4],
) -> Image {
    let objects = (ids.len() == position.width * position.height).then_some((ids, back));
    moving_points(prev_view_proj, view_proj, position, objects, None)
}

/// [`object_motion_vectors`] of a scene whose surfaces may also deform (skins, morph
/// targets): where `steps[i]` is finite it is the world-space step from pixel i's point back
/// to where that surface point was (lumo-render's `deformation_back`), taken instead of its
/// object's transform. `steps` must have one entry per pixel; otherwise it is ignored.
pub fn surface_motion_vectors(
    prev_view_proj: &Mat4,
    view_proj: &Mat4,
    position: &Image,
    ids: &[u32],
    back: &[Mat4],
    steps: &[Vec3],
) -> Image {
    let n = position.width * position.height;
    let objects = (ids.len() == n).then_some((ids, back));
    let steps = (steps.len() == n).then_some(steps);
    moving_points(prev_view_proj, view_proj, position, objects, steps)
}

/// Per object, the transform that carries a point from where the object is now back to where
/// it was: `prev[i] · now[i]⁻¹` from the objects' object → world transforms then and now. The
/// identity for every object when the lists differ in length (a different scene) and for an
/// object whose transform now cannot be inverted.
pub fn object_motion(prev: &[Mat4], now: &[Mat4]) -> Vec<Mat4> {
    if prev.len() != now.len() {
        return vec![Mat4::IDENTITY; now.len()];
    }
    prev.iter()
        .zip(now)
        .map(|(p, c)| {
            if p == c || c.determinant() == 0.0 {
                Mat4::IDENTITY
            } else {
                *p * c.inverse()
            }
        })
        .collect()
}

/// The motion vectors of `position`'s points, each first carried back by its finite step in
/// `steps` or else by its object's transform when `objects` (ids per pixel, transform per
/// id) are given.
fn moving_points(
    prev_view_proj: &Mat4,
    view_proj: &Mat4,
    position: &Image,
    objects: Option<(&[u32], &[Mat4])>,
    steps: Option<&[Vec3]>,
) -> Image {
    let (w, h) = (position.width, position.height);
    let pc = position.channels;
    let mut out = Image::new(w, h, 2, f32::NAN);
    if pc < 3 || w == 0 {
        return out;
    }
    out.data
        .par_chunks_mut(2 * w)
        .enumerate()
        .for_each(|(y, row)| {
            for x in 0..w {
                let i = y * w + x;
                let q = &position.data[i * pc..][..3];
                let p = Vec3::new(q[0], q[1], q[2]);
                if !p.is_finite() {
                    continue;
                }
                let step = steps.map(|s| s[i]).filter(|s| s.is_finite());
                let then = match (
                    step,
                    objects.and_then(|(ids, back)| back.get(ids[i] as usize)),
                ) {
                    (Some(s), _) => p + s,
                    (None, Some(m)) => m.transform_point3(p),
                    (None, None) => p,
                };
                let (Some(a), Some(b)) = (
                    project_to_pixel(prev_view_proj, then, w, h),
                    project_to_pixel(view_proj, p, w, h),
                ) else {
                    continue;
                };
                row[2 * x] = a[0] - b[0];
                row[2 * x + 1] = a[1] - b[1];
            }
        });
    out
}
