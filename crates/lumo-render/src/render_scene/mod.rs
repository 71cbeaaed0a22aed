//! A scene prepared for rendering: acceleration structure, light sampler and per-material
//! constants, plus the surface-interaction reconstruction every integrator needs.

mod branches;
mod footprint;
mod materials;
mod spectral;
mod vertex_data;

use materials::has_mask;

use glam::{Mat3, Mat4, Vec2, Vec3};
use lumo_scene::{AnimatedScene, BsdfSpec, Mesh, Roughness, Scene, SceneError, Texture};

use crate::accel::analytic::Shape;
use crate::accel::{Accel, AccelUpdate, Hit};
use crate::bsdf::{texture, Prepared};
use crate::geometry::offset_point;
use crate::geometry::Basis;
use crate::lights::Lights;

/// Everything known about a ray's hit point.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    /// World position.
    pub p: Vec3,
    /// Unit geometric normal (from the winding).
    pub ng: Vec3,
    /// Shading frame (interpolated normal, on the same side as `ng`).
    pub frame: Basis,
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
    /// The ray arrived on the back side (against `ng`): what a `twosided` material with two
    /// BSDFs shades with its back one (the simple-diffuse lane loops, whose materials have
    /// one BSDF, leave it false).
    pub back: bool,
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
    /// Per material, what its BSDF set up once (a plastic's coat tables).
    prepared: Vec<Prepared>,
    /// Per material, whether its roughness is anisotropic: only then does the shading
    /// frame's tangent matter, and only then is it built from ∂p/∂u as Mitsuba's is.
    anisotropic: Vec<bool>,
    /// Per material, whether its back side is black (an opaque BSDF that is not two-sided:
    /// Mitsuba's plain BSDFs).
    one_sided: Vec<bool>,
    /// Per scene material, whether nothing of it reads the texture coordinates (a constant
    /// diffuse reflectance, no emission texture, no adapter): an exact shape's hit then skips
    /// its uv in [`RenderScene::shading_surface`], an `atan2` and an `acos` no one reads. Set once, as `finite_textures`: the
    /// viewer's edits only make colours constant, and a material that still computes its uv
    /// renders the same.
    ignores_uv: Vec<bool>,
    /// Per material, whether the BSDF under its adapters is black from behind (as
    /// `one_sided`, but also under a mask, whose straight-through lobe still lets light pass).
    back_black: Vec<bool>,
    /// The branches of two-branch materials (`twosided` with two BSDFs, `blendbsdf`) as
    /// materials of their own, indexed after the scene's ([`branches`]).
    branch_materials: Vec<lumo_scene::Material>,
    /// Per material (the scene's, then the branch materials), its two branches if it has them.
    branches: Vec<Option<branches::Branches>>,
    /// Whether any material has branches (else [`RenderScene::bsdf`] skips the lookup).
    has_branches: bool,
    /// Whether any material has an opacity mask: only then do shadow rays look through
    /// what blocks them ([`crate::integrators::path::mask_shadow`]).
    has_masks: bool,
    /// Per instance, what surface reconstruction needs of its transform, computed once
    /// rather than per hit.
    placements: Vec<InstancePlacement>,
    /// Per instance, its exact shape if its mesh is analytic.
    shapes: Vec<Option<Shape>>,
    /// Per mesh, each triangle's unit geometric normal in object space (zero if degenerate):
    /// identity instances read it instead of re-deriving it with a cross product, square
    /// root and division per hit (~3 % of render time).
    unit_normals: Vec<Vec<Vec3>>,
    /// Per mesh, the bounding box of its positions in object space: each pose checks how far
    /// its instances reach ([`lumo_scene::COORDINATE_LIMIT`]) without a pass over every vertex.
    mesh_boxes: Vec<Option<(Vec3, Vec3)>>,
    /// Whether the meshes are too big to stay in the cache between hits, so that the
    /// wavefront prefetches what [`Self::surface`] reads ([`Self::prefetch_indices`]).
    prefetch_surfaces: bool,
    /// Offset applied to ray origins to escape the surface they leave.
    pub ray_epsilon: f32,
    /// Per instance, its reflectance and emission if it is a diffuse surface in world space
    /// (identity transform, no vertex colours, a reflectance whose every value is finite):
    /// the case the wavefront's vector bounce ([`crate::integrators::path::vector_bounce`]) handles.
    simple_diffuse: Vec<Option<SimpleDiffuse>>,
    /// Whether some simple diffuse instance is textured (else the vector bounce skips its
    /// texture pass).
    textured_simple: bool,
    /// Per diffuse material, whether its reflectance texture has only finite values: bitmaps
    /// are scanned once here rather than on every [`RenderScene::update`] (an update keeps
    /// the materials' textures; an edit only sets constant colours, which are checked where
    /// used).
    finite_textures: Vec<bool>,
    /// Per material (the scene's, then the branch materials), whether it reads a mip-mapped
    /// texture, so that only those hits pay for a footprint ([`footprint`]).
    reads_footprint: Vec<bool>,
    /// How wide one camera sample is, for mip-mapped lookups ([`RenderScene::set_texture_footprint`]).
    sample_spread: footprint::SampleSpread,
    /// Spectral constants of the materials, fitted on the first spectral lookup.
    spectral: std::sync::OnceLock<spectral::SpectralCache>,
    /// What the scene looked like when built, to tell an update apart from a new scene.
    structure: Structure,
}

