//! glTF skins (JOINTS_n / WEIGHTS_n, inverseBindMatrices) and morph targets (POSITION / NORMAL
//! displacements, mesh and node `weights`): read with each primitive, and turned into
//! [`Deformer`]s once the whole node tree is known (a skin's joints may come after its mesh).

use std::collections::{HashMap, HashSet};

use glam::{Mat4, Vec3};
use gltf::accessor::{DataType, Dimensions};

use super::GltfReader;
use crate::animation::NodeItem;
use crate::deform::{Deformer, Morph, Skin};
use crate::load::LoadError;
use crate::Instance;

/// What one primitive carries for deformation, read with its mesh.
pub(super) struct PrimDeform {
    /// Position displacements per morph target (empty where a target has none).
    positions: Vec<Vec<Vec3>>,
    /// Normal displacements per morph target.
    normals: Vec<Vec<Vec3>>,
    /// Influences per vertex (4 per JOINTS_n set; 0 without JOINTS_0).
    per_vertex: usize,
    /// Joint slots, `per_vertex` per vertex.
    joint_ids: Vec<u32>,
    /// Weights normalised per vertex (all zero where they summed to zero).
    weights: Vec<f32>,
    /// Vertices whose weights summed to zero.
    unweighted: usize,
    /// "mesh M primitive P", for messages.
    label: String,
}

/// A node's deforming mesh, waiting for the node tree to be complete.
struct Pending {
    /// Rig node carrying it.
    rig_node: usize,
    /// Its glTF node.
    node: usize,
    /// The lumo mesh it deforms (its own copy).
    mesh: usize,
    /// The lumo mesh whose primitive data it reads (`mesh` or the one it was copied from).
    source: usize,
}

/// The loader's bookkeeping for deformation.
#[derive(Default)]
pub(super) struct DeformState {
    /// Primitive data by lumo mesh.
    prims: HashMap<usize, PrimDeform>,
    /// Morph target count of each glTF mesh.
    pub(super) targets: HashMap<usize, usize>,
    pending: Vec<Pending>,
    /// lumo meshes placed by some instance.
    instanced: HashSet<usize>,
    /// lumo meshes a deformer rewrites (no other instance may share them).
    claimed: HashSet<usize>,
}

impl GltfReader<'_, '_> {
    /// Reads the morph targets and skin attributes of `prim`, whose geometry became lumo mesh
    /// `mesh`.
    pub(super) fn read_deform(
        &mut self,
        gmesh: &gltf::Mesh,
        prim: &gltf::Primitive,
        label: &str,
        mesh: usize,
    ) -> Result<(), LoadError> {
        let n = self.scene.meshes[mesh].positions.len();
        let count = prim.morph_targets().len();
        match self.deform.targets.get(&gmesh.index()) {
            Some(&first) if first != count => {
                return Err(LoadError::invalid(
                    self.at(label.to_string()),
                    format!(
                        "has {count} morph targets but an earlier primitive of the mesh has \
                         {first}; glTF requires every primitive of a mesh to have the same number"
                    ),
                ));
            }
            _ => {
                self.deform.targets.insert(gmesh.index(), count);
            }
        }
        let mut positions = Vec::with_capacity(count);
        let mut normals = Vec::with_capacity(count);
        for (k, t) in prim.morph_targets().enumerate() {
            use super::attributes::Quantized;
            for (acc, what, kind, out) in [
                (
                    t.positions(),
                    "POSITION",
                    Quantized::AnyInteger,
                    &mut positions,
                ),
                (
                    t.normals(),
                    "NORMAL",
                    Quantized::SignedNormalized,
                    &mut normals,
                ),
            ] {
                let Some(acc) = acc else {
                    out.push(Vec::new());
                    continue;
                };
                let what = format!("morph target {k} {what}");
                self.check_attribute(&acc, Dimensions::Vec3, &what, kind)?;
                if acc.count() != n {
                    return Err(LoadError::invalid(
                        self.at(format!("{label} {what}")),
                        format!(
                            "has {} displacements but POSITION has {n} vertices; give one per \
                             vertex",
                            acc.count()
                        ),
                    ));
                }
                out.push(
                    self.read_floats::<3>(&acc)?
                        .into_iter()
                        .map(Vec3::from)
                        .collect(),
                );
            }
        }
        let bad = positions
            .iter()
            .chain(&normals)
            .enumerate()
            .find_map(|(k, d)| {
                d.iter()
                    .position(|v| !v.is_finite())
                    .map(|v| (k % count.max(1), v))
            });
        if let Some((k, v)) = bad {
            return Err(LoadError::invalid(
                self.at(label.to_string()),
                format!(
                    "morph target {k}: the displacement of vertex {v} is not finite; fix the \
                     target's data"
                ),
            ));
        }
        let (per_vertex, joint_ids, weights, unweighted) = self.read_influences(prim, label, n)?;
        if count > 0 || per_vertex > 0 {
            self.deform.prims.insert(
                mesh,
                PrimDeform {
                    positions,
                    normals,
                    per_vertex,
                    joint_ids,
                    weights,
                    unweighted,
                    label: label.to_string(),
                },
            );
        }
        Ok(())
    }

