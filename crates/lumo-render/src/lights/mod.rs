//! Light sampling for next-event estimation: emissive triangles, point, spot, directional,
//! constant and image-based environment lights, chosen in proportion to an estimate of power.

pub mod distribution;
mod emission;
mod environment;
mod polygon;
mod split;

use std::f32::consts::PI;

use std::sync::Arc;

use glam::{Vec2, Vec3};
use lumo_image::luminance;
use lumo_scene::{Light, Material, Mesh, Scene, Texture};

use crate::accel::analytic::Shape;
use crate::geometry::{square_to_triangle, square_to_uniform_sphere, UNIFORM_SPHERE_PDF};
use crate::lights::distribution::{AliasTable, Distribution1d};
pub use emission::{EmissionPdf, EmissionSample};
use environment::EnvSampler;
pub use polygon::{triangle_cosine_integral, CosineTriangle};

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

enum LightKind {
    Triangle(EmissiveTriangle),
    /// An emissive exact sphere, disk or cylinder.
    Shape {
        shape: Shape,
        radiance: Vec3,
    },
    Point {
        position: Vec3,
        intensity: Vec3,
    },
    Spot {
        position: Vec3,
        axis: Vec3,
        intensity: Vec3,
        cone: SpotCone,
    },
    Directional {
        direction: Vec3,
        irradiance: Vec3,
    },
    Environment,
}

/// A spot light's cone: full intensity inside the beam, falling off linearly in angle to zero
/// at the cutoff, as Mitsuba 3's `spot` defines it (its `falloff_curve`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotCone {
    cos_beam: f32,
    cos_cutoff: f32,
    cutoff: f32,
    inv_transition: f32,
}

impl SpotCone {
    /// The cone of a spot with the given beam width and cutoff half-angles in degrees (a beam
    /// wider than the cutoff is clamped to it).
    pub fn new(beam_width_deg: f32, cutoff_deg: f32) -> Self {
        let cutoff = cutoff_deg.to_radians();
        let beam = beam_width_deg.min(cutoff_deg).to_radians();
        Self {
            cos_beam: beam.cos(),
            cos_cutoff: cutoff.cos(),
            cutoff,
            // A hard-edged spot (beam = cutoff) never reaches the transition branch.
            inv_transition: if cutoff > beam {
                1.0 / (cutoff - beam)
            } else {
                0.0
            },
        }
    }

    /// Cosine of the cutoff angle: nothing is emitted outside it.
    pub fn cos_cutoff(&self) -> f32 {
        self.cos_cutoff
    }

    /// The factor in [0, 1] applied to the intensity at `cos` from the axis.
    #[inline]
    pub fn falloff(&self, cos: f32) -> f32 {
        if cos <= self.cos_cutoff {
            0.0
        } else if cos >= self.cos_beam {
            1.0
        } else {
            ((self.cutoff - cos.clamp(-1.0, 1.0).acos()) * self.inv_transition).clamp(0.0, 1.0)
        }
    }

    /// ∫ falloff dω over the sphere: the emitted power over the intensity. With θ_b the beam
    /// and θ_c the cutoff angle, 2π (1 − (sin θ_c − sin θ_b) / (θ_c − θ_b)), or 2π (1 − cos θ_b)
    /// for a hard edge.
    pub fn solid_angle(&self) -> f32 {
        let beam = self.cos_beam.clamp(-1.0, 1.0).acos();
        if self.inv_transition == 0.0 {
            2.0 * PI * (1.0 - self.cos_beam)
        } else {
            2.0 * PI * (1.0 - (self.cutoff.sin() - beam.sin()) * self.inv_transition)
        }
    }
}

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

/// All lights of a scene with a power-proportional choice among them.
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
}

impl Lights {
    /// Collects the scene's lights. Emissive triangles come from materials with emission.
    pub fn new(scene: &Scene) -> Self {
        Self::build(scene, None)
    }

    /// Re-collects the lights after instances, vertices or punctual lights moved (a new pose of
    /// an animation). The environment's sampler and mean are kept rather than rebuilt from its
    /// image, so the scene's environment light must be the one this was built with; the result
    /// equals [`Lights::new`] of the changed scene.
    pub fn update(&mut self, scene: &Scene) {
        let env = self.env.take().map(|e| (e, self.env_mean));
        *self = Self::build(scene, env);
    }