/// A diffuse instance in world space whose reflectance is finite everywhere.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct SimpleDiffuse {
    /// Mesh index (for its unit normals).
    pub mesh: usize,
    /// Diffuse reflectance where it is constant (unused if `textured`).
    pub albedo: Vec3,
    /// Whether the reflectance is a texture, looked up per hit ([`RenderScene::simple_albedo`]).
    pub textured: bool,
    /// Emitted radiance (front side).
    pub emission: Vec3,
    /// Black from behind (see [`RenderScene::one_sided`]).
    pub one_sided: bool,
}

/// Per-instance tables of [`RenderScene`] that depend on the instance transforms: what
/// surface reconstruction needs of each transform, the exact shapes, and the simple diffuse
/// instances. One function for [`RenderScene::new`] and [`RenderScene::update`], so an updated
/// scene holds exactly what a fresh one would.
type InstanceTables = (
    Vec<InstancePlacement>,
    Vec<Option<Shape>>,
    Vec<Option<SimpleDiffuse>>,
);

fn instance_tables(scene: &Scene, finite_textures: &[bool]) -> InstanceTables {
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
    let simple_diffuse = scene
        .instances
        .iter()
        .map(|inst| {
            let mesh = &scene.meshes[inst.mesh];
            let material = &scene.materials[mesh.material];
            let BsdfSpec::Diffuse { reflectance } = &material.bsdf else {
                return None;
            };
            // A non-finite reflectance would make the vector bounce's selects and the scalar
            // path's branches disagree; such surfaces take the scalar path.
            let finite = match reflectance {
                Texture::Constant(c) => c.is_finite(),
                _ => finite_textures.get(mesh.material).copied().unwrap_or(false),
            };
            // A mip-mapped reflectance is read over a footprint, which the vector bounce
            // does not compute.
            (inst.transform == Mat4::IDENTITY
                && mesh.analytic.is_none()
                && finite
                && !reflectance.uses_footprint()
                && mesh.colors.is_empty()
                && material.emission_map.is_none())
            .then_some(SimpleDiffuse {
                mesh: inst.mesh,
                albedo: match reflectance {
                    Texture::Constant(c) => *c,
                    _ => Vec3::ZERO,
                },
                textured: !matches!(reflectance, Texture::Constant(_)),
                emission: material.emission,
                one_sided: !material.two_sided,
            })
        })
        .collect();
    (placements, shapes, simple_diffuse)
}

/// The texture coordinates at barycentrics (u, v), w = 1 − u − v, of triangle `corners` of
/// `mesh`: its vertex uvs interpolated, or (u, v) itself where it has none.
#[inline(always)]
fn corner_uv(mesh: &Mesh, [i0, i1, i2]: [usize; 3], u: f32, v: f32, w: f32) -> Vec2 {
    if mesh.uvs.is_empty() {
        Vec2::new(u, v)
    } else {
        mesh.uvs[i0] * w + mesh.uvs[i1] * u + mesh.uvs[i2] * v
    }
}

/// Whether some simple diffuse instance has a textured reflectance.
fn any_textured(simple: &[Option<SimpleDiffuse>]) -> bool {
    simple.iter().flatten().any(|s| s.textured)
}