    /// Every JOINTS_n / WEIGHTS_n set of `prim`: (influences per vertex, joint slots,
    /// normalised weights, vertices whose weights sum to zero).
    #[allow(clippy::type_complexity)]
    fn read_influences(
        &self,
        prim: &gltf::Primitive,
        label: &str,
        n: usize,
    ) -> Result<(usize, Vec<u32>, Vec<f32>, usize), LoadError> {
        let mut sets: Vec<(Vec<[u16; 4]>, Vec<[f32; 4]>)> = Vec::new();
        for s in 0u32.. {
            let joints = prim.get(&gltf::Semantic::Joints(s));
            let weights = prim.get(&gltf::Semantic::Weights(s));
            let (joints, weights) = match (joints, weights) {
                (None, None) => break,
                (Some(j), Some(w)) => (j, w),
                (j, _) => {
                    let (has, lacks) = if j.is_some() {
                        ("JOINTS", "WEIGHTS")
                    } else {
                        ("WEIGHTS", "JOINTS")
                    };
                    return Err(LoadError::invalid(
                        self.at(label.to_string()),
                        format!(
                            "has {has}_{s} but no {lacks}_{s}: skinning needs both (one joint \
                             index and one weight per influence); add {lacks}_{s} or remove \
                             {has}_{s}"
                        ),
                    ));
                }
            };
            let what = format!("JOINTS_{s}");
            self.check_layout(&joints, &[Dimensions::Vec4], &what)?;
            if !matches!(joints.data_type(), DataType::U8 | DataType::U16) || joints.normalized() {
                return Err(LoadError::invalid(
                    self.at(format!("accessor {} ({what})", joints.index())),
                    "joint indices must be unsigned bytes or shorts, not normalised",
                ));
            }
            self.check_accessor(&weights, &[Dimensions::Vec4], &format!("WEIGHTS_{s}"))?;
            let buffers = &self.buffers;
            let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
            let j: Vec<[u16; 4]> = reader
                .read_joints(s)
                .map(|it| it.into_u16().collect())
                .unwrap_or_default();
            let w: Vec<[f32; 4]> = reader
                .read_weights(s)
                .map(|it| it.into_f32().collect())
                .unwrap_or_default();
            if j.len() != n || w.len() != n {
                return Err(LoadError::invalid(
                    self.at(label.to_string()),
                    format!(
                        "JOINTS_{s} has {} entries and WEIGHTS_{s} {}, but POSITION has {n}",
                        j.len(),
                        w.len()
                    ),
                ));
            }
            if let Some(v) = w
                .iter()
                .position(|w| w.iter().any(|x| !x.is_finite() || *x < 0.0))
            {
                return Err(LoadError::invalid(
                    self.at(format!("{label} WEIGHTS_{s}")),
                    format!(
                        "vertex {v} has weights {:?}; skin weights must be finite and not \
                         negative",
                        w[v]
                    ),
                ));
            }
            sets.push((j, w));
        }
        let per_vertex = 4 * sets.len();
        let mut joint_ids = Vec::with_capacity(n * per_vertex);
        let mut weights = Vec::with_capacity(n * per_vertex);
        let mut unweighted = 0;
        for v in 0..n {
            let start = weights.len();
            for (j, w) in &sets {
                joint_ids.extend(j[v].iter().map(|&x| u32::from(x)));
                weights.extend_from_slice(&w[v]);
            }
            let sum: f32 = weights[start..].iter().sum();
            if sum > 0.0 {
                weights[start..].iter_mut().for_each(|w| *w /= sum);
            } else if per_vertex > 0 {
                unweighted += 1;
            }
        }
        Ok((per_vertex, joint_ids, weights, unweighted))
    }

