//! Light sampling for next-event estimation: emissive triangles, point, spot, directional,
//! constant and image-based environment lights, chosen in proportion to an estimate of power.

mod directional;
pub mod distribution;
mod emission;
mod environment;
mod point;
mod polygon;
mod selection;
mod shape;
mod split;
mod spot;
mod triangle;

use std::f32::consts::PI;

use glam::{Vec2, Vec3};
use lumo_scene::{EnvMap, Light, Scene};

use crate::accel::analytic::Shape;
use crate::geometry::UNIFORM_SPHERE_PDF;
use crate::lights::distribution::{AliasTable, Distribution1d};
use directional::DirectionalLight;
pub use emission::{EmissionPdf, EmissionSample};
use environment::{EnvSampler, EnvironmentLight};
use point::PointLight;
pub use polygon::{triangle_cosine_integral, CosineTriangle};
pub use selection::SelectionRefusal;
pub(crate) use shape::towards;
use shape::ShapeLight;
pub use spot::SpotCone;
use spot::SpotLight;
pub use triangle::EmissiveTriangle;
pub(crate) use triangle::{TexturedEmission, NO_TEXTURE};

// The kinds of light: a new kind is its file, its `mod` line above, a `LightKind` variant,
// its line in `each_kind!` and, for a light the scene lists, its arm in `from_scene`; the
// `LightSource` dispatch (`source.rs`) follows.

/// A light of the scene: one of the kinds, each in its own file.
enum LightKind {
    /// An emissive triangle of a mesh.
    Triangle(EmissiveTriangle),
    /// An emissive exact sphere, disk or cylinder.
    Shape(ShapeLight),
    /// A point light.
    Point(PointLight),
    /// A spot light.
    Spot(SpotLight),
    /// A directional (sun-like) light.
    Directional(DirectionalLight),
    /// The environment: the constant background and/or the image, as one light.
    Environment(EnvironmentLight),
}

/// `$body` with `$l` bound to the light of any kind (static dispatch: every arm inlines).
macro_rules! each_kind {
    ($kind:expr, $l:ident => $body:expr) => {
        match $kind {
            LightKind::Triangle($l) => $body,
            LightKind::Shape($l) => $body,
            LightKind::Point($l) => $body,
            LightKind::Spot($l) => $body,
            LightKind::Directional($l) => $body,
            LightKind::Environment($l) => $body,
        }
    };
}

/// What a light of the scene's list becomes among the kinds.
enum SceneLight<'a> {
    /// A kind of its own.
    Kind(LightKind),
    /// Constant radiance, summed into the one environment light.
    Constant(Vec3),
    /// The environment image, sampled by the one environment light.
    Environment(&'a EnvMap),
    /// Nothing to sample (an empty image: the loaders refuse one, a scene built in code must
    /// not panic).
    Nothing,
}

impl LightKind {
    /// The kind a light of the scene's list is (area lights come from emissive materials).
    fn from_scene(light: &Light) -> SceneLight<'_> {
        match light {
            Light::Point {
                position,
                intensity,
                range,
            } => SceneLight::Kind(LightKind::Point(PointLight {
                position: *position,
                intensity: *intensity,
                range: *range,
            })),
            Light::Spot {
                position,
                direction,
                intensity,
                beam_width,
                cutoff,
                falloff,
                range,
            } => SceneLight::Kind(LightKind::Spot(SpotLight {
                position: *position,
                axis: direction.normalize(),
                intensity: *intensity,
                cone: SpotCone::new(*beam_width, *cutoff, *falloff),
                range: *range,
            })),
            Light::Directional {
                direction,
                irradiance,
            } => SceneLight::Kind(LightKind::Directional(DirectionalLight {
                direction: direction.normalize(),
                irradiance: *irradiance,
            })),
            Light::Constant { radiance } => SceneLight::Constant(*radiance),
            Light::Environment(map) if map.image.width == 0 || map.image.height == 0 => {
                SceneLight::Nothing
            }
            Light::Environment(map) => SceneLight::Environment(map),
        }
    }
}

mod source;

/// A light direction chosen for a shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3,
    /// Distance to the light point (infinite for distant lights).
    pub distance: f32,
    /// The light point itself (the light's position for point and spot lights; unused for
    /// distant lights): shadow rays aim at it from their offset origin.
    pub point: Vec3,
    /// Emitted radiance (or intensity term) divided by the full sampling density.
    pub weight: Vec3,
    /// Solid-angle density including the light choice (0 for delta lights).
    pub pdf: f32,
    /// Which light was sampled (for [`Lights::emission_pdf_of`]: bidirectional methods weigh
    /// a light sample as the light subpath that could have started there).
    pub light: u32,
    /// The area light's unit normal at `point` (zero for other lights).
    pub normal: Vec3,
}

