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

/// A shape light's sample seen from a shading point, in plain floats (see [`towards`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct TowardsLight {
    /// Unit direction from the shading point to the light point.
    pub wi: [f32; 3],
    /// Distance to the light point.
    pub distance: f32,
    /// Radiance over the full density (light choice included).
    pub weight: [f32; 3],
    /// Solid-angle density, light choice included.
    pub pdf: f32,
    /// Whether the sample counts: the light point faces `from` and is not at it.
    pub ok: bool,
}

/// The light sample of point `q` with unit normal `n` on a shape light of radiance
/// `radiance`, picked with probability `pick` and then with solid-angle density `pdf` from
/// the shading point `from`. Plain floats, no branches: the scalar sampler and the vector
/// bounce's lanes share it, so both give the same bits.
#[inline(always)]
pub(crate) fn towards(
    q: [f32; 3],
    n: [f32; 3],
    pdf: f32,
    pick: f32,
    radiance: [f32; 3],
    from: [f32; 3],
) -> TowardsLight {
    let d = [q[0] - from[0], q[1] - from[1], q[2] - from[2]];
    let distance = ((d[0] * d[0]) + (d[1] * d[1]) + (d[2] * d[2])).sqrt();
    let inv = 1.0 / distance;
    let wi = [d[0] * inv, d[1] * inv, d[2] * inv];
    let facing = (n[0] * -wi[0]) + (n[1] * -wi[1]) + (n[2] * -wi[2]);
    let pdf = pick * pdf;
    let inv_pdf = 1.0 / pdf;
    TowardsLight {
        wi,
        distance,
        weight: [
            radiance[0] * inv_pdf,
            radiance[1] * inv_pdf,
            radiance[2] * inv_pdf,
        ],
        pdf,
        ok: !(facing <= 0.0 || distance <= 0.0),
    }
}

/// What the vector bounce reads of a sphere light seen from outside (whose cone it samples).
#[derive(Clone, Copy, Debug)]
pub(crate) struct SphereLane {
    /// World centre.
    pub center: Vec3,
    /// World radius.
    pub radius: f32,
    /// Normals point inwards (the sphere emits inwards).
    pub flip: bool,
    /// Emitted radiance.
    pub radiance: Vec3,
}

impl ShapeLight {
    /// This light as the vector bounce samples it from `from`, if it is a sphere that `from`
    /// sees from outside (the cone sample of [`crate::accel::analytic::cone_point`]); other
    /// shapes, and a sphere's inside, are sampled by area on the scalar path.
    #[inline(always)]
    pub(crate) fn sphere_lane(&self, from: Vec3) -> Option<SphereLane> {
        let shape = &self.shape;
        shape.sees_cone(from).then_some(SphereLane {
            center: shape.center,
            radius: shape.radius,
            flip: shape.flip,
            radiance: self.radiance,
        })
    }
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
        let s = towards(
            sp.p.into(),
            sp.n.into(),
            pdf,
            pick,
            self.radiance.into(),
            p.into(),
        );
        s.ok.then(|| LightSample {
            light,
            normal: sp.n,
            wi: Vec3::from(s.wi),
            distance: s.distance,
            point: sp.p,
            weight: Vec3::from(s.weight),
            pdf: s.pdf,
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
