use glam::{Mat4, Vec3, Vec4Swizzles};

use crate::{Camera, Instance, Light, Material, Mesh, SceneError, SceneMedia};

/// The longest path depth and Russian-roulette depth a scene file or the command line may ask
/// for: Mitsuba's "unbounded" (`max_depth = -1`) maps to it, and Russian roulette ends such
/// paths long before (a larger limit only lets a closed mirror box run for hours).
pub const DEPTH_LIMIT: u32 = 1 << 16;

/// The largest coordinate magnitude instanced geometry may reach: beyond it squared
/// distances overflow single precision and the acceleration structure's boxes stop bounding
/// anything (a glTF node scaled by 1e20 once crashed the renderer). [`Scene::validate`] and
/// every re-pose of an animated scene check it.
pub const COORDINATE_LIMIT: f32 = 1e18;

/// The axis-aligned box around the box `lo..hi` after `transform`: its eight corners
/// transformed (a bound, not the tightest box, under rotation); NaN when a corner is not
/// finite.
pub fn transformed_box(lo: Vec3, hi: Vec3, transform: &Mat4) -> (Vec3, Vec3) {
    let mut b = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for i in 0..8 {
        let corner = Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        let w = transform.transform_point3(corner);
        if !w.is_finite() {
            return (Vec3::NAN, Vec3::NAN);
        }
        b = (b.0.min(w), b.1.max(w));
    }
    b
}

/// The largest coordinate magnitude of the box `(lo, hi)`; NaN when it is not finite.
pub fn box_reach((lo, hi): (Vec3, Vec3)) -> f32 {
    if lo.is_finite() && hi.is_finite() {
        lo.abs().max(hi.abs()).max_element()
    } else {
        f32::NAN
    }
}

/// The local bounding box of `positions` (`None` when empty).
pub fn positions_box(positions: &[Vec3]) -> Option<(Vec3, Vec3)> {
    let first = *positions.first()?;
    Some(
        positions
            .iter()
            .fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))),
    )
}

/// The error for an instance whose transform is singular or not finite.
pub fn singular_instance(instance: usize, mesh: &str) -> SceneError {
    SceneError::Invalid(format!(
        "instance {instance} (mesh {mesh:?}): transform is singular or not finite (a zero \
         scale flattens the object, and lumo does not hide objects that way: give the node and \
         its parents a non-zero scale at every time)"
    ))
}

/// The error for an instance whose geometry reaches `reach` (beyond [`COORDINATE_LIMIT`]).
pub fn reach_error(instance: usize, mesh: &str, reach: f32) -> SceneError {
    SceneError::Invalid(format!(
        "instance {instance} (mesh {mesh:?}): its geometry reaches {reach:e} units from the \
         origin, beyond the {COORDINATE_LIMIT:e} that single-precision rays can handle; scale \
         it down (a transform or animation with a huge scale?)"
    ))
}

/// Resolution and sampling a scene asks for; command-line options override them.
#[derive(Clone, Debug)]
pub struct RenderDefaults {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// Samples per pixel.
    pub spp: u32,
    /// Maximum path depth (Mitsuba's convention: 1 = emitters only, 2 = direct light).
    pub max_depth: u32,
}

/// Everything the renderer needs.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Name, used for default output files.
    pub name: String,
    /// Meshes in object space.
    pub meshes: Vec<Mesh>,
    /// Placements of meshes in the world.
    pub instances: Vec<Instance>,
    /// Materials, referenced by meshes.
    pub materials: Vec<Material>,
    /// Non-area lights.
    pub lights: Vec<Light>,
    /// The camera.
    pub camera: Camera,
    /// Resolution and sampling defaults.
    pub defaults: RenderDefaults,
    /// Participating media and the shapes that bound them (empty for surface-only scenes).
    pub media: SceneMedia,
}

impl Scene {
    /// A scene with nothing in it but `camera`, named "scene", with small defaults (16×16
    /// pixels, 16 samples, depth 8): the start of a scene built in code.
    pub fn empty(camera: Camera) -> Scene {
        Scene {
            name: "scene".into(),
            meshes: vec![],
            instances: vec![],
            materials: vec![],
            lights: vec![],
            camera,
            defaults: RenderDefaults {
                width: 16,
                height: 16,
                spp: 16,
                max_depth: 8,
            },
            media: SceneMedia::default(),
        }
    }

    /// Adds a mesh placed once with the identity transform; returns the mesh index.
    pub fn add_mesh(&mut self, mesh: Mesh) -> usize {
        self.meshes.push(mesh);
        let index = self.meshes.len() - 1;
        self.instances.push(Instance {
            mesh: index,
            transform: glam::Mat4::IDENTITY,
        });
        index
    }

    /// Adds a material; returns its index.
    pub fn add_material(&mut self, material: Material) -> usize {
        self.materials.push(material);
        self.materials.len() - 1
    }

