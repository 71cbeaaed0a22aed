//! Emissive exact shapes (spheres, disks, cylinders): sampled by the solid angle they cover
//! where the shape can, and as particle sources by area.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};
use lumo_image::luminance;

use super::source::LightSource;
use super::{EmissionPdf, EmissionSample, LightSample, Lights};
use crate::accel::analytic::Shape;

/// An emissive exact sphere, disk or cylinder of constant radiance.
pub(crate) struct ShapeLight {
    /// The shape in world space.
    pub(super) shape: Shape,
    /// Emitted radiance (front side).
    pub(super) radiance: Vec3,
}

impl LightSource for ShapeLight {
    fn power(&self, _disk: f32) -> f32 {
        let shape = &self.shape;
        if shape.area > 0.0 && shape.area.is_finite() {
            shape.area * PI * luminance(self.radiance.into())
        } else {
            0.0
        }
    }

    fn is_delta(&self) -> bool {
        false
    }

    fn emits_particles(&self) -> bool {
        self.shape.area > 0.0 && self.shape.area.is_finite()
    }

    #[inline(always)]
    fn sample_from(
        &self,
        _lights: &Lights,
        light: u32,
        pick: f32,
        p: Vec3,
        u: Vec2,
    ) -> Option<LightSample> {
        let (sp, pdf) = self.shape.sample_direction(p, u)?;
        let d = sp.p - p;
        let distance = d.length();
        let wi = d / distance;
        if sp.n.dot(-wi) <= 0.0 || distance <= 0.0 {
            return None;
        }
        let pdf = pick * pdf;
        Some(LightSample {
            light,
            normal: sp.n,
            wi,
            distance,
            point: sp.p,
            weight: self.radiance / pdf,
            pdf,
        })
    }

    fn pdf_from(&self, _lights: &Lights, pick: f32, from: Vec3, p: Vec3) -> f32 {
        pick * self
            .shape
            .pdf_direction(from, p, || self.shape.normal_at(p))
    }

    fn emit(
        &self,
        _lights: &Lights,
        light: u32,
        pick: f32,
        u_pos: Vec2,
        u_dir: Vec2,
    ) -> Option<EmissionSample> {
        let sp = self.shape.sample_area(u_pos);
        Some(super::emission::area_emission(
            light,
            pick,
            (sp.p, sp.n, self.shape.area, self.radiance),
            u_dir,
        ))
    }

    fn emission_pdf(&self, _lights: &Lights, pick: f32, n: Vec3, dir: Vec3) -> Option<EmissionPdf> {
        Some(EmissionPdf {
            area: pick / self.shape.area,
            solid_angle: n.dot(dir) / PI,
            delta_position: false,
            delta_direction: false,
        })
    }
}