/// Whether every value `t` can take is finite (a bitmap's texels are all scanned).
fn texture_is_finite(t: &Texture) -> bool {
    match t {
        Texture::Constant(c) => c.is_finite(),
        Texture::Checkerboard {
            color0,
            color1,
            scale,
        } => color0.is_finite() && color1.is_finite() && scale.is_finite(),
        Texture::Bitmap {
            image, uv_scale, ..
        } => uv_scale.is_finite() && image.non_finite_count() == 0,
        Texture::Mipmapped { mips, .. } => mips.levels()[0].non_finite_count() == 0,
        Texture::Transformed { texture, uv } => uv.is_finite() && texture_is_finite(texture),
    }
}

/// Each triangle's unit geometric normal in object space (zero if degenerate).
fn unit_normals(m: &Mesh) -> Vec<Vec3> {
    m.indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            (b - a).cross(c - a).normalize_or_zero()
        })
        .collect()
}

/// The parts of a scene that [`RenderScene::update`] cannot change in place: how many meshes,
/// vertices, triangles and instances there are, which mesh each instance places, whether it
/// is an exact shape, and the materials.
#[derive(Clone, Debug, PartialEq)]
struct Structure {
    meshes: Vec<(usize, usize, usize, bool)>,
    instances: Vec<usize>,
    materials: usize,
}

impl Structure {
    fn of(scene: &Scene) -> Self {
        Structure {
            meshes: scene
                .meshes
                .iter()
                .map(|m| {
                    (
                        m.positions.len(),
                        m.indices.len(),
                        m.material,
                        m.analytic.is_some(),
                    )
                })
                .collect(),
            instances: scene.instances.iter().map(|i| i.mesh).collect(),
            materials: scene.materials.len(),
        }
    }
}

/// How [`RenderScene::update`] brought a render scene up to date.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneUpdate {
    /// The BVH was refitted (moved vertices) and its instances re-placed (moved
    /// instances); lights and per-instance tables recomputed.
    Refitted,
    /// The BVH had to be rebuilt (an instance joined or left the identity transform, which
    /// changes the merged BVH of identity instances; see [`crate::accel::AccelUpdate`]).
    RebuiltAccel,
    /// Everything was rebuilt as by [`RenderScene::new`]: meshes, instances or materials
    /// changed in number or kind.
    Rebuilt,
}

impl RenderScene {
    /// Validates the scene and builds the acceleration structure and light sampler.
    pub fn new(scene: Scene) -> Result<Self, SceneError> {
        scene.validate()?;
        let accel = Accel::build(&scene);
        let lights = Lights::new(&scene);
        let (branch_materials, branches) = branches::branch_materials(&scene.materials);
        // The per-material tables cover the branch materials too (they follow the scene's).
        let all = || scene.materials.iter().chain(branch_materials.iter());
        // Per material, what its BSDF sets up once (a plastic's coat).
        let prepared = all().map(|m| Prepared::of(&m.bsdf)).collect();
        let mut anisotropic: Vec<bool> = all()
            .map(|m| {
                m.bsdf.roughness().is_some_and(Roughness::is_anisotropic)
                    || matches!(m.bsdf.innermost(), BsdfSpec::Principled(p) if p.is_anisotropic())
            })
            .collect();
        // A two-branch material's frame must serve either branch (children follow their
        // parents in the list, so a reverse pass sees them first).
        for i in (0..branches.len()).rev() {
            if let Some(b) = &branches[i] {
                anisotropic[i] = anisotropic[b.first] || anisotropic[b.second];
            }
        }
        let back_black: Vec<bool> = all().map(|m| !m.two_sided && !m.bsdf.transmits()).collect();
        let has_masks = all().any(|m| has_mask(&m.bsdf));
        let one_sided = all()
            .zip(&back_black)
            .map(|(m, &black)| black && !has_mask(&m.bsdf))
            .collect();
        // A two-branch material is black from behind only where both branches are (a blend
        // with a dielectric still lets light through from behind).
        let (mut one_sided, mut back_black): (Vec<bool>, Vec<bool>) = (one_sided, back_black);
        for i in (0..branches.len()).rev() {
            if let Some(b) = &branches[i] {
                one_sided[i] = one_sided[b.first] && one_sided[b.second];
                back_black[i] = back_black[b.first] && back_black[b.second];
            }
        }
        let finite_textures: Vec<bool> = scene
            .materials
            .iter()
            .map(|m| match &m.bsdf {
                BsdfSpec::Diffuse { reflectance } => texture_is_finite(reflectance),
                _ => false,
            })
            .collect();
        let ignores_uv = scene
            .materials
            .iter()
            .map(|m| {
                m.emission_map.is_none()
                    && matches!(
                        m.bsdf,
                        BsdfSpec::Diffuse {
                            reflectance: Texture::Constant(_)
                        }
                    )
            })
            .collect();
        let (placements, shapes, simple_diffuse) = instance_tables(&scene, &finite_textures);
        let unit_normals = scene.meshes.iter().map(unit_normals).collect();
        let mesh_boxes = scene
            .meshes
            .iter()
            .map(|m| lumo_scene::positions_box(&m.positions))
            .collect();
        let reads_footprint = all().map(|m| footprint::reads_footprint(&m.bsdf)).collect();
        Ok(Self {
            reads_footprint,
            sample_spread: footprint::SampleSpread::Off,
            prefetch_surfaces: surface_bytes(&scene) > PREFETCH_ABOVE_BYTES,
            structure: Structure::of(&scene),
            textured_simple: any_textured(&simple_diffuse),
            simple_diffuse,
            finite_textures,
            spectral: std::sync::OnceLock::new(),
            // Relative to the coordinate magnitude (see `offset`): float error in the hit
            // point grows with it.
            ray_epsilon: 1e-4,
            scene,
            accel,
            lights,
            prepared,
            anisotropic,
            one_sided,
            ignores_uv,
            back_black,
            has_branches: branches.iter().any(Option::is_some),
            has_masks,
            branch_materials,
            branches,
            placements,
            shapes,
            unit_normals,
            mesh_boxes,
        })
    }

