//! Emissive triangles of meshes: their radiance (constant or a texture), sampled by area from a
//! shading point and as particle sources (cosine-weighted).

use std::f32::consts::PI;
use std::sync::Arc;

use glam::{Vec2, Vec3};
use lumo_image::luminance;
use lumo_scene::{Material, Mesh, Texture};

use super::source::LightSource;
use super::{EmissionPdf, EmissionSample, LightSample, Lights};
use crate::geometry::square_to_triangle;

/// An emissive triangle in world space.
#[derive(Clone, Copy, Debug)]
pub struct EmissiveTriangle {
    /// First corner.
    pub(crate) p0: Vec3,
    /// Second corner minus the first.
    pub(crate) e1: Vec3,
    /// Third corner minus the first.
    pub(crate) e2: Vec3,
    /// Unit geometric normal; the triangle emits on this side only.
    pub(crate) normal: Vec3,
    /// Area.
    pub(crate) area: f32,
    /// Emitted radiance (the average of its texture where `texture` is set).
    pub(crate) radiance: Vec3,
    /// Index into [`Lights`]' textured emission records, or `NO_TEXTURE` where the radiance
    /// is the same everywhere (an index, not a pointer, keeps the triangle `Copy` and small).
    pub(crate) texture: u32,
}

/// [`EmissiveTriangle::texture`] of a triangle whose radiance is constant.
pub(crate) const NO_TEXTURE: u32 = u32::MAX;

/// The radiance texture of an emissive triangle and its corners' texture coordinates.
#[derive(Clone, Debug)]
pub(crate) struct TexturedEmission {
    texture: Arc<Texture>,
    uv: [Vec2; 3],
}

impl TexturedEmission {
    /// [`EmissiveTriangle::texture`] for triangle `t` of `mesh` under `material`: a new
    /// record in `textured` if its radiance is a texture, else `NO_TEXTURE`. (Shared by the
    /// light sampler and the light tracer, which collect the same triangles.)
    pub(crate) fn register(
        textured: &mut Vec<Self>,
        material: &Material,
        mesh: &Mesh,
        t: usize,
    ) -> u32 {
        let Some(texture) = &material.emission_map else {
            return NO_TEXTURE;
        };
        textured.push(Self {
            texture: texture.clone(),
            uv: mesh.triangle_uvs(t),
        });
        textured.len() as u32 - 1
    }
}

/// Radiance of a triangle whose record is `texture` (see [`TexturedEmission::register`]) at
/// the point with weights `b` of its second and third corner; `constant` where it has none.
#[inline(always)]
pub(crate) fn triangle_radiance(
    textured: &[TexturedEmission],
    texture: u32,
    constant: Vec3,
    b: Vec2,
) -> Vec3 {
    match textured.get(texture as usize) {
        Some(TexturedEmission {
            texture,
            uv: [a, c, d],
        }) => texture.eval(*a * (1.0 - b.x - b.y) + *c * b.x + *d * b.y),
        None => constant,
    }
}

impl LightSource for EmissiveTriangle {
    fn power(&self, _disk: f32) -> f32 {
        // Degenerate triangles keep their slot (indices must line up) but get no power.
        if self.area > 0.0 {
            self.area * PI * luminance(self.radiance.into())
        } else {
            0.0
        }
    }

    fn is_delta(&self) -> bool {
        false
    }

    fn emits_particles(&self) -> bool {
        self.area > 0.0
    }

    #[inline(always)]
    fn sample_from(
        &self,
        lights: &Lights,
        light: u32,
        pick: f32,
        p: Vec3,
        u: Vec2,
    ) -> Option<LightSample> {
        let tri = self;
        let b = square_to_triangle(u);
        let q = tri.p0 + tri.e1 * b.x + tri.e2 * b.y;
        let d = q - p;
        let dist2 = d.length_squared();
        let distance = dist2.sqrt();
        let wi = d * (1.0 / distance);
        let cos = tri.normal.dot(-wi);
        if cos <= 0.0 || tri.area <= 0.0 {
            return None;
        }
        // pdf and 1/pdf as two independent divisions rather than a chain of them
        // (the chain of sqrt and divides was this function's critical path).
        let (num, den) = (pick * dist2, tri.area * cos);
        Some(LightSample {
            light,
            normal: tri.normal,
            wi,
            distance,
            point: q,
            weight: triangle_radiance(&lights.textured, tri.texture, tri.radiance, b) * (den / num),
            pdf: num / den,
        })
    }

    fn pdf_from(&self, _lights: &Lights, pick: f32, from: Vec3, p: Vec3) -> f32 {
        let tri = self;
        let d = p - from;
        let dist2 = d.length_squared();
        let cos = tri.normal.dot(-d / dist2.sqrt()).abs();
        if cos <= 0.0 || tri.area <= 0.0 {
            return 0.0;
        }
        pick * dist2 / (tri.area * cos)
    }

    fn emit(
        &self,
        lights: &Lights,
        light: u32,
        pick: f32,
        u_pos: Vec2,
        u_dir: Vec2,
    ) -> Option<EmissionSample> {
        let tri = self;
        let b = square_to_triangle(u_pos);
        let radiance = triangle_radiance(&lights.textured, tri.texture, tri.radiance, b);
        Some(super::emission::area_emission(
            light,
            pick,
            (
                tri.p0 + tri.e1 * b.x + tri.e2 * b.y,
                tri.normal,
                tri.area,
                radiance,
            ),
            u_dir,
        ))
    }

    fn emission_pdf(&self, _lights: &Lights, pick: f32, n: Vec3, dir: Vec3) -> Option<EmissionPdf> {
        Some(EmissionPdf {
            area: pick / self.area,
            solid_angle: n.dot(dir) / PI,
            delta_position: false,
            delta_direction: false,
        })
    }
}
