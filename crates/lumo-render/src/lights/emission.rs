//! The lights as sources of particles: a light chosen in proportion to its power among those
//! that can emit from inside the scene, a point on it and a direction leaving it. The light
//! tracer starts its paths here (and bidirectional methods their light subpaths); next-event
//! estimation samples the same lights from a shading point ([`Lights::sample`]).
//!
//! Environment and constant lights do not emit particles: a particle from infinity needs a
//! scene-sized disk per direction, and they stay the path tracer's job.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::{LightKind, Lights};
use crate::geometry::{square_to_cosine_hemisphere, Basis};

/// A particle leaving a light.
#[derive(Clone, Copy, Debug)]
pub struct EmissionSample {
    /// Where it starts: a point on an area light, a point or spot light's position, or a point
    /// on a scene-sized disk outside the scene for a directional light.
    pub p: Vec3,
    /// The area light's unit normal at `p` (it emits on this side); `None` for point, spot and
    /// directional lights, which a camera cannot see directly.
    pub normal: Option<Vec3>,
    /// An area light's radiance at `p` (towards any direction on its front side); zero for
    /// point, spot and directional lights.
    pub radiance: Vec3,
    /// Unit direction of travel.
    pub dir: Vec3,
    /// Emitted radiance (or intensity, irradiance) × cosine over the full sampling density of
    /// (`p`, `dir`): the particle's initial throughput.
    pub weight: Vec3,
    /// The densities of `p` and `dir` (for multiple importance sampling of light subpaths).
    pub pdf: EmissionPdf,
    /// Which light emitted it (for [`Lights::emission_pdf_of`]).
    pub light: u32,
}

/// The densities with which [`Lights::sample_emission`] starts a particle at a point and
/// sends it in a direction: what bidirectional methods need to weigh light subpaths (and, from
/// [`Lights::emission_pdf`], a camera path that hits an area light).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmissionPdf {
    /// Density of the point per unit area, including the choice of the light; for a point or
    /// spot light (a delta position) the probability of choosing it.
    pub area: f32,
    /// Density of the direction per unit solid angle: cosine-weighted for area lights, uniform
    /// over the sphere or the spot's cone; 1 for a directional light (a delta direction).
    pub solid_angle: f32,
    /// The position is a Dirac delta (point and spot lights).
    pub delta_position: bool,
    /// The direction is a Dirac delta (directional lights).
    pub delta_direction: bool,
}

impl Lights {
    /// The densities with which [`Lights::sample_emission`] would leave a point of emissive
    /// triangle `triangle` of instance `instance` (or of its exact shape) in direction `dir`;
    /// `n` is the light's own geometric normal there (a `Surface::ng` on its front side, not a
    /// shading normal), and `triangle` must be one of that instance's triangles. `None` where
    /// that light emits no particles or not towards `dir`.
    pub fn emission_pdf(
        &self,
        instance: u32,
        triangle: u32,
        n: Vec3,
        dir: Vec3,
    ) -> Option<EmissionPdf> {
        self.emission_pdf_of(self.light_index(instance, triangle)?, n, dir)
    }

    /// The index (as in [`EmissionSample::light`] and [`super::LightSample::light`]) of the
    /// light that emissive triangle `triangle` of instance `instance` belongs to.
    pub fn light_index(&self, instance: u32, triangle: u32) -> Option<u32> {
        let offset = (*self.instance_offset.get(instance as usize)?)?;
        match self.lights.get(offset as usize)? {
            // A shape is one light per instance; a mesh has one per triangle.
            LightKind::Shape(_) => Some(offset),
            _ => Some(offset + triangle),
        }
    }

    /// The scene material of area light `light` (`None` for other lights).
    #[inline]
    pub fn area_material(&self, light: u32) -> Option<usize> {
        self.area_materials.get(light as usize).map(|&m| m as usize)
    }

    /// The densities with which [`Lights::sample_emission`] would start a particle on light
    /// `light` (at a point with normal `n`, for area lights) travelling in direction `dir`.
    /// For a directional light `area` is the density on its scene-sized disk and `dir` is not
    /// checked (the direction is a delta). `None` for lights that emit no particles
    /// (environment lights, zero power) and directions they do not emit in.
    pub fn emission_pdf_of(&self, light: u32, n: Vec3, dir: Vec3) -> Option<EmissionPdf> {
        let choice = self.emission_choice.as_ref()?;
        let index = light as usize;
        let pick = choice.pmf(index);
        if pick <= 0.0 {
            return None;
        }
        let pdf = self.lights.get(index)?.emission_pdf(self, pick, n, dir)?;
        (pdf.area > 0.0 && pdf.area.is_finite() && pdf.solid_angle > 0.0).then_some(pdf)
    }

    /// True when no light can emit particles (none at all, or environment lights only).
    pub fn emits_no_particles(&self) -> bool {
        self.emission_choice.is_none()
    }

    /// A particle from a light chosen for `u_choice` in proportion to power, starting at a
    /// point chosen by `u_pos` (area lights; the disk of directional lights) in a direction
    /// chosen by `u_dir`: cosine-weighted for area lights, uniform for point lights, uniform in
    /// the cutoff cone for spot lights.
    pub fn sample_emission(
        &self,
        u_choice: f32,
        u_pos: Vec2,
        u_dir: Vec2,
    ) -> Option<EmissionSample> {
        let choice = self.emission_choice.as_ref()?;
        let (index, _) = choice.sample(u_choice);
        let pick = choice.pmf(index);
        if pick <= 0.0 {
            return None;
        }
        self.lights[index].emit(self, index as u32, pick, u_pos, u_dir)
    }
}

