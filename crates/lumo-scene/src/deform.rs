//! Deforming meshes (glTF skins and morph targets): the rest geometry and what bends it, so
//! that [`crate::AnimatedScene::pose`] can rewrite a mesh's positions and normals at any time.
//! Morph targets are applied first, then the skin, as glTF orders them.

use glam::{Mat3, Mat4, Vec3};

/// Linear blend skinning data of one mesh.
#[derive(Clone, Debug)]
pub struct Skin {
    /// Rig node of each joint.
    pub joints: Vec<usize>,
    /// Inverse bind matrix of each joint (mesh space → the joint's space at bind time).
    pub inverse_bind: Vec<Mat4>,
    /// Influences per vertex (4 per JOINTS_n/WEIGHTS_n set).
    pub per_vertex: usize,
    /// Joint slot (index into `joints`) of each influence, `per_vertex` per vertex.
    pub joint_ids: Vec<u32>,
    /// Weight of each influence, normalised per vertex to sum to one; all zero for a vertex
    /// that no joint moves (it follows the mesh's node instead).
    pub weights: Vec<f32>,
}

/// Morph targets of one mesh: displacements blended by weights.
#[derive(Clone, Debug, Default)]
pub struct Morph {
    /// Position displacement of each vertex per target (empty: the target moves none).
    pub positions: Vec<Vec<Vec3>>,
    /// Normal displacement of each vertex per target (empty: none).
    pub normals: Vec<Vec<Vec3>>,
    /// Weights when no clip drives them (the node's `weights`, else the mesh's, else zeros).
    pub weights: Vec<f32>,
}

/// One deforming mesh: which mesh, its rest geometry and what bends it.
#[derive(Clone, Debug)]
pub struct Deformer {
    /// Index into [`crate::Scene::meshes`].
    pub mesh: usize,
    /// Rig node carrying the mesh: its morph weights are animated there, and a skinned vertex
    /// without weights follows its transform.
    pub node: usize,
    /// Positions before morphing and skinning.
    pub rest_positions: Vec<Vec3>,
    /// Normals before morphing and skinning (empty for flat shading).
    pub rest_normals: Vec<Vec3>,
    /// Morph targets, if any.
    pub morph: Option<Morph>,
    /// The skin, if any: then the mesh's vertices are placed in world space and its instance
    /// keeps the identity transform (glTF ignores a skinned mesh's node transform).
    pub skin: Option<Skin>,
}

impl Deformer {
    /// The deformed positions and normals, given every rig node's world matrix and the morph
    /// weights (`None`: the static ones).
    pub fn deform(&self, world: &[Mat4], weights: Option<&[f32]>) -> (Vec<Vec3>, Vec<Vec3>) {
        let mut positions = self.rest_positions.clone();
        let mut normals = self.rest_normals.clone();
        if let Some(morph) = &self.morph {
            let weights = weights.unwrap_or(&morph.weights);
            for (k, &w) in weights.iter().enumerate() {
                if w == 0.0 {
                    continue;
                }
                let add = |out: &mut Vec<Vec3>, deltas: Option<&Vec<Vec3>>| {
                    for (o, d) in out.iter_mut().zip(deltas.into_iter().flatten()) {
                        *o += w * *d;
                    }
                };
                add(&mut positions, morph.positions.get(k));
                add(&mut normals, morph.normals.get(k));
            }
        }
        if let Some(skin) = &self.skin {
            let joint: Vec<Mat4> = skin
                .joints
                .iter()
                .zip(&skin.inverse_bind)
                .map(|(&j, ibm)| world.get(j).copied().unwrap_or(Mat4::IDENTITY) * *ibm)
                .collect();
            let own = world.get(self.node).copied().unwrap_or(Mat4::IDENTITY);
            let n = skin.per_vertex;
            for (v, p) in positions.iter_mut().enumerate() {
                let range = v * n..(v + 1) * n;
                let mut m = Mat4::ZERO;
                for (&j, &w) in skin.joint_ids[range.clone()]
                    .iter()
                    .zip(&skin.weights[range])
                {
                    if w != 0.0 {
                        m += joint.get(j as usize).copied().unwrap_or(Mat4::IDENTITY) * w;
                    }
                }
                if m == Mat4::ZERO {
                    m = own;
                }
                *p = m.transform_point3(*p);
                if let Some(nrm) = normals.get_mut(v) {
                    *nrm = normal_matrix(&m) * *nrm;
                }
            }
        }
        for n in &mut normals {
            *n = n.normalize_or_zero();
        }
        (positions, normals)
    }
}

/// The matrix that carries normals under `m`: its cofactor matrix (the inverse transpose up to
/// a positive factor, defined also where `m` is singular), sign-corrected for mirrors.
fn normal_matrix(m: &Mat4) -> Mat3 {
    let a = Mat3::from_mat4(*m);
    let cof = Mat3::from_cols(
        a.y_axis.cross(a.z_axis),
        a.z_axis.cross(a.x_axis),
        a.x_axis.cross(a.y_axis),
    );
    if a.determinant() < 0.0 {
        -cof
    } else {
        cof
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;

    #[test]
    fn cofactor_carries_normals_like_the_inverse_transpose() {
        let m = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, 0.5, -3.0),
            Quat::from_rotation_y(0.7),
            Vec3::ONE,
        );
        let n = Vec3::new(0.3, -0.4, 0.8);
        let want = (Mat3::from_mat4(m).inverse().transpose() * n).normalize();
        let got = (normal_matrix(&m) * n).normalize();
        assert!((want - got).length() < 1e-5, "{want} {got}");
    }
}
