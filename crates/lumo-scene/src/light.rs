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
        /// Distance at which the light stops (glTF KHR_lights_punctual's `range`): inside it
        /// the inverse-square falloff is multiplied by [`range_window`]; `None` reaches any
        /// distance.
        range: Option<f32>,
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
        /// How the intensity falls from the beam to the cutoff.
        falloff: SpotFalloff,
        /// Distance at which the light stops, as [`Light::Point`]'s `range`.
        range: Option<f32>,
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

/// Brightest emitted radiance, intensity or irradiance a scene may hold per channel: the film
/// sums squares of what it receives for its variance plane, and (1e15)² = 1e30 is within f32's
/// 3.4e38 with room for the sums. Past it (or past f32's range, as an emissive factor ×
/// strength of 1e20 × 1e20 was) the render came out black with exit 0.
pub const MAX_EMISSION: f32 = 1e15;

/// The factor glTF's KHR_lights_punctual recommends for a light of range `range` at distance
/// `distance`: clamp(1 − (distance / range)⁴, 0, 1), a smooth window that is 1 at the light,
/// falls to exactly 0 at the range and stays 0 beyond it. It multiplies the inverse-square law
/// (intensity · window / distance²), not replaces it.
#[inline]
pub fn range_window(distance: f32, range: f32) -> f32 {
    let x = distance / range;
    let x2 = x * x;
    (1.0 - x2 * x2).clamp(0.0, 1.0)
}

impl Light {
    /// The position of a light that has one (point, spot), for the viewer's edits and picks.
    pub fn position_mut(&mut self) -> Option<&mut Vec3> {
        match self {
            Light::Point { position, .. } | Light::Spot { position, .. } => Some(position),
            Light::Directional { .. } | Light::Constant { .. } | Light::Environment(_) => None,
        }
    }

    /// The editable strength of a light that has one: a point or spot light's intensity, a
    /// directional light's irradiance (constant and image lights have none the viewer edits).
    pub fn intensity_mut(&mut self) -> Option<&mut Vec3> {
        match self {
            Light::Point { intensity, .. } | Light::Spot { intensity, .. } => Some(intensity),
            Light::Directional { irradiance, .. } => Some(irradiance),
            Light::Constant { .. } | Light::Environment(_) => None,
        }
    }

    /// [`Self::position_mut`], read-only.
    pub fn position(&self) -> Option<Vec3> {
        self.fields().0
    }

    /// [`Self::intensity_mut`], read-only.
    pub fn intensity(&self) -> Option<Vec3> {
        self.fields().1
    }

    /// Position and editable strength by value (one exhaustive match for both readers).
    fn fields(&self) -> (Option<Vec3>, Option<Vec3>) {
        match self {
            Light::Point {
                position,
                intensity,
                ..
            }
            | Light::Spot {
                position,
                intensity,
                ..
            } => (Some(*position), Some(*intensity)),
            Light::Directional { irradiance, .. } => (None, Some(*irradiance)),
            Light::Constant { .. } | Light::Environment(_) => (None, None),
        }
    }

    /// The light's strength as its field is named (`intensity`, `irradiance`, `radiance`, or an
    /// environment's `scale × brightest texel`) and its value per channel, for range checks.
    pub fn strength(&self) -> (&'static str, Vec3) {
        match self {
            Light::Point { intensity, .. } | Light::Spot { intensity, .. } => {
                ("intensity", *intensity)
            }
            Light::Directional { irradiance, .. } => ("irradiance", *irradiance),
            Light::Constant { radiance } => ("radiance", *radiance),
            Light::Environment(env) => ("scale × brightest texel", env.brightest()),
        }
    }
}

impl EnvMap {
    /// `scale` times the image's largest value per colour channel (a grey image's in all
    /// three), infinite where a texel is not finite.
    pub fn brightest(&self) -> Vec3 {
        let c = self.image.channels.max(1);
        let mut max = Vec3::ZERO;
        for (i, &v) in self.image.data.iter().enumerate() {
            let k = if c >= 3 { i % c } else { 0 };
            if k < 3 {
                max[k] = max[k].max(if v.is_finite() { v } else { f32::INFINITY });
            }
        }
        if c < 3 {
            max = Vec3::splat(max.x);
        }
        max * self.scale
    }
}

/// How a spot light's intensity falls off between its beam (full) and cutoff (zero) angles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SpotFalloff {
    /// Linear in the angle from the axis (Mitsuba 3's `spot`).
    #[default]
    LinearAngle,
    /// The square of a linear ramp in the cosine (the falloff glTF's KHR_lights_punctual
    /// recommends: saturate((cos − cos outer) / (cos inner − cos outer))²).
    SquaredCosine,
}
