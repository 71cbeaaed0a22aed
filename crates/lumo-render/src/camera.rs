//! Primary rays of the pinhole camera.

use glam::{Vec2, Vec3};
use lumo_scene::Camera;

/// Precomputed camera basis for one image size.
#[derive(Clone, Copy, Debug)]
pub struct CameraRays {
    origin: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    inv_size: Vec2,
}

impl CameraRays {
    /// Camera rays for a `width`×`height` image.
    pub fn new(camera: &Camera, width: usize, height: usize) -> Self {
        let (right, up, forward) = camera.basis();
        let (hw, hh) = camera.half_extent(width, height);
        Self {
            origin: camera.origin,
            forward,
            right: right * hw,
            up: up * hh,
            inv_size: Vec2::new(1.0 / width as f32, 1.0 / height as f32),
        }
    }

    /// Eye position.
    pub fn origin(&self) -> Vec3 {
        self.origin
    }

    /// Unit direction through image position `film` (pixels; x right, y down).
    #[inline]
    pub fn direction(&self, film: Vec2) -> Vec3 {
        let ndc = film * self.inv_size;
        let (sx, sy) = (2.0 * ndc.x - 1.0, 1.0 - 2.0 * ndc.y);
        (self.forward + self.right * sx + self.up * sy).normalize()
    }

    /// Image position (pixels) where world direction `dir` from the eye lands, if in front.
    pub fn project(&self, dir: Vec3) -> Option<Vec2> {
        let z = dir.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let sx = dir.dot(self.right) / (z * self.right.length_squared());
        let sy = dir.dot(self.up) / (z * self.up.length_squared());
        Some(Vec2::new(
            (sx + 1.0) * 0.5 / self.inv_size.x,
            (1.0 - sy) * 0.5 / self.inv_size.y,
        ))
    }
}
