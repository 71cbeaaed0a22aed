//! Point lights: a Dirac delta in position, emitting the same intensity in every direction.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};
use lumo_image::luminance;

use super::source::LightSource;
use super::{EmissionPdf, EmissionSample, LightSample, Lights};
use crate::geometry::{square_to_uniform_sphere, UNIFORM_SPHERE_PDF};

/// A point light.
pub(crate) struct PointLight {
    /// Where it is.
    pub(super) position: Vec3,
    /// Radiant intensity (W/sr per channel).
    pub(super) intensity: Vec3,
    /// Distance at which it stops (glTF's `range`), `None` for none.
    pub(super) range: Option<f32>,
}

impl LightSource for PointLight {
    fn power(&self, _disk: f32) -> f32 {
        // Without the range's window: the emitted power of the unranged light. A ranged light
        // delivers less (how much depends on what lies within its range), so the choice among
        // lights over-picks it a little; that costs variance, not bias.
        4.0 * PI * luminance(self.intensity.into())
    }

    fn is_delta(&self) -> bool {
        true
    }

    fn emits_particles(&self) -> bool {
        true
    }

    #[inline(always)]
    fn sample_from(
        &self,
        _lights: &Lights,
        light: u32,
        pick: f32,
        p: Vec3,
        _u: Vec2,
    ) -> Option<LightSample> {
        let d = self.position - p;
        let dist2 = d.length_squared();
        let distance = dist2.sqrt();
        let intensity = windowed(self.intensity, self.range, distance)?;
        Some(LightSample {
            light,
            normal: Vec3::ZERO,
            wi: d / distance,
            distance,
            point: self.position,
            weight: intensity / (dist2 * pick),
            pdf: 0.0,
        })
    }

    fn pdf_from(&self, _lights: &Lights, _pick: f32, _from: Vec3, _point: Vec3) -> f32 {
        0.0
    }

    fn emit(
        &self,
        _lights: &Lights,
        light: u32,
        pick: f32,
        _u_pos: Vec2,
        u_dir: Vec2,
    ) -> Option<EmissionSample> {
        Some(EmissionSample {
            light,
            p: self.position,
            normal: None,
            radiance: Vec3::ZERO,
            dir: square_to_uniform_sphere(u_dir),
            weight: self.intensity / (pick * UNIFORM_SPHERE_PDF),
            pdf: EmissionPdf {
                area: pick,
                solid_angle: UNIFORM_SPHERE_PDF,
                delta_position: true,
                delta_direction: false,
            },
        })
    }

    fn emission_pdf(
        &self,
        _lights: &Lights,
        pick: f32,
        _n: Vec3,
        _dir: Vec3,
    ) -> Option<EmissionPdf> {
        Some(EmissionPdf {
            area: pick,
            solid_angle: UNIFORM_SPHERE_PDF,
            delta_position: true,
            delta_direction: false,
        })
    }
}

/// `intensity` seen at `distance` from a light of range `range`: times the range's window
/// (`None` at or beyond the range: nothing arrives, no shadow ray is needed), or untouched
/// for a light without one (so that such lights keep their bits).
#[inline(always)]
pub(super) fn windowed(intensity: Vec3, range: Option<f32>, distance: f32) -> Option<Vec3> {
    match range {
        None => Some(intensity),
        Some(r) => {
            let w = lumo_scene::range_window(distance, r);
            (w > 0.0).then(|| intensity * w)
        }
    }
}
