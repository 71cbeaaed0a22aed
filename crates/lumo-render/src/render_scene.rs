//! A scene prepared for rendering: acceleration structure, light sampler and per-material
//! constants, plus the surface-interaction reconstruction every integrator needs.

use glam::{Mat3, Mat4, Vec2, Vec3};
use lumo_scene::{Bsdf as SceneBsdf, Scene, SceneError, Texture};

use crate::accel::{Accel, Hit};
use crate::analytic::Shape;
use crate::bsdf::{fresnel_diffuse_reflectance, Bsdf, Microfacet, RoughCoat, SMOOTH_ALPHA};
use crate::geometry::Frame;
use crate::lights::Lights;
use crate::shading::ShadingBsdf;

/// Everything known about a ray's hit point.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    /// World position.
    pub p: Vec3,
    /// Unit geometric normal (from the winding).
    pub ng: Vec3,
    /// Shading frame (interpolated normal, on the same side as `ng`).
    pub frame: Frame,
    /// Texture coordinates.
    pub uv: Vec2,
    /// Interpolated vertex colour (white for meshes without colours); multiplies the diffuse
    /// reflectance.
    pub color: Vec3,
    /// Material index.
    pub material: usize,
    /// Instance and triangle hit, for light-pdf lookups.
    pub instance: u32,
    /// Triangle index within the mesh.
    pub triangle: u32,
}

/// An instance's transform in the forms [`RenderScene::surface`] uses.
#[derive(Clone, Copy, Debug)]
struct InstancePlacement {
    /// The transform is the identity (object space is world space): skip all matrix work.
    identity: bool,
    /// Object → world for points.
    to_world: Mat4,
    /// Object → world for normals (inverse transpose of the linear part).
    normal_to_world: Mat3,
    /// The instance is an exact sphere, disk or cylinder (its shape in
    /// [`RenderScene::shapes`]).
    analytic: bool,
}

/// A scene with its acceleration structure and light sampler.
pub struct RenderScene {
    /// The scene description.
    pub scene: Scene,
    /// Ray queries.
    pub accel: Accel,
    /// Light sampling.
    pub lights: Lights,
    /// Internal diffuse reflectance of the coat per material (plastics only; 0 otherwise).
    fdr_int: Vec<f32>,
    /// Per material, Mitsuba's tabulated rough coat (rough plastics from Mitsuba scenes).
    coats: Vec<Option<&'static RoughCoat>>,
    /// Per material, whether its roughness is anisotropic: only then does the shading
    /// frame's tangent matter, and only then is it built from ∂p/∂u as Mitsuba's is.
    anisotropic: Vec<bool>,
    /// Per material, whether its back side is black (an opaque BSDF that is not two-sided:
    /// Mitsuba's plain BSDFs).
    one_sided: Vec<bool>,
    /// Per material, whether the BSDF under its adapters is black from behind (as
    /// `one_sided`, but also under a mask, whose straight-through lobe still lets light pass).
    back_black: Vec<bool>,
    /// Per instance, what surface reconstruction needs of its transform, computed once
    /// rather than per hit.
    placements: Vec<InstancePlacement>,
    /// Per instance, its exact shape if its mesh is analytic.
    shapes: Vec<Option<Shape>>,
    /// Per mesh, each triangle's unit geometric normal in object space (zero if degenerate):
    /// identity instances read it instead of re-deriving it with a cross product, square
    /// root and division per hit (~3 % of render time).
    unit_normals: Vec<Vec<Vec3>>,
    /// Offset applied to ray origins to escape the surface they leave.
    pub ray_epsilon: f32,
    /// Per instance, its reflectance and emission if it is a diffuse surface in world space
    /// (identity transform, no vertex colours, constant reflectance):
    /// the case the wavefront's vector bounce ([`crate::simd_bounce`]) handles.
    simple_diffuse: Vec<Option<SimpleDiffuse>>,
}

/// A constant-reflectance diffuse instance in world space.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct SimpleDiffuse {
    /// Mesh index (for its unit normals).
    pub mesh: usize,
    /// Diffuse reflectance.
    pub albedo: Vec3,
    /// Emitted radiance (front side).
    pub emission: Vec3,
    /// Black from behind (see [`RenderScene::one_sided`]).
    pub one_sided: bool,
}