    /// Places the lumo meshes of `node`'s mesh: instances that follow the node, except a
    /// skinned mesh's, which stay at the identity (skinning puts its vertices in the world).
    /// A deforming mesh gets a copy of its own when another instance already uses it.
    pub(super) fn place_mesh(
        &mut self,
        node: &gltf::Node,
        gmesh: &gltf::Mesh,
        rig_node: usize,
        meshes: Vec<usize>,
    ) -> Result<(), LoadError> {
        let skinned = node.skin().is_some();
        let morphs = self
            .deform
            .targets
            .get(&gmesh.index())
            .copied()
            .unwrap_or(0)
            > 0;
        let deforms = skinned || morphs;
        for m in meshes {
            let shared = self.deform.instanced.contains(&m);
            let own = if shared && (deforms || self.deform.claimed.contains(&m)) {
                // Nothing is posed while loading, so the mesh still has its rest geometry.
                let copy = self.scene.meshes[m].clone();
                self.scene.meshes.push(copy);
                self.scene.meshes.len() - 1
            } else {
                m
            };
            self.deform.instanced.insert(own);
            if deforms {
                self.deform.claimed.insert(own);
                self.deform.pending.push(Pending {
                    rig_node,
                    node: node.index(),
                    mesh: own,
                    source: m,
                });
            }
            self.scene.instances.push(Instance {
                mesh: own,
                transform: Mat4::IDENTITY,
            });
            if !skinned {
                let i = self.scene.instances.len() - 1;
                self.rig.items.push((rig_node, NodeItem::Instance(i)));
            }
        }
        Ok(())
    }

    /// Turns the deforming meshes into the rig's deformers, now that every node is known.
    pub(super) fn deformers(&mut self, doc: &gltf::Document) -> Result<(), LoadError> {
        let mut skins: HashMap<usize, (Vec<usize>, Vec<Mat4>)> = HashMap::new();
        for p in std::mem::take(&mut self.deform.pending) {
            let Some(node) = doc.nodes().nth(p.node) else {
                continue;
            };
            let Some(gmesh) = node.mesh() else { continue };
            let data = self.deform.prims.remove(&p.source);
            let count = self
                .deform
                .targets
                .get(&gmesh.index())
                .copied()
                .unwrap_or(0);
            let morph = match count {
                0 => None,
                _ => Some(Morph {
                    weights: self.static_weights(&node, &gmesh, count)?,
                    positions: data
                        .as_ref()
                        .map(|d| d.positions.clone())
                        .unwrap_or_default(),
                    normals: data.as_ref().map(|d| d.normals.clone()).unwrap_or_default(),
                }),
            };
            let skin = match node.skin() {
                None => None,
                Some(s) => {
                    let (joints, inverse_bind) = match skins.get(&s.index()) {
                        Some(j) => j.clone(),
                        None => {
                            let j = self.skin_joints(&s)?;
                            skins.insert(s.index(), j.clone());
                            j
                        }
                    };
                    Some(self.skin(&node, joints, inverse_bind, data.as_ref(), &p)?)
                }
            };
            if let Some(d) = data {
                // A copy shares its source's data: put it back for the next user.
                self.deform.prims.insert(p.source, d);
            }
            if !self.scene.meshes[p.mesh].tangents.is_empty() {
                self.scene.meshes[p.mesh].tangents.clear();
                self.diag.warn(
                    self.at(format!("mesh {}", self.scene.meshes[p.mesh].name)),
                    "TANGENT of a skinned or morphing primitive is not deformed with it, so it is \
                     dropped: its normal map takes the tangent frame from the uvs (∂p/∂u)",
                )?;
            }
            let mesh = &self.scene.meshes[p.mesh];
            self.rig.deformers.push(Deformer {
                mesh: p.mesh,
                node: p.rig_node,
                rest_positions: mesh.positions.clone(),
                rest_normals: mesh.normals.clone(),
                morph,
                skin,
            });
        }
        Ok(())
    }

    /// The morph weights of `node` when no clip drives them: its own `weights`, else its
    /// mesh's, else zeros.
    fn static_weights(
        &self,
        node: &gltf::Node,
        gmesh: &gltf::Mesh,
        count: usize,
    ) -> Result<Vec<f32>, LoadError> {
        let (weights, at) = match (node.weights(), gmesh.weights()) {
            (Some(w), _) => (w, format!("node {} weights", node.index())),
            (None, Some(w)) => (w, format!("mesh {} weights", gmesh.index())),
            (None, None) => return Ok(vec![0.0; count]),
        };
        if weights.len() != count {
            return Err(LoadError::invalid(
                self.at(at),
                format!(
                    "has {} weights but mesh {} has {count} morph targets; give one weight per \
                     target",
                    weights.len(),
                    gmesh.index()
                ),
            ));
        }
        if let Some(i) = weights.iter().position(|w| !w.is_finite()) {
            return Err(LoadError::invalid(
                self.at(at),
                format!(
                    "weight {i} is {}; morph weights must be finite numbers",
                    weights[i]
                ),
            ));
        }
        Ok(weights.to_vec())
    }