    /// [`Lights::new`], reusing `reuse` (a sampler and its mean) for the environment image.
    fn build(scene: &Scene, mut reuse: Option<(EnvSampler, Vec3)>) -> Self {
        let (lo, hi) = scene.bounds();
        let scene_center = (lo + hi) * 0.5;
        let scene_radius = ((hi - lo).length() * 0.5).max(1e-3);
        let mut lights = Vec::new();
        let mut power = Vec::new();
        let mut instance_offset = vec![None; scene.instances.len()];
        let mut textured = Vec::new();
        let mut area_materials = Vec::new();
        for (ii, inst) in scene.instances.iter().enumerate() {
            let mesh = &scene.meshes[inst.mesh];
            let material = &scene.materials[mesh.material];
            if !material.is_emissive() {
                continue;
            }
            instance_offset[ii] = Some(lights.len() as u32);
            if let Some(a) = &mesh.analytic {
                let shape = Shape::new(a, inst.transform);
                power.push(if shape.area > 0.0 && shape.area.is_finite() {
                    shape.area * PI * luminance(material.emission.into())
                } else {
                    0.0
                });
                lights.push(LightKind::Shape {
                    shape,
                    radiance: material.emission,
                });
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
                // Degenerate triangles keep their slot (indices must line up) but get no power.
                power.push(if area > 0.0 {
                    area * PI * luminance(material.emission.into())
                } else {
                    0.0
                });
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
            match light {
                Light::Point {
                    position,
                    intensity,
                } => {
                    power.push(4.0 * PI * luminance((*intensity).into()));
                    lights.push(LightKind::Point {
                        position: *position,
                        intensity: *intensity,
                    });
                }
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    beam_width,
                    cutoff,
                } => {
                    let cone = SpotCone::new(*beam_width, *cutoff);
                    power.push(cone.solid_angle() * luminance((*intensity).into()));
                    lights.push(LightKind::Spot {
                        position: *position,
                        axis: direction.normalize(),
                        intensity: *intensity,
                        cone,
                    });
                }
                Light::Directional {
                    direction,
                    irradiance,
                } => {
                    power.push(disk * luminance((*irradiance).into()));
                    lights.push(LightKind::Directional {
                        direction: direction.normalize(),
                        irradiance: *irradiance,
                    });
                }
                Light::Constant { radiance } => constant += *radiance,
                // An empty image emits nothing (the loaders refuse one; a scene built in code
                // must not panic).
                Light::Environment(map) if map.image.width == 0 || map.image.height == 0 => {}
                Light::Environment(map) => {
                    env = Some(reuse.take().unwrap_or_else(|| {
                        let sampler = EnvSampler::new(map);
                        let m = map.image.to_channels(3).channel_means();
                        let mean = Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32) * map.scale;
                        (sampler, mean)
                    }))
                }
            }
        }
        let (env, env_mean) = match env {
            Some((e, mean)) => (Some(e), mean),
            None => (None, Vec3::ZERO),
        };
        // One entry samples the whole environment (constant and/or image).
        if env.is_some() || constant.max_element() > 0.0 {
            let mean = env_mean + constant;
            power.push(disk * PI * luminance(mean.into()));
            lights.push(LightKind::Environment);
        }
        let choice = Distribution1d::new(&power);
        let emits = |l: &LightKind| match l {
            LightKind::Triangle(tri) => tri.area > 0.0,
            LightKind::Shape { shape, .. } => shape.area > 0.0 && shape.area.is_finite(),
            LightKind::Environment => false,
            _ => true,
        };
        let emission_power: Vec<f32> = lights
            .iter()
            .zip(&power)
            .map(|(l, &w)| if emits(l) { w } else { 0.0 })
            .collect();
        // Only lights with power emit: with none (all black, or environment only) the light
        // tracer has nothing to start from, rather than a uniform choice of dark lights.
        let emission_choice = emission_power
            .iter()
            .any(|&w| w.is_finite() && w > 0.0)
            .then(|| Distribution1d::new(&emission_power));
        let is_delta = |l: &LightKind| {
            matches!(
                l,
                LightKind::Point { .. } | LightKind::Spot { .. } | LightKind::Directional { .. }
            )
        };
        let area_power: Vec<f32> = lights
            .iter()
            .zip(&power)
            .map(|(l, &w)| if is_delta(l) { 0.0 } else { w })
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
        matches!(self.lights.last(), Some(LightKind::Environment)).then(|| self.lights.len() - 1)
    }

    /// Whether light `light` (a [`LightSample::light`]) is the environment.
    pub fn is_environment(&self, light: u32) -> bool {
        matches!(
            self.lights.get(light as usize),
            Some(LightKind::Environment)
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
        let tri = match self.lights.get(index) {
            Some(LightKind::Triangle(tri)) => tri,
            Some(LightKind::Shape { shape, .. }) => {
                let n = shape.surface_at(p).n;
                return self.choice.pmf(index) * shape.pdf_direction(from, p, n);
            }
            _ => return 0.0,
        };
        let d = p - from;
        let dist2 = d.length_squared();
        let cos = tri.normal.dot(-d / dist2.sqrt()).abs();
        if cos <= 0.0 || tri.area <= 0.0 {
            return 0.0;
        }
        self.choice.pmf(index) * dist2 / (tri.area * cos)
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
        let light_index = index as u32;
        let sample = match light {
            LightKind::Triangle(tri) => {
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
                LightSample {
                    light: light_index,
                    normal: tri.normal,
                    wi,
                    distance,
                    point: q,
                    weight: triangle_radiance(&self.textured, tri.texture, tri.radiance, b)
                        * (den / num),
                    pdf: num / den,
                }
            }
            LightKind::Shape { shape, radiance } => {
                let (sp, pdf) = shape.sample_direction(p, u)?;
                let d = sp.p - p;
                let distance = d.length();
                let wi = d / distance;
                if sp.n.dot(-wi) <= 0.0 || distance <= 0.0 {
                    return None;
                }
                let pdf = pick * pdf;
                LightSample {
                    light: light_index,
                    normal: sp.n,
                    wi,
                    distance,
                    point: sp.p,
                    weight: *radiance / pdf,
                    pdf,
                }
            }
            LightKind::Point {
                position,
                intensity,
            } => {
                let d = *position - p;
                let dist2 = d.length_squared();
                let distance = dist2.sqrt();
                LightSample {
                    light: light_index,
                    normal: Vec3::ZERO,
                    wi: d / distance,
                    distance,
                    point: *position,
                    weight: *intensity / (dist2 * pick),
                    pdf: 0.0,
                }
            }
            LightKind::Spot {
                position,
                axis,
                intensity,
                cone,
            } => {
                let d = *position - p;
                let dist2 = d.length_squared();
                let distance = dist2.sqrt();
                let wi = d / distance;
                let falloff = cone.falloff(axis.dot(-wi));
                if falloff <= 0.0 {
                    return None;
                }
                LightSample {
                    light: light_index,
                    normal: Vec3::ZERO,
                    wi,
                    distance,
                    point: *position,
                    weight: *intensity * falloff / (dist2 * pick),
                    pdf: 0.0,
                }
            }
            LightKind::Directional {
                direction,
                irradiance,
            } => LightSample {
                light: light_index,
                normal: Vec3::ZERO,
                wi: -*direction,
                distance: f32::INFINITY,
                point: Vec3::ZERO,
                weight: *irradiance / pick,
                pdf: 0.0,
            },
            LightKind::Environment => {
                let (wi, _) = match (&self.env, self.constant.max_element() > 0.0) {
                    (Some(e), true) => {
                        // Split the 2-D point: first coordinate decides the mixture component.
                        if u.x < 0.5 {
                            e.sample(Vec2::new(u.x * 2.0, u.y))
                        } else {
                            (
                                square_to_uniform_sphere(Vec2::new(u.x * 2.0 - 1.0, u.y)),
                                0.0,
                            )
                        }
                    }
                    (Some(e), false) => e.sample(u),
                    (None, _) => (square_to_uniform_sphere(u), 0.0),
                };
                let pdf = pick * self.env_direction_pdf(wi);
                if pdf <= 0.0 {
                    return None;
                }
                LightSample {
                    light: light_index,
                    normal: Vec3::ZERO,
                    wi,
                    distance: f32::INFINITY,
                    point: Vec3::ZERO,
                    weight: self.environment(wi) / pdf,
                    pdf,
                }
            }
        };
        sample.weight.is_finite().then_some(sample)
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
