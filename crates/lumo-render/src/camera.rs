//! The pinhole camera both ways: rays from the eye through the film (path tracing) and world
//! points projected back onto the film with the camera's importance (light tracing and, later,
//! bidirectional connections).

use glam::{Vec2, Vec3};
use lumo_scene::Camera;

/// A pinhole camera for one image size: precomputed basis, film extent and importance.
#[derive(Clone, Copy, Debug)]
pub struct PinholeCamera {
    origin: Vec3,
    forward: Vec3,
    /// Unit right and up axes.
    right: Vec3,
    up: Vec3,
    /// Right and up scaled by the film's half-extents at distance 1.
    right_extent: Vec3,
    up_extent: Vec3,
    /// Half-extents of the film at distance 1.
    half: Vec2,
    size: Vec2,
    inv_size: Vec2,
    /// Pixels per unit film area at distance 1 ([`PinholeCamera::pixel_importance`]).
    pixel_importance: f32,
}

impl PinholeCamera {
    /// The camera for a `width`×`height` image.
    pub fn new(camera: &Camera, width: usize, height: usize) -> Self {
        let (right, up, forward) = camera.basis();
        let (hw, hh) = camera.half_extent(width, height);
        Self {
            origin: camera.origin,
            forward,
            right,
            up,
            right_extent: right * hw,
            up_extent: up * hh,
            half: Vec2::new(hw, hh),
            size: Vec2::new(width as f32, height as f32),
            inv_size: Vec2::new(1.0 / width as f32, 1.0 / height as f32),
            pixel_importance: (width * height) as f32 / (4.0 * hw * hh),
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
        (self.forward + self.right_extent * sx + self.up_extent * sy).normalize()
    }

    /// Image position (pixels) where world direction `dir` from the eye lands, if in front
    /// (it may lie outside the film).
    pub fn project(&self, dir: Vec3) -> Option<Vec2> {
        let z = dir.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let sx = dir.dot(self.right_extent) / (z * self.right_extent.length_squared());
        let sy = dir.dot(self.up_extent) / (z * self.up_extent.length_squared());
        Some(Vec2::new(
            (sx + 1.0) * 0.5 / self.inv_size.x,
            (1.0 - sy) * 0.5 / self.inv_size.y,
        ))
    }

    /// Film position (pixels, x right, y down) of world point `p` and the cosine between the
    /// view axis and the direction to `p`, if `p` is in front and inside the film.
    pub fn project_point(&self, p: Vec3) -> Option<(Vec2, f32)> {
        let d = p - self.origin;
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let sx = d.dot(self.right) / (z * self.half.x);
        let sy = d.dot(self.up) / (z * self.half.y);
        if !(-1.0..1.0).contains(&sx) || !(-1.0..1.0).contains(&sy) {
            return None;
        }
        let film = Vec2::new((sx + 1.0) * 0.5, (1.0 - sy) * 0.5) * self.size;
        Some((film, z / d.length()))
    }

    /// Pixels per unit film area at distance 1. The importance a pixel-sized filter gives a
    /// direction at angle θ to the view axis is `pixel_importance / cos⁴θ` (the film at
    /// distance 1 seen under solid angle `cos³θ dA`), so a connection from a surface point at
    /// distance d contributes `G·We = |cos_surface| · pixel_importance / (d² cos³θ)`.
    pub fn pixel_importance(&self) -> f32 {
        self.pixel_importance
    }
}
