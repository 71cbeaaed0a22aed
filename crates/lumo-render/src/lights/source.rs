//! The one interface every light kind answers (one file per kind, as `bsdf/` has one per
//! material), and its dispatch over [`LightKind`], the closed set of kinds (registered in
//! `lights/mod.rs` beside their modules).

use glam::{Vec2, Vec3};

use super::{EmissionPdf, EmissionSample, LightKind, LightSample, Lights};

/// What [`Lights`] asks of each light: its power (which weighs the choice among lights),
/// whether it is a Dirac delta, a point on it seen from a shading point and that point's
/// density, and particles leaving it with their densities. `lights` gives what is shared
/// (textured emission, the scene's bounding sphere, the environment's tables); `pick` is the
/// probability with which the light was chosen, folded into densities and weights in the
/// order each kind always has (so that every image keeps its bits).
pub(super) trait LightSource {
    /// The power estimate that weighs the light choice; `disk` is the area of the scene's
    /// bounding sphere's great disk (what a distant light pours into the scene over).
    fn power(&self, disk: f32) -> f32;

    /// A Dirac delta in position or direction: light sampling finds it, a path never hits it.
    fn is_delta(&self) -> bool;

    /// Whether it can start particles (the light tracer's and BDPT's light subpaths).
    fn emits_particles(&self) -> bool;

    /// A point on the light as seen from `p` (`light` is its index).
    fn sample_from(
        &self,
        lights: &Lights,
        light: u32,
        pick: f32,
        p: Vec3,
        u: Vec2,
    ) -> Option<LightSample>;

    /// Solid-angle density at `from` with which [`LightSource::sample_from`] picks `point` on
    /// the light (with normal there `n`), choice included; 0 for a Dirac delta.
    fn pdf_from(&self, lights: &Lights, pick: f32, from: Vec3, point: Vec3) -> f32;

    /// A particle leaving the light (`None` where it emits none).
    fn emit(
        &self,
        lights: &Lights,
        light: u32,
        pick: f32,
        u_pos: Vec2,
        u_dir: Vec2,
    ) -> Option<EmissionSample>;

    /// The densities with which [`LightSource::emit`] leaves a point with normal `n` in
    /// direction `dir`, before the check that they are usable.
    fn emission_pdf(&self, lights: &Lights, pick: f32, n: Vec3, dir: Vec3) -> Option<EmissionPdf>;
}

impl LightKind {
    /// See [`LightSource::power`].
    pub(super) fn power(&self, disk: f32) -> f32 {
        each_kind!(self, l => l.power(disk))
    }

    /// See [`LightSource::is_delta`].
    #[inline]
    pub(super) fn is_delta(&self) -> bool {
        each_kind!(self, l => l.is_delta())
    }

    /// See [`LightSource::emits_particles`].
    pub(super) fn emits_particles(&self) -> bool {
        each_kind!(self, l => l.emits_particles())
    }

    /// See [`LightSource::sample_from`].
    #[inline(always)]
    pub(super) fn sample_from(
        &self,
        lights: &Lights,
        light: u32,
        pick: f32,
        p: Vec3,
        u: Vec2,
    ) -> Option<LightSample> {
        each_kind!(self, l => l.sample_from(lights, light, pick, p, u))
    }

    /// See [`LightSource::pdf_from`].
    pub(super) fn pdf_from(&self, lights: &Lights, pick: f32, from: Vec3, point: Vec3) -> f32 {
        each_kind!(self, l => l.pdf_from(lights, pick, from, point))
    }

    /// See [`LightSource::emit`].
    pub(super) fn emit(
        &self,
        lights: &Lights,
        light: u32,
        pick: f32,
        u_pos: Vec2,
        u_dir: Vec2,
    ) -> Option<EmissionSample> {
        each_kind!(self, l => l.emit(lights, light, pick, u_pos, u_dir))
    }

    /// See [`LightSource::emission_pdf`].
    pub(super) fn emission_pdf(
        &self,
        lights: &Lights,
        pick: f32,
        n: Vec3,
        dir: Vec3,
    ) -> Option<EmissionPdf> {
        each_kind!(self, l => l.emission_pdf(lights, pick, n, dir))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Cornell box's area light (a quad of triangles), a sphere light and one light of
    /// every other kind.
    fn lights() -> Lights {
        let mut scene = lumo_scene::builtin_scene("cornell").expect("builtin");
        scene
            .lights
            .extend(crate::test_lights::every_other_light_kind());
        let to_world = lumo_scene::Mat4::from_scale_rotation_translation(
            Vec3::splat(0.1),
            glam::Quat::IDENTITY,
            Vec3::new(0.0, 0.4, 0.0),
        );
        let mut sphere = lumo_scene::shapes::sphere(&to_world, scene.materials.len(), 8, 16);
        sphere.analytic = Some(lumo_scene::Analytic {
            kind: lumo_scene::AnalyticKind::Sphere,
            to_mesh: to_world,
            flip_normals: false,
        });
        scene.meshes.push(sphere);
        scene.materials.push(
            lumo_scene::Material::diffuse("sphere light", Vec3::ZERO).with_emission(Vec3::ONE),
        );
        scene.instances.push(lumo_scene::Instance {
            mesh: scene.meshes.len() - 1,
            transform: lumo_scene::Mat4::IDENTITY,
        });
        Lights::new(&scene)
    }

    /// Each kind's density from a point agrees with the samples it draws (so MIS weighs
    /// them right), a Dirac light has none, and only the environment emits no particles.
    #[test]
    fn each_kind_samples_with_the_density_it_reports() {
        let lights = lights();
        let p = Vec3::new(0.05, -0.3, 0.1);
        let mut kinds = [0usize; 6];
        for (i, l) in lights.lights.iter().enumerate() {
            kinds[match l {
                LightKind::Triangle(_) => 0,
                LightKind::Shape(_) => 1,
                LightKind::Point(_) => 2,
                LightKind::Spot(_) => 3,
                LightKind::Directional(_) => 4,
                LightKind::Environment(_) => 5,
            }] += 1;
            assert_eq!(
                l.emits_particles(),
                !matches!(l, LightKind::Environment(_)),
                "light {i}"
            );
            assert!(l.power(1.0) > 0.0, "light {i}");
            let pick = 0.25;
            let mut checked = 0;
            for k in 0..16 {
                let u = Vec2::new((k as f32 + 0.5) / 16.0, ((k * 7 % 16) as f32 + 0.5) / 16.0);
                let Some(s) = l.sample_from(&lights, i as u32, pick, p, u) else {
                    continue;
                };
                checked += 1;
                if l.is_delta() {
                    assert_eq!(s.pdf, 0.0, "light {i}");
                    assert_eq!(l.pdf_from(&lights, pick, p, p + s.wi), 0.0, "light {i}");
                    continue;
                }
                let to = if s.distance.is_finite() {
                    s.point
                } else {
                    p + s.wi
                };
                let pdf = l.pdf_from(&lights, pick, p, to);
                assert!(
                    (pdf - s.pdf).abs() <= 1e-3 * s.pdf,
                    "light {i}: sampled with {} but reports {pdf}",
                    s.pdf
                );
            }
            assert!(checked > 0, "light {i} never sampled from {p}");
        }
        assert!(
            kinds.iter().all(|&n| n > 0),
            "every kind present: {kinds:?}"
        );
    }
}