impl RenderScene {
    /// Validates the scene and builds the acceleration structure and light sampler.
    pub fn new(scene: Scene) -> Result<Self, SceneError> {
        scene.validate()?;
        let accel = Accel::build(&scene);
        let lights = Lights::new(&scene);
        let coats: Vec<Option<&'static RoughCoat>> = scene
            .materials
            .iter()
            .map(|m| match innermost(&m.bsdf) {
                SceneBsdf::Plastic {
                    ior,
                    roughness,
                    exact_rough_coat: true,
                    ..
                } => {
                    let mf = microfacet(roughness, None);
                    (mf.max_alpha() >= SMOOTH_ALPHA).then(|| RoughCoat::shared(mf, *ior))
                }
                _ => None,
            })
            .collect();
        let fdr_int = scene
            .materials
            .iter()
            .zip(&coats)
            .map(|(m, coat)| match (innermost(&m.bsdf), coat) {
                (SceneBsdf::Plastic { .. }, Some(c)) => c.internal_reflectance,
                (SceneBsdf::Plastic { ior, .. }, None) => fresnel_diffuse_reflectance(1.0 / ior),
                _ => 0.0,
            })
            .collect();
        let anisotropic = scene
            .materials
            .iter()
            .map(|m| match innermost(&m.bsdf) {
                SceneBsdf::Conductor { roughness, .. }
                | SceneBsdf::Plastic { roughness, .. }
                | SceneBsdf::Dielectric { roughness, .. } => roughness.is_anisotropic(),
                _ => false,
            })
            .collect();
        let back_black: Vec<bool> = scene
            .materials
            .iter()
            .map(|m| {
                !m.two_sided
                    && !matches!(
                        innermost(&m.bsdf),
                        SceneBsdf::Dielectric { .. } | SceneBsdf::ThinDielectric { .. }
                    )
            })
            .collect();
        let one_sided = scene
            .materials
            .iter()
            .zip(&back_black)
            .map(|(m, &black)| black && !has_mask(&m.bsdf))
            .collect();
        let placements = scene
            .instances
            .iter()
            .map(|inst| InstancePlacement {
                identity: inst.transform == Mat4::IDENTITY,
                to_world: inst.transform,
                normal_to_world: Mat3::from_mat4(inst.transform).inverse().transpose(),
                analytic: scene.meshes[inst.mesh].analytic.is_some(),
            })
            .collect();
        let shapes = scene
            .instances
            .iter()
            .map(|inst| {
                let a = scene.meshes[inst.mesh].analytic.as_ref()?;
                Some(Shape::new(a, inst.transform))
            })
            .collect();
        let unit_normals = scene
            .meshes
            .iter()
            .map(|m| {
                m.indices
                    .iter()
                    .map(|t| {
                        let [a, b, c] = t.map(|i| m.positions[i as usize]);
                        (b - a).cross(c - a).normalize_or_zero()
                    })
                    .collect()
            })
            .collect();
        let simple_diffuse = scene
            .instances
            .iter()
            .map(|inst| {
                let mesh = &scene.meshes[inst.mesh];
                let material = &scene.materials[mesh.material];
                match &material.bsdf {
                    SceneBsdf::Diffuse {
                        reflectance: Texture::Constant(albedo),
                    } if inst.transform == Mat4::IDENTITY
                        && mesh.analytic.is_none()
                        && albedo.is_finite()
                        && mesh.colors.is_empty()
                        && material.emission_map.is_none() =>
                    {
                        Some(SimpleDiffuse {
                            mesh: inst.mesh,
                            albedo: *albedo,
                            emission: material.emission,
                            one_sided: !material.two_sided,
                        })
                    }
                    _ => None,
                }
            })
            .collect();
        Ok(Self {
            simple_diffuse,
            // Relative to the coordinate magnitude (see `offset`): float error in the hit
            // point grows with it.
            ray_epsilon: 1e-4,
            scene,
            accel,
            lights,
            fdr_int,
            coats,
            anisotropic,
            one_sided,
            back_black,
            placements,
            shapes,
            unit_normals,
        })
    }

    /// The instance's reflectance and emission if it is a simple diffuse surface (see the
    /// field's doc), for the vector bounce.
    #[inline]
    pub(crate) fn simple_diffuse(&self, instance: u32) -> Option<SimpleDiffuse> {
        self.simple_diffuse[instance as usize]
    }

    /// Unit geometric normal of triangle `triangle` of mesh `mesh`, in object space.
    #[inline]
    pub(crate) fn unit_normal(&self, mesh: usize, triangle: u32) -> Vec3 {
        self.unit_normals[mesh][triangle as usize]
    }