    /// A skin's joints (as rig nodes) and inverse bind matrices, checked.
    fn skin_joints(&self, skin: &gltf::Skin) -> Result<(Vec<usize>, Vec<Mat4>), LoadError> {
        let at = |what: &str| self.at(format!("skin {} {what}", skin.index()));
        let mut joints = Vec::new();
        for (k, j) in skin.joints().enumerate() {
            let Some(&rig) = self.node_index.get(&j.index()) else {
                return Err(LoadError::invalid(
                    at("joints"),
                    format!(
                        "joint {k} is node {}, which is not in the rendered scene's node tree; \
                         make every joint a node of the scene",
                        j.index()
                    ),
                ));
            };
            joints.push(rig);
        }
        let Some(acc) = skin.inverse_bind_matrices() else {
            // glTF: without inverseBindMatrices each is the identity.
            return Ok((joints.clone(), vec![Mat4::IDENTITY; joints.len()]));
        };
        self.check_accessor(&acc, &[Dimensions::Mat4], "inverseBindMatrices")?;
        let buffers = &self.buffers;
        let reader = skin.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let ibm: Vec<Mat4> = reader
            .read_inverse_bind_matrices()
            .map(|it| it.map(|m| Mat4::from_cols_array_2d(&m)).collect())
            .unwrap_or_default();
        if ibm.len() != joints.len() {
            return Err(LoadError::invalid(
                at("inverseBindMatrices"),
                format!(
                    "has {} matrices for {} joints; give one per joint",
                    ibm.len(),
                    joints.len()
                ),
            ));
        }
        for (k, m) in ibm.iter().enumerate() {
            let det = m.determinant();
            if !m.is_finite() || !det.is_finite() || det.abs() < 1e-12 {
                return Err(LoadError::invalid(
                    at("inverseBindMatrices"),
                    format!(
                        "matrix {k} (joint {k}) is not finite or not invertible (determinant \
                         {det}); it must be the inverse of the joint's world transform at bind \
                         time"
                    ),
                ));
            }
        }
        Ok((joints, ibm))
    }

    /// The skin of a pending mesh: its influences checked against the joint count.
    fn skin(
        &mut self,
        node: &gltf::Node,
        joints: Vec<usize>,
        inverse_bind: Vec<Mat4>,
        data: Option<&PrimDeform>,
        p: &Pending,
    ) -> Result<Skin, LoadError> {
        let n = self.scene.meshes[p.mesh].positions.len();
        let name = self.scene.meshes[p.mesh].name.clone();
        let at = format!("node {} skin", node.index());
        let Some(d) = data.filter(|d| d.per_vertex > 0) else {
            self.diag.warn(
                self.at(at),
                format!(
                    "mesh {name:?} has no JOINTS_0/WEIGHTS_0, so the skin cannot move it; it is \
                     drawn rigidly by its node's transform (add the skin attributes)"
                ),
            )?;
            return Ok(Skin {
                joints,
                inverse_bind,
                per_vertex: 0,
                joint_ids: Vec::new(),
                weights: Vec::new(),
            });
        };
        let bad = d
            .joint_ids
            .iter()
            .zip(&d.weights)
            .position(|(&j, &w)| w > 0.0 && j as usize >= joints.len());
        if let Some(i) = bad {
            return Err(LoadError::invalid(
                self.at(format!("{} JOINTS", d.label)),
                format!(
                    "vertex {} uses joint {} but skin {} has {} joints; joint indices count \
                     into the skin's joints list",
                    i / d.per_vertex,
                    d.joint_ids[i],
                    node.skin().map_or(0, |s| s.index()),
                    joints.len()
                ),
            ));
        }
        if d.unweighted > 0 {
            self.diag.warn(
                self.at(format!("{} WEIGHTS_0", d.label)),
                format!(
                    "{} of {n} vertices have weights summing to 0; they follow the node's own \
                     transform (give each vertex a non-zero weight)",
                    d.unweighted
                ),
            )?;
        }
        Ok(Skin {
            joints,
            inverse_bind,
            per_vertex: d.per_vertex,
            joint_ids: d.joint_ids.clone(),
            weights: d.weights.clone(),
        })
    }
}