/// A light as [`Lights::choose_lane`] hands it to the vector bounce, with the probability it
/// was picked with.
#[derive(Clone, Copy)]
pub(crate) enum LaneLight<'a> {
    /// An emissive sphere, disk or cylinder.
    Shape(f32, &'a ShapeLight),
    /// The constant environment (no image).
    Environment(f32),
    /// Any other light, or none: the scalar path samples it.
    Other,
}

/// All lights of a scene with a choice among them: by power, or by power mixed with measured
/// shares ([`Lights::select_by_groups`]).
pub struct Lights {
    lights: Vec<LightKind>,
    choice: Distribution1d,
    /// The same choice, sampled in constant time.
    alias: AliasTable,
    /// The choice among lights that emit particles (not the environment), by the same power;
    /// `None` when there are none.
    emission_choice: Option<Distribution1d>,
    /// The choice among lights that are not Dirac deltas (triangles, shapes, environment), by
    /// the same power; `None` when there are none (the direct-light split samples these).
    area_choice: Option<Distribution1d>,
    /// Index of the first light that is not an emissive triangle or shape: the point, spot
    /// and directional lights and the environment come from here on.
    first_punctual: usize,
    /// For each instance, the index of its first emissive triangle in `lights`, if emissive.
    instance_offset: Vec<Option<u32>>,
    /// Radiance textures of textured emissive triangles ([`EmissiveTriangle::texture`]).
    textured: Vec<TexturedEmission>,
    /// The material of each area light (the first entries of `lights`), for what only the
    /// material knows (a tabulated emission spectrum).
    area_materials: Vec<u32>,
    env: Option<EnvSampler>,
    /// Mean radiance of the environment image times its scale (zero without one): part of
    /// its power estimate, kept so [`Lights::update`] need not rescan the image.
    env_mean: Vec3,
    constant: Vec3,
    scene_radius: f32,
    scene_center: Vec3,
    /// Each light's power estimate (the choice by power, and the power term of a measured
    /// selection).
    power: Vec<f32>,
    /// The index in `lights` of each light group's first light ([`Lights::group_count`]).
    group_starts: Vec<u32>,
    /// The measured shares the choice mixes with power, if any (`selection.rs`).
    selection: Option<selection::Selection>,
}

impl Lights {
    /// Collects the scene's lights. Emissive triangles come from materials with emission.
    pub fn new(scene: &Scene) -> Self {
        Self::build(scene, None)
    }

    /// Re-collects the lights after instances, vertices or punctual lights moved (a new pose of
    /// an animation). The environment's sampler and mean are kept rather than rebuilt from its
    /// image, so the scene's environment light must be the one this was built with; the result
    /// equals [`Lights::new`] of the changed scene, except that a measured selection
    /// ([`Lights::select_by_groups`]) is kept: its group shares are re-applied to the new
    /// powers (a light that moved keeps its share rather than a new pilot's).
    pub fn update(&mut self, scene: &Scene) {
        let env = self.env.take().map(|e| (e, self.env_mean));
        let selection = self.selection.take();
        *self = Self::build(scene, env);
        self.reapply(selection);
    }