    /// Reconstructs the surface at `hit` of the ray with direction `dir`.
    #[inline]
    pub fn surface(&self, hit: &Hit, origin: Vec3, dir: Vec3) -> Surface {
        let inst = &self.scene.instances[hit.instance as usize];
        let place = &self.placements[hit.instance as usize];
        if place.analytic {
            return self.analytic_surface(hit, origin, dir);
        }
        let mesh = &self.scene.meshes[inst.mesh];
        let [i0, i1, i2] = mesh.indices[hit.triangle as usize].map(|i| i as usize);
        let (u, v) = (hit.u, hit.v);
        let w = 1.0 - u - v;
        let ng = if place.identity {
            self.unit_normals[inst.mesh][hit.triangle as usize]
        } else {
            // From the transformed corners, so a mirroring transform keeps the winding rule.
            let [a, b, c] =
                [i0, i1, i2].map(|i| place.to_world.transform_point3(mesh.positions[i]));
            (b - a).cross(c - a).normalize_or_zero()
        };
        let p = origin + dir * hit.t;
        let mut ns = if mesh.normals.is_empty() {
            // Flat shading (every built-in scene): the geometric normal is already unit.
            ng
        } else {
            let n = mesh.normals[i0] * w + mesh.normals[i1] * u + mesh.normals[i2] * v;
            let n = if place.identity {
                n
            } else {
                place.normal_to_world * n
            };
            let n = n.normalize_or_zero();
            if n == Vec3::ZERO || !n.is_finite() {
                ng
            } else {
                n
            }
        };
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        let uv = if mesh.uvs.is_empty() {
            Vec2::new(u, v)
        } else {
            mesh.uvs[i0] * w + mesh.uvs[i1] * u + mesh.uvs[i2] * v
        };
        let color = if mesh.colors.is_empty() {
            Vec3::ONE
        } else {
            mesh.colors[i0] * w + mesh.colors[i1] * u + mesh.colors[i2] * v
        };
        let mut surface = Surface {
            p,
            ng,
            frame: Frame::new(ns),
            uv,
            color,
            material: mesh.material,
            instance: hit.instance,
            triangle: hit.triangle,
        };
        if self.anisotropic[mesh.material] {
            surface.frame = self.tangent_frame(&surface);
        }
        surface
    }

    /// The surface of an exact shape at `hit`: the hit point re-projected onto it, the
    /// shape's normal as both geometric and shading normal, Mitsuba's uv.
    #[cold]
    fn analytic_surface(&self, hit: &Hit, origin: Vec3, dir: Vec3) -> Surface {
        let inst = &self.scene.instances[hit.instance as usize];
        let material = self.scene.meshes[inst.mesh].material;
        let Some(shape) = &self.shapes[hit.instance as usize] else {
            unreachable!("analytic placement without a shape");
        };
        let sp = shape.surface_at(origin + dir * hit.t);
        let mut surface = Surface {
            p: sp.p,
            ng: sp.n,
            frame: Frame::new(sp.n),
            uv: sp.uv,
            color: Vec3::ONE,
            material,
            instance: hit.instance,
            triangle: 0,
        };
        if self.anisotropic[material] {
            surface.frame = self.tangent_frame(&surface);
        }
        surface
    }

    /// The exact shape of instance `instance`, if it is one.
    #[inline]
    pub(crate) fn shape(&self, instance: u32) -> Option<&Shape> {
        self.shapes.get(instance as usize)?.as_ref()
    }

    /// Mitsuba's shading frame at `s`: the tangent is ∂p/∂u made perpendicular to the normal
    /// and the bitangent n × tangent, which orients anisotropic roughness (α_u along ∂p/∂u).
    /// Falls back to the normal-only frame where the uv map is degenerate.
    fn tangent_frame(&self, s: &Surface) -> Frame {
        let n = s.frame.n;
        match self
            .dp_duv(s)
            .and_then(|(dp_du, _)| (dp_du - n * n.dot(dp_du)).try_normalize())
        {
            Some(t) => Frame {
                s: t,
                t: n.cross(t),
                n,
            },
            None => s.frame,
        }
    }

    /// The BSDF of `surface` with textures evaluated and Mitsuba's adapters (normal and bump
    /// maps, masks) applied.
    #[inline]
    pub fn bsdf(&self, surface: &Surface) -> ShadingBsdf {
        let material = &self.scene.materials[surface.material];
        let mut b = &material.bsdf;
        if !is_adapter(b) {
            return self.base_bsdf(b, surface).into();
        }
        let (mut normal, mut opacity) = (None, 1.0f32);
        // Adapters nest; masks multiply, and the outermost normal or bump map shapes the frame
        // (a map under another map is not composed with it).
        loop {
            b = match b {
                SceneBsdf::Mask { opacity: t, nested } => {
                    opacity *= t.eval_1(surface.uv).clamp(0.0, 1.0);
                    nested
                }
                SceneBsdf::NormalMap { normals, nested } => {
                    if normal.is_none() {
                        normal = Some(self.normal_mapped(surface, normals));
                    }
                    nested
                }
                SceneBsdf::BumpMap {
                    height,
                    scale,
                    nested,
                } => {
                    if normal.is_none() {
                        normal = Some(self.bump_mapped(surface, height, *scale));
                    }
                    nested
                }
                _ => break,
            };
        }
        ShadingBsdf::new(
            self.base_bsdf(b, surface),
            normal.flatten(),
            opacity,
            self.back_black[surface.material],
        )
    }