    /// Brings the render scene up to date after `self.scene` changed its instance transforms,
    /// the vertex positions of `moved_meshes` (same triangles), its punctual lights or its
    /// camera, as posing an animation does: the two-level BVH is refitted and its instances
    /// re-placed rather than rebuilt, and the lights (emissive geometry that moved) and
    /// per-instance tables are recomputed. The result renders what [`RenderScene::new`] of the
    /// changed scene renders (the ray hits are the same; only the trees' shapes differ).
    ///
    /// If meshes, instances or materials changed in number or kind, everything is rebuilt.
    /// The environment light must not change (its sampler is kept). On an invalid change (a
    /// transform that is singular or not finite, a vertex that is not finite) the error is
    /// returned and the render scene must not be used until a valid update.
    pub fn update(&mut self, moved_meshes: &[usize]) -> Result<SceneUpdate, SceneError> {
        if Structure::of(&self.scene) != self.structure {
            // A clone, so that on an error `self` still holds the changed scene.
            let spread = self.sample_spread;
            *self = Self::new(self.scene.clone())?;
            self.sample_spread = spread;
            return Ok(SceneUpdate::Rebuilt);
        }
        self.check_update(moved_meshes)?;
        let accel = if moved_meshes.is_empty() {
            self.accel.refit_instances(&self.scene)
        } else {
            self.accel.refit_meshes(&self.scene, moved_meshes)
        };
        for &m in moved_meshes {
            self.unit_normals[m] = unit_normals(&self.scene.meshes[m]);
            self.mesh_boxes[m] = lumo_scene::positions_box(&self.scene.meshes[m].positions);
        }
        (self.placements, self.shapes, self.simple_diffuse) =
            instance_tables(&self.scene, &self.finite_textures);
        self.textured_simple = any_textured(&self.simple_diffuse);
        self.lights.update(&self.scene);
        Ok(match accel {
            AccelUpdate::Refitted => SceneUpdate::Refitted,
            AccelUpdate::Rebuilt => SceneUpdate::RebuiltAccel,
        })
    }

    /// Poses `rig` (the scene's node animation) at time `t` seconds and updates the render
    /// scene to match ([`RenderScene::update`]): instances, punctual lights and a keyframed
    /// camera move, and skinned or morphing meshes are re-deformed and refitted.
    pub fn pose(&mut self, rig: &AnimatedScene, t: f32) -> Result<SceneUpdate, SceneError> {
        let deformed = rig.pose(&mut self.scene, Some(t));
        self.update(&deformed)
    }

