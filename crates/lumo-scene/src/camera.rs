use glam::{Quat, Vec3};

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

/// How the camera forms its image.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Lens {
    /// A pinhole: every ray leaves the eye (no depth of field).
    #[default]
    Pinhole,
    /// A thin lens (Mitsuba's `thinlens`): rays leave a disk of `aperture_radius` around the
    /// eye, perpendicular to the view axis, and meet again on the plane `focus_distance` ahead,
    /// so only that plane is sharp.
    Thin {
        /// Radius of the aperture disk, in world units.
        aperture_radius: f32,
        /// Distance of the plane in focus along the view axis, in world units.
        focus_distance: f32,
    },
    /// A parallel projection (Mitsuba's `orthographic`, glTF's `orthographic`): rays leave
    /// the plane through the eye along the view axis. The image spans ±`half_width` along the
    /// camera's right axis and ±`half_height` along its up axis (world units); the field of
    /// view is unused.
    Orthographic {
        /// Half the image's width in world units.
        half_width: f32,
        /// Half the image's height in world units.
        half_height: f32,
    },
}

/// The pixel reconstruction filter: how a pixel weighs the image around it. Samples are
/// placed with the filter's density (importance sampling), so every sample counts equally.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum PixelFilter {
    /// Uniform over the pixel (Mitsuba's `box`).
    #[default]
    Box,
    /// 1 − |x|/radius on each axis (Mitsuba's `tent`, radius 1 pixel by default).
    Tent {
        /// Radius in pixels.
        radius: f32,
    },
    /// A Gaussian of `stddev` pixels on each axis, cut at 4 stddev (Mitsuba's `gaussian`,
    /// stddev 0.5 by default).
    Gaussian {
        /// Standard deviation in pixels.
        stddev: f32,
    },
}

/// A perspective (pinhole or thin-lens) or orthographic camera.
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
    /// Pinhole, thin lens or orthographic.
    pub lens: Lens,
    /// The pixel reconstruction filter.
    pub filter: PixelFilter,
}

impl Camera {
    /// Whether the camera has a basis: finite eye, target and up, the target away from the
    /// eye and the up hint not along the view direction ([`Camera::basis`] is NaN otherwise,
    /// and every ray with it: a black image).
    pub fn is_well_formed(&self) -> bool {
        let forward = self.target - self.origin;
        let finite = self.origin.is_finite() && self.target.is_finite() && self.up.is_finite();
        let side = forward
            .normalize_or_zero()
            .cross(self.up.normalize_or_zero());
        finite && forward.length_squared() > 0.0 && side.length_squared() > 1e-12
    }

    /// Orthonormal (right, up, forward) basis of the camera.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let forward = (self.target - self.origin).normalize();
        let right = forward.cross(self.up).normalize();
        let up = right.cross(forward);
        (right, up, forward)
    }

    /// The camera turned by `degrees` about the vertical line through `pivot` (the line along
    /// its up hint): eye and target both turn, so a camera looking at `pivot` keeps looking at
    /// it. Positive angles turn counter-clockwise seen from above (right-handed about `up`).
    /// An up hint of zero length leaves the camera as it is.
    pub fn orbited(&self, pivot: Vec3, degrees: f32) -> Camera {
        let axis = self.up.normalize_or_zero();
        if axis == Vec3::ZERO || !degrees.is_finite() {
            return self.clone();
        }
        let turn = Quat::from_axis_angle(axis, degrees.to_radians());
        Camera {
            origin: pivot + turn * (self.origin - pivot),
            target: pivot + turn * (self.target - pivot),
            ..self.clone()
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orbit_turns_about_the_pivot_and_keeps_looking_at_it() {
        let c = Camera {
            origin: Vec3::new(0.0, 1.0, 4.0),
            target: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            fov: 40.0,
            fov_axis: FovAxis::X,
            lens: Default::default(),
            filter: Default::default(),
        };
        let o = c.orbited(c.target, 90.0);
        // A quarter turn about +y takes +z to +x.
        assert!(
            (o.origin - Vec3::new(4.0, 1.0, 0.0)).length() < 1e-5,
            "{}",
            o.origin
        );
        assert_eq!(o.target, c.target);
        let full = c.orbited(c.target, 360.0);
        assert!((full.origin - c.origin).length() < 1e-5);
    }
}