    /// [`Lights::new`], reusing `reuse` (a sampler and its mean) for the environment image.
    fn build(scene: &Scene, mut reuse: Option<(EnvSampler, Vec3)>) -> Self {
        let (lo, hi) = scene.bounds();
        let scene_center = (lo + hi) * 0.5;
        let scene_radius = ((hi - lo).length() * 0.5).max(1e-3);
        let mut lights = Vec::new();
        let mut instance_offset = vec![None; scene.instances.len()];
        let mut textured = Vec::new();
        let mut area_materials = Vec::new();
        // Each emissive instance is one group; each punctual light and the environment too.
        let mut group_starts = Vec::new();
        for (ii, inst) in scene.instances.iter().enumerate() {
            let mesh = &scene.meshes[inst.mesh];
            let material = &scene.materials[mesh.material];
            if !material.is_emissive() {
                continue;
            }
            instance_offset[ii] = Some(lights.len() as u32);
            group_starts.push(lights.len() as u32);
            if let Some(a) = &mesh.analytic {
                lights.push(LightKind::Shape(ShapeLight {
                    shape: Shape::new(a, inst.transform),
                    radiance: material.emission,
                }));
                area_materials.push(mesh.material as u32);
                continue;
            }
            for t in 0..mesh.triangle_count() {
                let [a, b, c] = mesh.triangle(t).map(|p| inst.transform.transform_point3(p));
                let cross = (b - a).cross(c - a);
                let area = 0.5 * cross.length();
                let texture = TexturedEmission::register(&mut textured, material, mesh, t);
                let tri = EmissiveTriangle {
                    p0: a,
                    e1: b - a,
                    e2: c - a,
                    normal: cross.normalize_or_zero(),
                    area,
                    radiance: material.emission,
                    texture,
                };
                lights.push(LightKind::Triangle(tri));
                area_materials.push(mesh.material as u32);
            }
        }
        let disk = PI * scene_radius * scene_radius;
        // The scene's punctual lights (and the environment, last) follow the area lights.
        let first_punctual = lights.len();
        let mut env = None;
        let mut constant = Vec3::ZERO;
        for light in &scene.lights {
            match LightKind::from_scene(light) {
                SceneLight::Kind(kind) => {
                    group_starts.push(lights.len() as u32);
                    lights.push(kind)
                }
                SceneLight::Constant(radiance) => constant += radiance,
                SceneLight::Environment(map) => {
                    env = Some(reuse.take().unwrap_or_else(|| {
                        let sampler = EnvSampler::new(map);
                        let m = map.image.to_channels(3).channel_means();
                        let mean = Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32) * map.scale;
                        (sampler, mean)
                    }))
                }
                SceneLight::Nothing => {}
            }
        }
        let (env, env_mean) = match env {
            Some((e, mean)) => (Some(e), mean),
            None => (None, Vec3::ZERO),
        };
        // One entry samples the whole environment (constant and/or image).
        if env.is_some() || constant.max_element() > 0.0 {
            group_starts.push(lights.len() as u32);
            lights.push(LightKind::Environment(EnvironmentLight {
                mean: env_mean + constant,
            }));
        }
        let power: Vec<f32> = lights.iter().map(|l| l.power(disk)).collect();
        let choice = Distribution1d::new(&power);
        let emission_power: Vec<f32> = lights
            .iter()
            .zip(&power)
            .map(|(l, &w)| if l.emits_particles() { w } else { 0.0 })
            .collect();
        // Only lights with power emit: with none (all black, or environment only) the light
        // tracer has nothing to start from, rather than a uniform choice of dark lights.
        let emission_choice = emission_power
            .iter()
            .any(|&w| w.is_finite() && w > 0.0)
            .then(|| Distribution1d::new(&emission_power));
        let area_power: Vec<f32> = lights
            .iter()
            .zip(&power)
            .map(|(l, &w)| if l.is_delta() { 0.0 } else { w })
            .collect();
        let area_choice = area_power
            .iter()
            .any(|&w| w.is_finite() && w > 0.0)
            .then(|| Distribution1d::new(&area_power));
        Lights {
            area_choice,
            first_punctual,
            alias: AliasTable::new(&choice),
            emission_choice,
            choice,
            lights,
            instance_offset,
            textured,
            area_materials,
            env,
            env_mean,
            constant,
            scene_radius,
            scene_center,
            power,
            group_starts,
            selection: None,
        }
    }

    /// True when there is nothing to sample.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// True when rays that escape the scene receive light (an environment map or a constant
    /// background): light that emits no particles.
    pub fn has_environment(&self) -> bool {
        self.env.is_some() || self.constant != Vec3::ZERO
    }

    /// Radiance arriving from direction `dir` when a ray escapes the scene.
    #[inline]
    pub fn environment(&self, dir: Vec3) -> Vec3 {
        self.constant + self.env.as_ref().map_or(Vec3::ZERO, |e| e.radiance(dir))
    }

    fn env_index(&self) -> Option<usize> {
        matches!(self.lights.last(), Some(LightKind::Environment(_))).then(|| self.lights.len() - 1)
    }

    /// Whether light `light` (a [`LightSample::light`]) is the environment.
    pub fn is_environment(&self, light: u32) -> bool {
        matches!(
            self.lights.get(light as usize),
            Some(LightKind::Environment(_))
        )
    }

    /// Density with which [`Lights::sample`] would pick escaping direction `dir`.
    pub fn environment_pdf(&self, dir: Vec3) -> f32 {
        let Some(i) = self.env_index() else {
            return 0.0;
        };
        self.choice.pmf(i) * self.env_direction_pdf(dir)
    }

    fn env_direction_pdf(&self, dir: Vec3) -> f32 {
        match &self.env {
            // Constant part sampled uniformly, image part by importance: a one-sample mixture.
            Some(e) if self.constant.max_element() > 0.0 => 0.5 * (e.pdf(dir) + UNIFORM_SPHERE_PDF),
            Some(e) => e.pdf(dir),
            None => UNIFORM_SPHERE_PDF,
        }
    }

    /// Density (solid angle at `from`) of sampling the point `p` on emissive triangle
    /// `triangle` of instance `instance` (on the exact shape, for a sphere, disk or cylinder).
    pub fn triangle_pdf(&self, instance: u32, triangle: u32, from: Vec3, p: Vec3) -> f32 {
        let Some(Some(offset)) = self.instance_offset.get(instance as usize) else {
            return 0.0;
        };
        let index = (*offset + triangle) as usize;
        match self.lights.get(index) {
            Some(light) => light.pdf_from(self, self.choice.pmf(index), from, p),
            None => 0.0,
        }
    }

    /// The light [`Lights::sample`] picks for `u_choice`, with its probability, if it is an
    /// emissive triangle of constant radiance that can be picked: the lights the wavefront's
    /// vector bounce samples itself (it reads the radiance as one constant).
    #[inline(always)]
    pub(crate) fn choose_triangle(&self, u_choice: f32) -> Option<(f32, &EmissiveTriangle, u32)> {
        match self.choose(u_choice)? {
            (index, pick, LightKind::Triangle(tri)) if tri.texture == NO_TEXTURE => {
                Some((pick, tri, index as u32))
            }
            _ => None,
        }
    }

    /// The light [`Lights::sample`] picks for `u_choice` where [`Lights::choose_triangle`]
    /// gave no triangle, as the vector bounce sorts it: an exact shape (whose sphere cone the
    /// lanes sample, [`ShapeLight::sphere_lane`]), the constant environment (no image), or
    /// anything else, including nothing to pick ([`LaneLight::Other`], sampled on the scalar
    /// path). Asked only after `choose_triangle`, which stays the triangle lanes' whole
    /// choice: one match for every kind cost the Cornell box's light loop ~1 % of the render's
    /// instructions.
    #[inline(always)]
    pub(crate) fn choose_lane(&self, u_choice: f32) -> LaneLight<'_> {
        match self.choose(u_choice) {
            Some((_, pick, LightKind::Shape(shape))) => LaneLight::Shape(pick, shape),
            Some((_, pick, LightKind::Environment(_))) if self.env.is_none() => {
                LaneLight::Environment(pick)
            }
            _ => LaneLight::Other,
        }
    }

    /// The constant environment's radiance (zero without one): what
    /// [`Lights::environment`] gives in every direction where there is no image.
    pub(crate) fn constant_radiance(&self) -> Vec3 {
        self.constant
    }

    /// Light `light` if it is an emissive triangle of constant radiance (the lights that the
    /// lane loops sample themselves, as [`Lights::choose_triangle`] hands them out).
    pub(crate) fn untextured_triangle(&self, light: u32) -> Option<&EmissiveTriangle> {
        match self.lights.get(light as usize)? {
            LightKind::Triangle(tri) if tri.texture == NO_TEXTURE => Some(tri),
            _ => None,
        }
    }

    /// The probability with which [`Lights::sample_emission`] picks light `light`, the
    /// `pick` of [`Lights::emission_pdf_of`] (0 where no light emits particles).
    pub(crate) fn emission_pick(&self, light: u32) -> f32 {
        self.emission_choice
            .as_ref()
            .map_or(0.0, |c| c.pmf(light as usize))
    }

    /// The light chosen for `u_choice` in proportion to power, with its probability; `None`
    /// without lights or where the chosen one cannot be picked.
    #[inline(always)]
    fn choose(&self, u_choice: f32) -> Option<(usize, f32, &LightKind)> {
        if self.lights.is_empty() {
            return None;
        }
        let index = self.alias.sample(u_choice);
        let pick = self.choice.pmf(index);
        (pick > 0.0).then(|| (index, pick, &self.lights[index]))
    }

    /// Picks a light and a point on it as seen from `p`.
    pub fn sample(&self, p: Vec3, u_choice: f32, u: Vec2) -> Option<LightSample> {
        let (index, pick, light) = self.choose(u_choice)?;
        self.sample_chosen(index, pick, light, p, u)
    }

    /// A point on light `index` (picked with probability `pick`) as seen from `p`.
    #[inline(always)]
    fn sample_chosen(
        &self,
        index: usize,
        pick: f32,
        light: &LightKind,
        p: Vec3,
        u: Vec2,
    ) -> Option<LightSample> {
        let sample = light.sample_from(self, index as u32, pick, p, u)?;
        sample.weight.is_finite().then_some(sample)
    }

    /// The range of light `light` (a point or spot light with one, glTF's `range`): its
    /// particles' first segment is weighed by [`lumo_scene::range_window`] of that segment's
    /// length, which the integrators that trace particles apply where the segment ends
    /// (next-event estimation gets the window in the light sample's weight). `None` for every
    /// other light, whose particles are unchanged.
    #[inline]
    pub fn range(&self, light: u32) -> Option<f32> {
        match self.lights.get(light as usize)? {
            LightKind::Point(l) => l.range,
            LightKind::Spot(l) => l.range,
            _ => None,
        }
    }

    /// Radius of the scene's bounding sphere (for ray epsilons and distant-light power).
    pub fn scene_radius(&self) -> f32 {
        self.scene_radius
    }

    /// Centre of the scene's bounding sphere.
    pub fn scene_center(&self) -> Vec3 {
        self.scene_center
    }
}