    /// What [`Scene::validate`] would say of the parts an update changes: the transforms and
    /// the moved meshes' positions. Checks only those, so an update stays cheaper than a
    /// build.
    fn check_update(&self, moved_meshes: &[usize]) -> Result<(), SceneError> {
        for (ii, inst) in self.scene.instances.iter().enumerate() {
            let mesh = inst.mesh;
            if !inst.transform.is_finite() || inst.transform.determinant() == 0.0 {
                let name = self.scene.meshes.get(mesh).map_or("", |m| m.name.as_str());
                return Err(lumo_scene::singular_instance(ii, name));
            }
            let bounds = if moved_meshes.contains(&mesh) {
                self.scene
                    .meshes
                    .get(mesh)
                    .and_then(|m| lumo_scene::positions_box(&m.positions))
            } else {
                self.mesh_boxes.get(mesh).copied().flatten()
            };
            if let Some((lo, hi)) = bounds {
                let world = lumo_scene::transformed_box(lo, hi, &inst.transform);
                let reach = lumo_scene::box_reach(world);
                if reach.is_nan() || reach > lumo_scene::COORDINATE_LIMIT {
                    let name = self.scene.meshes.get(mesh).map_or("", |m| m.name.as_str());
                    return Err(lumo_scene::reach_error(ii, name, reach));
                }
            }
        }
        // A keyframed camera can collapse too (a zero scale on its node at some time): its rays
        // would all be NaN, a black frame.
        if !self.scene.camera.is_well_formed() {
            return Err(SceneError::Invalid(
                "the camera is singular at this pose (a zero scale on its node, or up along the \
                 view direction): give the camera node and its parents a non-zero scale at every \
                 keyframe"
                    .into(),
            ));
        }
        for &m in moved_meshes {
            let Some(mesh) = self.scene.meshes.get(m) else {
                return Err(SceneError::Invalid(format!(
                    "moved mesh {m}: the scene has {} meshes",
                    self.scene.meshes.len()
                )));
            };
            if let Some(i) = mesh.positions.iter().position(|p| !p.is_finite()) {
                return Err(SceneError::NonFinite {
                    mesh: mesh.name.clone(),
                    attribute: "position",
                    index: i,
                    value: format!("{:?}", mesh.positions[i]),
                });
            }
        }
        Ok(())
    }

    /// The instance's reflectance and emission, for the vector bounce, where it is a simple
    /// diffuse surface (see the field's doc; a black record otherwise).
    #[inline]
    pub(crate) fn simple_diffuse_ref(&self, instance: u32) -> &SimpleDiffuse {
        static NONE: SimpleDiffuse = SimpleDiffuse {
            mesh: 0,
            albedo: Vec3::ZERO,
            textured: false,
            emission: Vec3::ZERO,
            one_sided: false,
        };
        self.simple_diffuse[instance as usize]
            .as_ref()
            .unwrap_or(&NONE)
    }

    /// The reflectance of simple diffuse surface `sd` at `hit`: exactly what
    /// [`Self::surface`] and [`Self::bsdf`] give the scalar path (its vertex colour is one,
    /// which multiplies exactly). Inline for the constant case; a texture is looked up out of
    /// line (a call per lane kept the vector bounce 3 % slower on untextured scenes).
    #[inline(always)]
    pub(crate) fn simple_albedo(&self, sd: &SimpleDiffuse, hit: &Hit) -> Vec3 {
        if sd.textured {
            self.textured_albedo(sd, hit)
        } else {
            sd.albedo
        }
    }

    /// [`Self::simple_albedo`] of a textured surface.
    #[inline(never)]
    fn textured_albedo(&self, sd: &SimpleDiffuse, hit: &Hit) -> Vec3 {
        let uv = self.simple_uv(sd, hit);
        match &self.scene.materials[self.scene.meshes[sd.mesh].material].bsdf {
            BsdfSpec::Diffuse { reflectance } => texture(reflectance, uv),
            _ => sd.albedo,
        }
    }

    /// The vertex normals of triangle `triangle` of simple diffuse surface `sd`, which its
    /// shading normal interpolates; `None` for a flat mesh (the gather of the vector bounce
    /// and of the bidirectional walk lanes).
    #[inline(always)]
    pub(crate) fn simple_normals(&self, sd: &SimpleDiffuse, triangle: u32) -> Option<[Vec3; 3]> {
        let mesh = &self.scene.meshes[sd.mesh];
        if mesh.normals.is_empty() {
            return None;
        }
        let [i0, i1, i2] = mesh.indices[triangle as usize].map(|v| v as usize);
        Some([mesh.normals[i0], mesh.normals[i1], mesh.normals[i2]])
    }