    /// World-space ∂p/∂u and ∂p/∂v of the triangle under `s` from its texture coordinates (as
    /// Mitsuba's meshes; lumo's barycentric uv where the mesh has none); `None` where the uv
    /// map is degenerate.
    fn dp_duv(&self, s: &Surface) -> Option<(Vec3, Vec3)> {
        if let Some(shape) = self.shape(s.instance) {
            let sp = shape.surface_at(s.p);
            return Some((sp.dp_du, sp.dp_dv));
        }
        let inst = &self.scene.instances[s.instance as usize];
        let place = &self.placements[s.instance as usize];
        let mesh = &self.scene.meshes[inst.mesh];
        let idx = mesh.indices[s.triangle as usize].map(|i| i as usize);
        let [p0, p1, p2] = idx.map(|i| mesh.positions[i]);
        let (dp0, dp1) = (p1 - p0, p2 - p0);
        let [t0, t1, t2] = mesh.triangle_uvs(s.triangle as usize);
        let (duv0, duv1) = (t1 - t0, t2 - t0);
        let det = duv0.x * duv1.y - duv0.y * duv1.x;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let dp_du = (dp0 * duv1.y - dp1 * duv0.y) / det;
        let dp_dv = (dp1 * duv0.x - dp0 * duv1.x) / det;
        Some(if place.identity {
            (dp_du, dp_dv)
        } else {
            (
                place.to_world.transform_vector3(dp_du),
                place.to_world.transform_vector3(dp_dv),
            )
        })
    }

    /// The shading normal a tangent-space normal map gives `s`, in its shading frame: the
    /// map's RGB in [0, 1] is (x, y, z) in [-1, 1] along the tangent (∂p/∂u made
    /// perpendicular to the normal), the bitangent n × tangent and the normal, as Mitsuba 3
    /// reads it. `None` for an exactly flat texel (no perturbation).
    fn normal_mapped(&self, s: &Surface, normals: &Texture) -> Option<Vec3> {
        let c = normals.eval(s.uv) * 2.0 - Vec3::ONE;
        if c.x == 0.0 && c.y == 0.0 {
            return None;
        }
        let n = s.frame.n;
        let tangent = self
            .dp_duv(s)
            .and_then(|(dp_du, _)| (dp_du - n * n.dot(dp_du)).try_normalize())
            .unwrap_or(s.frame.s);
        let bitangent = n.cross(tangent);
        let world = (tangent * c.x + bitangent * c.y + n * c.z).try_normalize()?;
        s.frame.to_local(world).try_normalize()
    }

    /// The shading normal a height texture gives `s`, in its shading frame: the surface moved
    /// along its normal by `scale`·height, differentiated along u and v (Mitsuba 3's
    /// `bumpmap`), turned to the side of the geometric normal. `None` where the height is
    /// flat.
    fn bump_mapped(&self, s: &Surface, height: &Texture, scale: f32) -> Option<Vec3> {
        let grad = height.eval_1_grad(s.uv) * scale;
        if grad == Vec2::ZERO {
            return None;
        }
        let (dp_du, dp_dv) = self.dp_duv(s)?;
        let n = s.frame.n;
        let du = dp_du + n * (grad.x - n.dot(dp_du));
        let dv = dp_dv + n * (grad.y - n.dot(dp_dv));
        let mut bumped = du.cross(dv).try_normalize()?;
        if bumped.dot(s.ng) < 0.0 {
            bumped = -bumped;
        }
        s.frame.to_local(bumped).try_normalize()
    }

