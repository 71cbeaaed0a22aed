use std::sync::Arc;

use glam::{Mat4, Vec3};
use lumo_image::Image;

/// An environment map in latitude-longitude layout (Mitsuba's convention: +Y up).
#[derive(Clone, Debug)]
pub struct EnvMap {
    /// Linear RGB radiance.
    pub image: Arc<Image>,
    /// Multiplier on the image.
    pub scale: f32,
    /// Environment-to-world rotation.
    pub to_world: Mat4,
}

/// Light sources other than emissive triangles (those come from materials).
#[derive(Clone, Debug)]
pub enum Light {
    /// Isotropic point light.
    Point {
        /// Position.
        position: Vec3,
        /// Radiant intensity (W/sr per channel).
        intensity: Vec3,
    },
    /// Spot light with a smooth falloff between two cone angles.
    Spot {
        /// Position.
        position: Vec3,
        /// Axis of the cone.
        direction: Vec3,
        /// Intensity on the axis.
        intensity: Vec3,
        /// Full-intensity half angle (degrees).
        beam_width: f32,
        /// Cut-off half angle (degrees).
        cutoff: f32,
    },
    /// Distant light from one direction.
    Directional {
        /// Direction the light travels.
        direction: Vec3,
        /// Irradiance on a surface facing the light.
        irradiance: Vec3,
    },
    /// Constant radiance from every direction.
    Constant {
        /// Radiance.
        radiance: Vec3,
    },
    /// Image-based lighting, importance sampled.
    Environment(EnvMap),
}
