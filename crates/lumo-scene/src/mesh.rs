use glam::{Mat4, Vec2, Vec3, Vec4};

/// A triangle mesh in its own object space with one material.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Name, used in messages.
    pub name: String,
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals; empty for flat shading.
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates; empty when the mesh has none.
    pub uvs: Vec<Vec2>,
    /// Per-vertex tangents for normal maps (glTF `TANGENT`): xyz the tangent along +u, w = ±1
    /// the bitangent's handedness (bitangent = normal × tangent · w); empty: normal maps
    /// take their frame from ∂p/∂u.
    pub tangents: Vec<Vec4>,
    /// Per-vertex linear RGB colours that multiply the material's diffuse reflectance (glTF
    /// `COLOR_0`, PLY `red`/`green`/`blue`); empty when the mesh has none.
    pub colors: Vec<Vec3>,
    /// Per-vertex alpha (glTF `COLOR_0`'s fourth component under alphaMode MASK or BLEND) that
    /// multiplies the material's opacity mask at each hit; empty where it is 1 everywhere.
    pub alphas: Vec<f32>,
    /// Triangles as vertex indices (counter-clockwise seen from the front).
    pub indices: Vec<[u32; 3]>,
    /// Index into [`crate::Scene::materials`].
    pub material: usize,
    /// Set for Mitsuba's `sphere`, `disk` and `cylinder`: the renderer intersects the exact
    /// shape, and the triangles above are only a proxy (bounds, counts, viewers).
    pub analytic: Option<Analytic>,
}

/// Which exact shape an analytic mesh stands for, in its own object space.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AnalyticKind {
    /// The unit sphere at the origin (Mitsuba's `sphere`: u = φ/2π, v = θ/π, poles on z).
    Sphere,
    /// The unit disk in the z = 0 plane facing +z (Mitsuba's `disk`: uv = (r, φ/2π)).
    Disk,
    /// The open cylinder of radius 1 around z from z = 0 to 1, normals outwards (Mitsuba's
    /// `cylinder`: uv = (φ/2π, z)).
    Cylinder,
}

/// An exact shape placed in the mesh's space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Analytic {
    /// The shape.
    pub kind: AnalyticKind,
    /// Shape object space → the mesh's space (Mitsuba's `to_world`, with the sphere's centre
    /// and radius and the cylinder's end points folded in); the instance transform follows.
    pub to_mesh: Mat4,
    /// Normals point inwards (Mitsuba's `flip_normals`).
    pub flip_normals: bool,
}

impl Mesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// The texture coordinates of triangle `t`'s corners: the mesh's own, or (0, 0), (1, 0),
    /// (0, 1) where it has none, so that a point's uv is its barycentric coordinates.
    #[inline]
    pub fn triangle_uvs(&self, t: usize) -> [Vec2; 3] {
        if self.uvs.is_empty() {
            [Vec2::ZERO, Vec2::X, Vec2::Y]
        } else {
            self.indices[t].map(|i| self.uvs[i as usize])
        }
    }

    /// The three corner positions of triangle `t`.
    #[inline]
    pub fn triangle(&self, t: usize) -> [Vec3; 3] {
        let [a, b, c] = self.indices[t];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// Appends `other` (same material assumed), offsetting its indices.
    pub fn append(&mut self, other: &Mesh) {
        let base = self.positions.len() as u32;
        let with_normals = !self.normals.is_empty() || self.positions.is_empty();
        let with_uvs = !self.uvs.is_empty() || self.positions.is_empty();
        let with_colors = !self.colors.is_empty() || self.positions.is_empty();
        let with_tangents = !self.tangents.is_empty() || self.positions.is_empty();
        if with_tangents && !other.tangents.is_empty() {
            self.tangents.extend_from_slice(&other.tangents);
        } else {
            self.tangents.clear();
        }
        // A part without alpha is opaque (alpha 1), unlike a part without colours.
        if !self.alphas.is_empty() || !other.alphas.is_empty() {
            self.alphas.resize(base as usize, 1.0);
            if other.alphas.is_empty() {
                self.alphas
                    .resize(base as usize + other.positions.len(), 1.0);
            } else {
                self.alphas.extend_from_slice(&other.alphas);
            }
        }
        self.positions.extend_from_slice(&other.positions);
        if with_normals && !other.normals.is_empty() {
            self.normals.extend_from_slice(&other.normals);
        } else {
            self.normals.clear();
        }
        if with_uvs && !other.uvs.is_empty() {
            self.uvs.extend_from_slice(&other.uvs);
        } else {
            self.uvs.clear();
        }
        if with_colors && !other.colors.is_empty() {
            self.colors.extend_from_slice(&other.colors);
        } else {
            self.colors.clear();
        }
        self.indices.extend(
            other
                .indices
                .iter()
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
    }

    /// This mesh with `m` applied to positions and (inverse-transpose) to normals.
    pub fn transformed(mut self, m: &Mat4) -> Mesh {
        let normal_matrix = m.inverse().transpose();
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        for n in &mut self.normals {
            *n = normal_matrix.transform_vector3(*n).normalize_or_zero();
        }
        // A mirror flips normal × tangent against the carried bitangent: flip the handedness.
        let hand = m.determinant().signum();
        for t in &mut self.tangents {
            let v = m.transform_vector3(t.truncate()).normalize_or_zero();
            *t = v.extend(t.w * hand);
        }
        if let Some(a) = &mut self.analytic {
            a.to_mesh = *m * a.to_mesh;
        }
        // A mirroring transform flips the winding; keep geometric normals facing outwards.
        if m.determinant() < 0.0 {
            for t in &mut self.indices {
                t.swap(1, 2);
            }
        }
        self
    }
}

/// A mesh placed in the world by a transform (object → world).
#[derive(Clone, Debug)]
pub struct Instance {
    /// Index into [`crate::Scene::meshes`].
    pub mesh: usize,
    /// Object-to-world transform.
    pub transform: Mat4,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A baked mirror keeps the winding (indices swapped, normals carried), so normal ×
    /// tangent turns against the carried bitangent: w flips and the tangent is carried.
    #[test]
    fn a_mirror_flips_the_tangent_handedness() {
        let mut m = crate::shapes::rectangle(&Mat4::IDENTITY, 0);
        m.tangents = vec![Vec4::new(1.0, 0.0, 0.0, 1.0); 4];
        let mirrored = m
            .clone()
            .transformed(&Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
        let (n, t) = (mirrored.normals[0], mirrored.tangents[0]);
        assert_eq!(t, Vec4::new(-1.0, 0.0, 0.0, -1.0));
        // The carried bitangent is +y, as it was before the mirror.
        assert_eq!(n.cross(t.truncate()) * t.w, Vec3::Y);
        let moved = m.transformed(&Mat4::from_rotation_z(std::f32::consts::FRAC_PI_2));
        let t = moved.tangents[0];
        assert!(
            (t - Vec4::new(0.0, 1.0, 0.0, 1.0)).abs().max_element() < 1e-6,
            "{t}"
        );
    }
}