    /// The texture coordinates of simple diffuse surface `sd` at `hit`, as
    /// [`Self::surface`] computes them.
    pub(crate) fn simple_uv(&self, sd: &SimpleDiffuse, hit: &Hit) -> Vec2 {
        let mesh = &self.scene.meshes[sd.mesh];
        let corners = mesh.indices[hit.triangle as usize].map(|i| i as usize);
        let (u, v) = (hit.u, hit.v);
        corner_uv(mesh, corners, u, v, 1.0 - u - v)
    }

    /// Whether some simple diffuse instance is textured ([`RenderScene::simple_albedo`]).
    #[inline]
    pub(crate) fn has_textured_simple(&self) -> bool {
        self.textured_simple
    }

    /// Whether the instance is a simple diffuse surface ([`RenderScene::simple_diffuse_ref`]).
    #[inline]
    pub(crate) fn is_simple_diffuse(&self, instance: u32) -> bool {
        self.simple_diffuse[instance as usize].is_some()
    }

    /// Unit geometric normal of triangle `triangle` of mesh `mesh`, in object space.
    #[inline]
    pub(crate) fn unit_normal(&self, mesh: usize, triangle: u32) -> Vec3 {
        self.unit_normals[mesh][triangle as usize]
    }

    /// Whether a group of hits should be prefetched ([`Self::prefetch_indices`]) before it
    /// is shaded: only where the meshes outgrow the cache (on the Cornell box the prefetch
    /// loops were 8 % of the render and saved nothing).
    #[inline]
    pub fn prefetches_surfaces(&self) -> bool {
        self.prefetch_surfaces
    }

    /// Starts loading the triangle's corner indices for [`Self::surface`] at `hit`.
    ///
    /// Why: the traversal reads its own copies of the triangles, so the mesh arrays `surface`
    /// reads are cold; issued for a whole group of hits before any is shaded, the misses
    /// overlap instead of each one stalling the shading that follows it.
    #[inline(always)]
    pub fn prefetch_indices(&self, hit: &Hit) {
        if let Some((m, mesh)) = self.hit_mesh(hit) {
            prefetch(mesh.indices.as_ptr().wrapping_add(hit.triangle as usize));
            if let Some(n) = self.unit_normals.get(m) {
                prefetch(n.as_ptr().wrapping_add(hit.triangle as usize));
            }
        }
    }

    /// Starts loading the per-corner attributes [`Self::surface`] will read at `hit` (after
    /// [`Self::prefetch_indices`], whose indices this reads).
    #[inline(always)]
    pub fn prefetch_corners(&self, hit: &Hit) {
        let Some((_, mesh)) = self.hit_mesh(hit) else {
            return;
        };
        let Some(&[i0, i1, i2]) = mesh.indices.get(hit.triangle as usize) else {
            return;
        };
        for i in [i0, i1, i2] {
            let i = i as usize;
            prefetch(mesh.positions.as_ptr().wrapping_add(i));
            if !mesh.normals.is_empty() {
                prefetch(mesh.normals.as_ptr().wrapping_add(i));
            }
            if !mesh.uvs.is_empty() {
                prefetch(mesh.uvs.as_ptr().wrapping_add(i));
            }
        }
    }

    /// The mesh of a triangle hit and its index (none for an exact shape, whose surface reads
    /// no mesh).
    #[inline(always)]
    fn hit_mesh(&self, hit: &Hit) -> Option<(usize, &Mesh)> {
        let place = self.placements.get(hit.instance as usize)?;
        if place.analytic {
            return None;
        }
        let m = self.scene.instances.get(hit.instance as usize)?.mesh;
        Some((m, self.scene.meshes.get(m)?))
    }

    /// Reconstructs the surface at `hit` of the ray with direction `dir`.
    #[inline(always)]
    pub fn surface(&self, hit: &Hit, origin: Vec3, dir: Vec3) -> Surface {
        self.surface_with(hit, origin, dir, true)
    }

    /// [`RenderScene::surface`] for shading only: on an exact shape whose material reads no
    /// texture coordinates (`ignores_uv`) the uv is left zero, skipping an `atan2` and an
    /// `acos`. Everything else is the same bits. (The path tracer's hits; `surface` keeps the
    /// uv for every other caller.)
    #[inline(always)]
    pub(crate) fn shading_surface(&self, hit: &Hit, origin: Vec3, dir: Vec3) -> Surface {
        self.surface_with(hit, origin, dir, false)
    }

