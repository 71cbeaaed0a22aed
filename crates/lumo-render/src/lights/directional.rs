//! Directional lights: a Dirac delta in direction (a sun), emitting particles from a
//! scene-sized disk outside the scene.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};
use lumo_image::luminance;

use super::source::LightSource;
use super::{EmissionPdf, EmissionSample, LightSample, Lights};
use crate::geometry::{square_to_disk, Basis};

/// A directional light.
pub(crate) struct DirectionalLight {
    /// Unit direction the light travels in.
    pub(super) direction: Vec3,
    /// Irradiance on a surface facing it.
    pub(super) irradiance: Vec3,
}

impl LightSource for DirectionalLight {
    fn power(&self, disk: f32) -> f32 {
        disk * luminance(self.irradiance.into())
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
        _p: Vec3,
        _u: Vec2,
    ) -> Option<LightSample> {
        Some(LightSample {
            light,
            normal: Vec3::ZERO,
            wi: -self.direction,
            distance: f32::INFINITY,
            point: Vec3::ZERO,
            weight: self.irradiance / pick,
            pdf: 0.0,
        })
    }

    fn pdf_from(&self, _lights: &Lights, _pick: f32, _from: Vec3, _point: Vec3) -> f32 {
        0.0
    }

    fn emit(
        &self,
        lights: &Lights,
        light: u32,
        pick: f32,
        u_pos: Vec2,
        _u_dir: Vec2,
    ) -> Option<EmissionSample> {
        // A disk covering the scene, perpendicular to the light, outside the scene.
        let direction = &self.direction;
        let r = lights.scene_radius;
        let d = square_to_disk(u_pos) * r;
        let f = Basis::new(*direction);
        Some(EmissionSample {
            light,
            p: lights.scene_center + f.to_world(Vec3::new(d.x, d.y, 0.0)) - *direction * r,
            normal: None,
            radiance: Vec3::ZERO,
            dir: *direction,
            weight: self.irradiance * (PI * r * r) / pick,
            pdf: EmissionPdf {
                area: pick / (PI * r * r),
                solid_angle: 1.0,
                delta_position: false,
                delta_direction: true,
            },
        })
    }

    fn emission_pdf(
        &self,
        lights: &Lights,
        pick: f32,
        _n: Vec3,
        _dir: Vec3,
    ) -> Option<EmissionPdf> {
        let r = lights.scene_radius;
        Some(EmissionPdf {
            area: pick / (PI * r * r),
            solid_angle: 1.0,
            delta_position: false,
            delta_direction: true,
        })
    }
}