    /// Total number of triangles over all instances.
    pub fn triangle_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes.get(i.mesh).map_or(0, |m| m.triangle_count()))
            .sum()
    }

    /// Per instance, a world box around its geometry: [`transformed_box`] of its mesh's own
    /// box (`None` for a mesh without vertices or out of range). One pass over each mesh's
    /// vertices, however many instances place it, where [`Scene::bounds`] transforms every
    /// vertex of every instance.
    pub fn instance_boxes(&self) -> Vec<Option<(Vec3, Vec3)>> {
        let boxes: Vec<_> = self
            .meshes
            .iter()
            .map(|m| positions_box(&m.positions))
            .collect();
        self.instances
            .iter()
            .map(|inst| {
                let (lo, hi) = boxes.get(inst.mesh).copied().flatten()?;
                Some(transformed_box(lo, hi, &inst.transform))
            })
            .collect()
    }

    /// World-space bounding box (min, max) of all instanced geometry.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for inst in &self.instances {
            if let Some(mesh) = self.meshes.get(inst.mesh) {
                for p in &mesh.positions {
                    let w = (inst.transform * p.extend(1.0)).xyz();
                    lo = lo.min(w);
                    hi = hi.max(w);
                }
            }
        }
        if lo.x > hi.x {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            (lo, hi)
        }
    }

    /// Checks references, index ranges and finiteness so the renderer can trust the data.
    pub fn validate(&self) -> Result<(), SceneError> {
        for (mi, mesh) in self.meshes.iter().enumerate() {
            let n = mesh.positions.len();
            if mesh.material >= self.materials.len() {
                return Err(SceneError::BadReference {
                    what: format!("mesh {mi} ({:?})", mesh.name),
                    kind: "material",
                    index: mesh.material,
                    count: self.materials.len(),
                });
            }
            for (attribute, len) in [
                ("normals", mesh.normals.len()),
                ("uvs", mesh.uvs.len()),
                ("colors", mesh.colors.len()),
                ("alphas", mesh.alphas.len()),
                ("tangents", mesh.tangents.len()),
            ] {
                if len != 0 && len != n {
                    return Err(SceneError::AttributeLength {
                        mesh: mesh.name.clone(),
                        attribute,
                        got: len,
                        expected: n,
                    });
                }
            }
            for (t, tri) in mesh.indices.iter().enumerate() {
                for &index in tri {
                    if index as usize >= n {
                        return Err(SceneError::IndexOutOfRange {
                            mesh: mesh.name.clone(),
                            triangle: t,
                            index,
                            count: n,
                        });
                    }
                }
            }
            let bad = |attribute, index, value: String| SceneError::NonFinite {
                mesh: mesh.name.clone(),
                attribute,
                index,
                value,
            };
            if let Some(a) = &mesh.analytic {
                if !a.to_mesh.is_finite() || a.to_mesh.determinant() == 0.0 {
                    return Err(SceneError::Invalid(format!(
                        "mesh {mi} ({:?}): analytic shape transform is singular or not finite",
                        mesh.name
                    )));
                }
            }
            if let Some(i) = mesh.positions.iter().position(|p| !p.is_finite()) {
                return Err(bad("position", i, format!("{:?}", mesh.positions[i])));
            }
            if let Some(i) = mesh.normals.iter().position(|p| !p.is_finite()) {
                return Err(bad("normal", i, format!("{:?}", mesh.normals[i])));
            }
            if let Some(i) = mesh.uvs.iter().position(|p| !p.is_finite()) {
                return Err(bad("uv", i, format!("{:?}", mesh.uvs[i])));
            }
            if let Some(i) = mesh.colors.iter().position(|p| !p.is_finite()) {
                return Err(bad("color", i, format!("{:?}", mesh.colors[i])));
            }
            if let Some(i) = mesh.tangents.iter().position(|t| !t.is_finite()) {
                return Err(bad("tangent", i, format!("{:?}", mesh.tangents[i])));
            }
            if let Some(i) = mesh.alphas.iter().position(|a| !a.is_finite()) {
                return Err(bad("alpha", i, format!("{:?}", mesh.alphas[i])));
            }
        }
        for (ii, inst) in self.instances.iter().enumerate() {
            if inst.mesh >= self.meshes.len() {
                return Err(SceneError::BadReference {
                    what: format!("instance {ii}"),
                    kind: "mesh",
                    index: inst.mesh,
                    count: self.meshes.len(),
                });
            }
            if !inst.transform.is_finite() || inst.transform.determinant() == 0.0 {
                return Err(singular_instance(ii, &self.meshes[inst.mesh].name));
            }
        }
        self.media.validate(self.meshes.len())?;
        for (ii, b) in self.instance_boxes().into_iter().enumerate() {
            let reach = b.map_or(0.0, box_reach);
            if reach.is_nan() || reach > COORDINATE_LIMIT {
                let mesh = &self.meshes[self.instances[ii].mesh].name;
                return Err(reach_error(ii, mesh, reach));
            }
        }
        // Loaders say this naming the file and field; this catches scenes built in code.
        for (li, light) in self.lights.iter().enumerate() {
            let (field, v) = light.strength();
            if !v.is_finite() || v.max_element() > crate::MAX_EMISSION {
                return Err(SceneError::Invalid(format!(
                    "light {li}: {field} {v} is beyond {:e} per channel (or not finite); \
                     scale the light down",
                    crate::MAX_EMISSION
                )));
            }
        }
        Ok(())
    }
}
