//! A mesh as a binary little-endian PLY file (positions, normals and texture coordinates where
//! the mesh has them, triangles), the layout Mitsuba 3's and lumo's PLY readers take.

use crate::Mesh;

/// The PLY file of `mesh`, in its own object space.
pub(super) fn ply_bytes(mesh: &Mesh) -> Vec<u8> {
    let normals = !mesh.normals.is_empty();
    let uvs = !mesh.uvs.is_empty();
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by lumo export\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        mesh.positions.len()
    );
    if normals {
        header.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if uvs {
        header.push_str("property float u\nproperty float v\n");
    }
    header.push_str(&format!(
        "element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        mesh.indices.len()
    ));
    let per_vertex = 4 * (3 + 3 * normals as usize + 2 * uvs as usize);
    let mut out = Vec::with_capacity(
        header.len() + mesh.positions.len() * per_vertex + mesh.indices.len() * 13,
    );
    out.extend_from_slice(header.as_bytes());
    let put = |v: f32, out: &mut Vec<u8>| out.extend_from_slice(&v.to_le_bytes());
    for (i, p) in mesh.positions.iter().enumerate() {
        for v in p.to_array() {
            put(v, &mut out);
        }
        if normals {
            for v in mesh.normals[i].to_array() {
                put(v, &mut out);
            }
        }
        if uvs {
            for v in mesh.uvs[i].to_array() {
                put(v, &mut out);
            }
        }
    }
    for tri in &mesh.indices {
        out.push(3);
        for i in tri {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::load::load_ply_bytes;
    use glam::{Vec2, Vec3};

    /// What is written reads back through lumo's own PLY reader as the same mesh.
    #[test]
    fn a_mesh_reads_back_as_itself() {
        let mesh = Mesh {
            name: "m".into(),
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(0.25, 2.0, -1.5)],
            normals: vec![Vec3::Z, Vec3::Z, Vec3::new(0.0, 0.6, 0.8)],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::new(0.3, 0.9)],
            indices: vec![[0, 1, 2]],
            ..Default::default()
        };
        let back = load_ply_bytes(
            &ply_bytes(&mesh),
            std::path::Path::new("m.ply"),
            &Default::default(),
        )
        .expect("reads");
        let m = &back.scene.meshes[0];
        assert_eq!(m.positions, mesh.positions);
        assert_eq!(m.indices, mesh.indices);
        assert_eq!(m.uvs, mesh.uvs);
        for (a, b) in m.normals.iter().zip(&mesh.normals) {
            assert!((*a - *b).length() < 1e-6, "{a} vs {b}");
        }
    }
}