/// A particle leaving `point`, normal, area and radiance of an area light picked with
/// probability `pick`, in a cosine-weighted direction chosen by `u_dir`.
#[inline]
pub(super) fn area_emission(
    light: u32,
    pick: f32,
    area_point: (Vec3, Vec3, f32, Vec3),
    u_dir: Vec2,
) -> EmissionSample {
    let (p, normal, area, radiance) = area_point;
    let pdf_area = pick / area;
    let local = square_to_cosine_hemisphere(u_dir);
    let dir = Basis::new(normal).to_world(local).normalize();
    EmissionSample {
        light,
        p,
        normal: Some(normal),
        radiance,
        dir,
        // Le·cos / (pdf_A · cos/π) = Le·π / pdf_A.
        weight: radiance * PI / pdf_area,
        pdf: EmissionPdf {
            area: pdf_area,
            solid_angle: local.z.max(0.0) / PI,
            delta_position: false,
            delta_direction: false,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumo_scene::shapes::rectangle;
    use lumo_scene::{Light, Mat4, Material, Scene};

    /// The particles' weights average to the lights' total power (∫∫ Le cos dA dω = π A Le for
    /// an area light, 4π I for a point light, I ∫ falloff dω for a spot, E π r² for a directional
    /// light over the scene's disk), and environment lights emit none.
    #[test]
    fn emission_weights_average_to_the_total_power() {
        let mut scene = Scene::empty(crate::test_camera::camera_facing_origin(Vec3::new(
            0.0, 0.0, 5.0,
        )));
        let m = scene
            .add_material(Material::diffuse("light", Vec3::ZERO).with_emission(Vec3::splat(3.0)));
        // A 2 × 1 rectangle (Mitsuba's rectangle spans [-1, 1]²).
        scene.add_mesh(rectangle(&Mat4::from_scale(Vec3::new(1.0, 0.5, 1.0)), m));
        scene.lights.push(Light::Point {
            position: Vec3::new(0.0, 1.0, 0.0),
            intensity: Vec3::splat(5.0),
            range: None,
        });
        scene.lights.push(Light::Spot {
            position: Vec3::new(1.0, 1.0, 0.0),
            direction: Vec3::new(0.0, -1.0, 0.0),
            intensity: Vec3::splat(7.0),
            beam_width: 20.0,
            cutoff: 35.0,
            falloff: Default::default(),
            range: None,
        });
        scene.lights.push(Light::Constant {
            radiance: Vec3::splat(1.0),
        });
        let lights = Lights::new(&scene);
        let spot = crate::lights::SpotCone::new(20.0, 35.0, Default::default()).solid_angle() * 7.0;
        let expected = PI * 2.0 * 3.0 + 4.0 * PI * 5.0 + spot;
        let n = 1 << 18;
        let mut sum = 0.0f64;
        for i in 0..n {
            let mut sampler = crate::sampler::PixelSampler::new(0, 0, i, 9);
            let (u_choice, u_pos, u_dir) =
                (sampler.next_1d(), sampler.next_2d(), sampler.next_2d());
            let e = lights
                .sample_emission(u_choice, u_pos, u_dir)
                .expect("an emitting light is always chosen");
            assert!(e.weight.is_finite() && e.dir.is_normalized());
            sum += e.weight.x as f64;
            // The weight is what the light emits along `dir` over the two densities.
            let emitted = match e.normal {
                Some(n) => 3.0 * n.dot(e.dir),
                None if e.p.x == 0.0 => 5.0,
                None => {
                    let cone = crate::lights::SpotCone::new(20.0, 35.0, Default::default());
                    7.0 * cone.falloff(-e.dir.y)
                }
            };
            let w = emitted / (e.pdf.area * e.pdf.solid_angle);
            // (Absolute near a spot's cutoff, where the falloff is steep in the cosine.)
            let tolerance = 1e-3 * (1.0 + e.weight.x.abs());
            assert!((w - e.weight.x).abs() < tolerance, "{w} vs {}", e.weight.x);
            assert_eq!(e.pdf.delta_position, e.normal.is_none());
        }
        let mean = sum / n as f64;
        assert!(
            (mean / expected as f64 - 1.0).abs() < 0.01,
            "mean weight {mean} vs total power {expected}"
        );
        // The densities of area-light particles agree with their weights: Le·cos / (pdf_A·pdf_ω).
        for i in 0..64 {
            let mut sampler = crate::sampler::PixelSampler::new(1, 0, i, 9);
            let (u_choice, u_pos, u_dir) =
                (sampler.next_1d(), sampler.next_2d(), sampler.next_2d());
            let e = lights.sample_emission(u_choice, u_pos, u_dir).unwrap();
            let Some(n) = e.normal else { continue };
            // The rectangle's two triangles have the same area and power, so the same pdf.
            let tri = 0;
            let pdf = lights
                .emission_pdf(0, tri, n, e.dir)
                .expect("the light emits");
            let weight = 3.0 * n.dot(e.dir) / (pdf.area * pdf.solid_angle);
            assert!(
                (weight / e.weight.x - 1.0).abs() < 1e-4,
                "{weight} vs {}",
                e.weight.x
            );
            assert!(
                lights.emission_pdf(0, tri, n, -e.dir).is_none(),
                "nothing leaves the back"
            );
        }
        let mut sky = Scene::empty(scene.camera);
        sky.lights.push(Light::Constant {
            radiance: Vec3::ONE,
        });
        assert!(Lights::new(&sky).emits_no_particles());
        // A light of zero power emits nothing either (no uniform choice among dark lights).
        sky.lights.push(Light::Point {
            position: Vec3::ZERO,
            intensity: Vec3::ZERO,
            range: None,
        });
        assert!(Lights::new(&sky).emits_no_particles());
    }
}
