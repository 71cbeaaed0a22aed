use glam::Vec3;

/// Which image axis the field of view spans (Mitsuba's `fov_axis`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FovAxis {
    /// Horizontal.
    X,
    /// Vertical.
    Y,
    /// The shorter image side.
    Smaller,
    /// The longer image side.
    Larger,
    /// The diagonal.
    Diagonal,
}

/// A pinhole perspective camera.
#[derive(Clone, Debug)]
pub struct Camera {
    /// Eye position.
    pub origin: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up hint.
    pub up: Vec3,
    /// Field of view in degrees along `fov_axis`.
    pub fov: f32,
    /// Axis the field of view refers to.
    pub fov_axis: FovAxis,
}

impl Camera {
    /// Orthonormal (right, up, forward) basis of the camera.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let forward = (self.target - self.origin).normalize();
        let right = forward.cross(self.up).normalize();
        let up = right.cross(forward);
        (right, up, forward)
    }

    /// Half-extents of the image plane at distance 1 for a `width`×`height` image.
    pub fn half_extent(&self, width: usize, height: usize) -> (f32, f32) {
        let (w, h) = (width as f32, height as f32);
        let t = (self.fov.to_radians() * 0.5).tan();
        let axis_len = match self.fov_axis {
            FovAxis::X => w,
            FovAxis::Y => h,
            FovAxis::Smaller => w.min(h),
            FovAxis::Larger => w.max(h),
            FovAxis::Diagonal => (w * w + h * h).sqrt(),
        };
        (t * w / axis_len, t * h / axis_len)
    }
}
