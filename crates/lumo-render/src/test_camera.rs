//! Test fixture: the camera most unit tests need, looking at the origin from a point on +z.

use glam::Vec3;
use lumo_scene::{Camera, FovAxis};

/// A 40° pinhole camera at `origin` looking at the world origin, y up.
pub(crate) fn camera_facing_origin(origin: Vec3) -> Camera {
    Camera {
        origin,
        target: Vec3::ZERO,
        up: Vec3::Y,
        fov: 40.0,
        fov_axis: FovAxis::X,
        lens: Default::default(),
        filter: Default::default(),
    }
}