    /// [`RenderScene::surface`], with the uv of exact shapes only where `uv` asks for it or
    /// the material reads it.
    #[inline(always)]
    fn surface_with(&self, hit: &Hit, origin: Vec3, dir: Vec3, uv: bool) -> Surface {
        let inst = &self.scene.instances[hit.instance as usize];
        let place = &self.placements[hit.instance as usize];
        if place.analytic {
            return self.analytic_surface(hit, origin, dir, uv);
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
        let uv = corner_uv(mesh, [i0, i1, i2], u, v, w);
        let color = if mesh.colors.is_empty() {
            Vec3::ONE
        } else {
            mesh.colors[i0] * w + mesh.colors[i1] * u + mesh.colors[i2] * v
        };
        let surface = Surface {
            p,
            ng,
            frame: Basis::new(ns),
            uv,
            color,
            material: mesh.material,
            instance: hit.instance,
            triangle: hit.triangle,
            back: dir.dot(ng) > 0.0,
        };
        if self.anisotropic[mesh.material] {
            return self.with_tangent_frame(surface);
        }
        surface
    }

    /// `surface` with its frame turned to the texture's u direction (anisotropic BSDFs).
    /// Out of line and by value: a reference to the surface taken in [`Self::surface`] itself
    /// kept LLVM from holding the record in registers for every other material.
    #[cold]
    #[inline(never)]
    fn with_tangent_frame(&self, mut surface: Surface) -> Surface {
        surface.frame = self.tangent_frame(&surface);
        surface
    }

    /// The surface of an exact shape at `hit`: the hit point re-projected onto it, the
    /// shape's normal as both geometric and shading normal, Mitsuba's uv (zero where `uv` is
    /// false and the material reads none).
    #[cold]
    fn analytic_surface(&self, hit: &Hit, origin: Vec3, dir: Vec3, uv: bool) -> Surface {
        let inst = &self.scene.instances[hit.instance as usize];
        let material = self.scene.meshes[inst.mesh].material;
        let Some(shape) = &self.shapes[hit.instance as usize] else {
            unreachable!("analytic placement without a shape");
        };
        let at = origin + dir * hit.t;
        // The same point and normal either way (`surface_at` projects as `point_at` does).
        let (p, n, uv) = if !uv && self.ignores_uv[material] {
            let sp = shape.point_at(at);
            (sp.p, sp.n, Vec2::ZERO)
        } else {
            let sp = shape.surface_at(at);
            (sp.p, sp.n, sp.uv)
        };
        let surface = Surface {
            p,
            ng: n,
            frame: Basis::new(n),
            uv,
            color: Vec3::ONE,
            material,
            instance: hit.instance,
            triangle: 0,
            back: dir.dot(n) > 0.0,
        };
        if self.anisotropic[material] {
            return self.with_tangent_frame(surface);
        }
        surface
    }

    /// The exact shape of instance `instance`, if it is one.
    #[inline]
    pub(crate) fn shape(&self, instance: u32) -> Option<&Shape> {
        self.shapes.get(instance as usize)?.as_ref()
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

    /// Whether any material has an opacity mask (see the field).
    #[inline]
    pub fn has_masks(&self) -> bool {
        self.has_masks
    }

    /// A ray origin just off the surface on the side of direction `d`.
    #[inline]
    pub fn offset(&self, s: &Surface, d: Vec3) -> Vec3 {
        offset_point(s.p.into(), s.ng.into(), d.into(), self.ray_epsilon).into()
    }
}

/// Mesh data above which hits are prefetched before shading: about a core's L2 cache.
const PREFETCH_ABOVE_BYTES: usize = 1 << 20;

/// The bytes of mesh data [`RenderScene::surface`] may read: indices, unit normals and the
/// per-corner attributes.
fn surface_bytes(scene: &Scene) -> usize {
    use std::mem::size_of_val;
    scene
        .meshes
        .iter()
        .map(|m| {
            size_of_val(m.indices.as_slice()) * 2
                + size_of_val(m.positions.as_slice())
                + size_of_val(m.normals.as_slice())
                + size_of_val(m.uvs.as_slice())
                + size_of_val(m.colors.as_slice())
                + size_of_val(m.alphas.as_slice())
        })
        .sum()
}

/// A hint to bring the cache line at `p` into the cache; never faults, whatever `p` is.
#[inline(always)]
fn prefetch<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is only a hint: it reads nothing and never faults, valid address or
    // not, and SSE is part of the x86-64 baseline.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}