    /// A scene BSDF without its adapters, with textures evaluated at `surface`.
    #[inline]
    fn base_bsdf(&self, bsdf: &SceneBsdf, surface: &Surface) -> Bsdf {
        match bsdf {
            SceneBsdf::Diffuse { reflectance } => Bsdf::Diffuse {
                albedo: texture(reflectance, surface.uv) * surface.color,
            },
            SceneBsdf::Mirror { reflectance } => Bsdf::Mirror {
                reflectance: *reflectance,
            },
            SceneBsdf::Conductor { eta, k, roughness } => Bsdf::Conductor {
                eta: *eta,
                k: *k,
                mf: microfacet(roughness, Some(surface.uv)),
            },
            SceneBsdf::Plastic {
                diffuse,
                ior,
                roughness,
                nonlinear,
                ..
            } => Bsdf::Plastic {
                diffuse: texture(diffuse, surface.uv) * surface.color,
                eta: *ior,
                mf: microfacet(roughness, Some(surface.uv)),
                fdr_int: self.fdr_int[surface.material],
                coat: self.coats[surface.material],
                nonlinear: *nonlinear,
            },
            SceneBsdf::Dielectric { ior, roughness } => Bsdf::Dielectric {
                eta: *ior,
                mf: microfacet(roughness, Some(surface.uv)),
            },
            SceneBsdf::ThinDielectric { ior } => Bsdf::ThinDielectric { eta: *ior },
            // Adapters are unwrapped by `bsdf`; one reached here (nested in a way it does not
            // unwrap) stands for the BSDF it wraps.
            SceneBsdf::NormalMap { nested, .. }
            | SceneBsdf::BumpMap { nested, .. }
            | SceneBsdf::Mask { nested, .. } => self.base_bsdf(nested, surface),
        }
    }

    /// Whether material `material` is black from behind: a path that reaches its back side
    /// (the viewer below the shading normal) ends there, as with Mitsuba's one-sided BSDFs.
    #[inline]
    pub fn one_sided(&self, material: usize) -> bool {
        self.one_sided[material]
    }

    /// Radiance emitted by `surface` towards `-dir` (front side only).
    #[inline]
    pub fn emission(&self, surface: &Surface, dir: Vec3) -> Vec3 {
        let m = &self.scene.materials[surface.material];
        if surface.ng.dot(dir) >= 0.0 {
            Vec3::ZERO
        } else if let Some(map) = &m.emission_map {
            map.eval(surface.uv)
        } else {
            m.emission
        }
    }

    /// A ray origin just off the surface on the side of direction `d`.
    #[inline]
    pub fn offset(&self, s: &Surface, d: Vec3) -> Vec3 {
        let side = if s.ng.dot(d) >= 0.0 { 1.0 } else { -1.0 };
        s.p + s.ng * (side * self.ray_epsilon * (1.0 + s.p.abs().max_element()))
    }
}

/// The render-side distribution of a scene roughness. Like Mitsuba, a rough surface keeps
/// α ≥ 1e-4 on each axis (one axis at 0 would divide by zero); negative or NaN α is smooth.
/// A per-texel α is read at `uv` (`None`: its average, for what is set up once per material).
fn microfacet(r: &lumo_scene::Roughness, uv: Option<glam::Vec2>) -> Microfacet {
    let clean = |a: f32| if a.is_finite() { a.max(0.0) } else { 0.0 };
    let (au, av) = match uv {
        Some(uv) => r.alpha_at(uv),
        None => (r.alpha_u, r.alpha_v),
    };
    let (mut au, mut av) = (clean(au), clean(av));
    if au.max(av) >= SMOOTH_ALPHA {
        (au, av) = (au.max(1e-4), av.max(1e-4));
    }
    Microfacet {
        distribution: r.distribution,
        alpha_u: au,
        alpha_v: av,
    }
}

/// The BSDF under a material's adapters (normal and bump maps, masks).
fn innermost(mut b: &SceneBsdf) -> &SceneBsdf {
    while let Some(nested) = adapted(b) {
        b = nested;
    }
    b
}

/// The BSDF an adapter wraps (`None` for a plain BSDF).
fn adapted(b: &SceneBsdf) -> Option<&SceneBsdf> {
    match b {
        SceneBsdf::NormalMap { nested, .. }
        | SceneBsdf::BumpMap { nested, .. }
        | SceneBsdf::Mask { nested, .. } => Some(nested),
        _ => None,
    }
}

/// Whether `b` is an adapter.
#[inline]
fn is_adapter(b: &SceneBsdf) -> bool {
    adapted(b).is_some()
}

/// Whether a mask is among the adapters of `b`.
fn has_mask(mut b: &SceneBsdf) -> bool {
    loop {
        match b {
            SceneBsdf::Mask { .. } => return true,
            _ => match adapted(b) {
                Some(nested) => b = nested,
                None => return false,
            },
        }
    }
}

/// `t` at `uv`, with the constant case (most materials) inline rather than a call into the
/// scene crate.
#[inline]
fn texture(t: &Texture, uv: Vec2) -> Vec3 {
    match t {
        Texture::Constant(c) => *c,
        _ => t.eval(uv),
    }
}
