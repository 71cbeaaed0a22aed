//! Primitive meshes with Mitsuba's conventions, so scenes written for Mitsuba map exactly.

use std::f32::consts::TAU;

use glam::{Mat4, Vec2, Vec3};

use crate::Mesh;

/// Mitsuba's `rectangle`: the square [-1,1]² in the z = 0 plane facing +z, then `to_world`.
pub fn rectangle(to_world: &Mat4, material: usize) -> Mesh {
    Mesh {
        name: "rectangle".into(),
        positions: vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ],
        normals: vec![Vec3::Z; 4],
        uvs: vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ],
        indices: vec![[0, 1, 2], [2, 3, 0]],
        material,
        colors: Vec::new(),
        alphas: Vec::new(),
        tangents: Vec::new(),
        analytic: None,
    }
    .transformed(to_world)
}

/// Mitsuba's `cube`: [-1,1]³ with outward-facing flat faces, then `to_world`.
pub fn cube(to_world: &Mat4, material: usize) -> Mesh {
    let mut mesh = Mesh {
        name: "cube".into(),
        material,
        ..Default::default()
    };
    // Each face: the rectangle rotated so its +z normal points along the face normal.
    let faces = [
        Mat4::from_translation(Vec3::Z),
        Mat4::from_rotation_y(std::f32::consts::PI) * Mat4::from_translation(Vec3::Z),
        Mat4::from_rotation_y(std::f32::consts::FRAC_PI_2) * Mat4::from_translation(Vec3::Z),
        Mat4::from_rotation_y(-std::f32::consts::FRAC_PI_2) * Mat4::from_translation(Vec3::Z),
        Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2) * Mat4::from_translation(Vec3::Z),
        Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2) * Mat4::from_translation(Vec3::Z),
    ];
    for f in faces {
        mesh.append(&rectangle(&f, material));
    }
    mesh.name = "cube".into();
    mesh.transformed(to_world)
}

/// A UV sphere of radius 1 at the origin with smooth normals, then `to_world`.
pub fn sphere(to_world: &Mat4, material: usize, rings: u32, segments: u32) -> Mesh {
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    for r in 0..=rings {
        let v = r as f32 / rings as f32;
        let theta = v * std::f32::consts::PI;
        for s in 0..=segments {
            let u = s as f32 / segments as f32;
            let phi = u * std::f32::consts::TAU;
            positions.push(Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            ));
            uvs.push(Vec2::new(u, 1.0 - v));
        }
    }
    let mut indices = Vec::new();
    let row = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let a = r * row + s;
            let b = a + row;
            if r != 0 {
                indices.push([a, b, a + 1]);
            }
            if r != rings - 1 {
                indices.push([a + 1, b, b + 1]);
            }
        }
    }
    Mesh {
        name: "sphere".into(),
        normals: positions.clone(),
        positions,
        uvs,
        indices,
        material,
        colors: Vec::new(),
        alphas: Vec::new(),
        tangents: Vec::new(),
        analytic: None,
    }
    .transformed(to_world)
}

/// An open cylinder of radius 1 along +z from z = 0 to z = 1 with smooth normals, then `to_world`.
pub fn cylinder(to_world: &Mat4, material: usize, segments: u32) -> Mesh {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    for s in 0..=segments {
        let u = s as f32 / segments as f32;
        let phi = u * std::f32::consts::TAU;
        let n = Vec3::new(phi.cos(), phi.sin(), 0.0);
        for z in [0.0, 1.0] {
            positions.push(n + Vec3::Z * z);
            normals.push(n);
            uvs.push(Vec2::new(u, z));
        }
    }
    let indices = (0..segments)
        .flat_map(|s| {
            let a = 2 * s;
            [[a, a + 2, a + 1], [a + 1, a + 2, a + 3]]
        })
        .collect();
    Mesh {
        name: "cylinder".into(),
        positions,
        normals,
        uvs,
        indices,
        material,
        colors: Vec::new(),
        alphas: Vec::new(),
        tangents: Vec::new(),
        analytic: None,
    }
    .transformed(to_world)
}

/// Mitsuba's `disk`: the unit disk in z = 0 facing +z, then `to_world`.
pub fn disk(to_world: &Mat4, material: usize, segments: u32) -> Mesh {
    let mut positions = vec![Vec3::ZERO];
    let mut uvs = vec![Vec2::splat(0.5)];
    for s in 0..segments {
        let phi = s as f32 / segments as f32 * std::f32::consts::TAU;
        positions.push(Vec3::new(phi.cos(), phi.sin(), 0.0));
        uvs.push(Vec2::new(0.5 + 0.5 * phi.cos(), 0.5 + 0.5 * phi.sin()));
    }
    let indices = (0..segments)
        .map(|s| [0, 1 + s, 1 + (s + 1) % segments])
        .collect();
    Mesh {
        name: "disk".into(),
        normals: vec![Vec3::Z; positions.len()],
        positions,
        uvs,
        indices,
        material,
        colors: Vec::new(),
        alphas: Vec::new(),
        tangents: Vec::new(),
        analytic: None,
    }
    .transformed(to_world)
}

/// An axis-aligned box between `lo` and `hi` (a convenience over [`cube`]).
pub fn aabox(lo: Vec3, hi: Vec3, material: usize) -> Mesh {
    let m = Mat4::from_translation((lo + hi) * 0.5) * Mat4::from_scale((hi - lo) * 0.5);
    cube(&m, material)
}

// ---- Builders for procedural meshes (the atrium's) ----------------------------------------

/// A (cols × rows)-quad grid with vertex `f(i, j)`, i across, j along; the front faces
/// (∂i × ∂j). With `wrap`, column `cols` is column 0 (closed surfaces of revolution). Smooth
/// normals and uv = (i/cols, j/rows).
pub(crate) fn grid(cols: u32, rows: u32, wrap: bool, f: impl Fn(u32, u32) -> Vec3) -> Mesh {
    let width = if wrap { cols } else { cols + 1 };
    let mut positions = Vec::with_capacity((width * (rows + 1)) as usize);
    let mut uvs = Vec::with_capacity(positions.capacity());
    for j in 0..=rows {
        for i in 0..width {
            positions.push(f(i, j));
            uvs.push(Vec2::new(i as f32 / cols as f32, j as f32 / rows as f32));
        }
    }
    let index = |i: u32, j: u32| j * width + if wrap { i % cols } else { i };
    let mut indices = Vec::with_capacity((2 * cols * rows) as usize);
    for j in 0..rows {
        for i in 0..cols {
            let (a, b, c, d) = (
                index(i, j),
                index(i + 1, j),
                index(i + 1, j + 1),
                index(i, j + 1),
            );
            indices.push([a, b, c]);
            indices.push([c, d, a]);
        }
    }
    let normals = smooth_normals(&positions, &indices);
    Mesh {
        name: "grid".into(),
        positions,
        normals,
        uvs,
        indices,
        material: 0,
        colors: Vec::new(),
        alphas: Vec::new(),
        tangents: Vec::new(),
        analytic: None,
    }
}

/// Area-weighted vertex normals.
pub(crate) fn smooth_normals(positions: &[Vec3], indices: &[[u32; 3]]) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for t in indices {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in t {
            normals[i as usize] += n;
        }
    }
    normals
        .into_iter()
        .map(|n| n.normalize_or(Vec3::Y))
        .collect()
}

/// A surface of revolution about +y through the (radius, height) points of `profile`, which
/// runs bottom to top so the faces point away from the axis (and up where it turns inwards).
pub(crate) fn lathe(profile: &[Vec2], segments: u32) -> Mesh {
    grid(segments, profile.len() as u32 - 1, true, |i, j| {
        let phi = i as f32 / segments as f32 * TAU;
        let p = profile[j as usize];
        Vec3::new(p.x * phi.cos(), p.y, -p.x * phi.sin())
    })
}

/// `n + 1` points of a circular arc in the (radius, height) plane, angles in radians.
pub(crate) fn arc(center: Vec2, radius: f32, from: f32, to: f32, n: u32) -> Vec<Vec2> {
    (0..=n)
        .map(|k| {
            let a = from + (to - from) * k as f32 / n as f32;
            center + radius * Vec2::new(a.cos(), a.sin())
        })
        .collect()
}

/// Appends the quad `q` (a planar convex polygon, either winding) facing `facing`.
pub(crate) fn push_quad(mesh: &mut Mesh, q: [Vec3; 4], facing: Vec3) {
    let n = (q[2] - q[0]).cross(q[3] - q[1]);
    let base = mesh.positions.len() as u32;
    mesh.positions.extend_from_slice(&q);
    if n.dot(facing) >= 0.0 {
        mesh.indices.push([base, base + 1, base + 2]);
        mesh.indices.push([base, base + 2, base + 3]);
    } else {
        mesh.indices.push([base, base + 2, base + 1]);
        mesh.indices.push([base, base + 3, base + 2]);
    }
}

/// An axis-aligned rectangle between `lo` and `hi` (equal along the axis of `facing`),
/// facing `facing`, with uv = world coordinates in its plane (so textures tile per metre).
pub(crate) fn panel(lo: Vec3, hi: Vec3, facing: Vec3, material: usize) -> Mesh {
    let axis = facing.abs().max_position();
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let corner = |a: f32, b: f32| {
        let mut p = lo;
        p[u] = a;
        p[v] = b;
        p
    };
    let q = [
        corner(lo[u], lo[v]),
        corner(hi[u], lo[v]),
        corner(hi[u], hi[v]),
        corner(lo[u], hi[v]),
    ];
    let mut mesh = Mesh {
        name: "panel".into(),
        material,
        ..Default::default()
    };
    push_quad(&mut mesh, q, facing);
    let n = facing.normalize();
    mesh.normals = vec![n; 4];
    mesh.uvs = q.iter().map(|p| Vec2::new(p[u], p[v])).collect();
    mesh
}

/// Concatenates meshes (all with or all without normals and uvs) into one named mesh.
pub(crate) fn merge(name: &str, material: usize, parts: impl IntoIterator<Item = Mesh>) -> Mesh {
    let mut mesh = Mesh {
        name: name.into(),
        material,
        ..Default::default()
    };
    for part in parts {
        mesh.append(&part);
    }
    mesh.name = name.into();
    mesh.material = material;
    mesh
}

/// `mesh` and its mirror image in the x = 0 plane (both colonnades from one side's parts).
pub(crate) fn with_mirror(mesh: Mesh) -> Mesh {
    let mirrored = mesh
        .clone()
        .transformed(&Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
    let mut both = mesh;
    both.append(&mirrored);
    both
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area_and_normal_check(mesh: &Mesh) -> f32 {
        let mut area = 0.0;
        for t in 0..mesh.triangle_count() {
            let [a, b, c] = mesh.triangle(t);
            let n = (b - a).cross(c - a);
            area += 0.5 * n.length();
            // Outward: the geometric normal points away from the centroid of the whole mesh.
            let centroid: Vec3 =
                mesh.positions.iter().copied().sum::<Vec3>() / mesh.positions.len() as f32;
            assert!(n.dot((a + b + c) / 3.0 - centroid) > 0.0, "inward face {t}");
        }
        area
    }

    #[test]
    fn cube_is_closed_and_outward() {
        let m = Mat4::from_scale(Vec3::new(1.0, 2.0, 3.0));
        let c = cube(&m, 0);
        assert_eq!(c.triangle_count(), 12);
        let area = area_and_normal_check(&c);
        assert!((area - 8.0 * (2.0 + 3.0 + 6.0)).abs() < 1e-3);
    }

    #[test]
    fn mirrored_cube_stays_outward() {
        let m = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
        area_and_normal_check(&cube(&m, 0));
    }

    #[test]
    fn sphere_area_close_to_analytic() {
        let s = sphere(&Mat4::IDENTITY, 0, 64, 128);
        let area = area_and_normal_check(&s);
        assert!((area - 4.0 * std::f32::consts::PI).abs() < 0.01 * 4.0 * std::f32::consts::PI);
    }

    #[test]
    fn rectangle_faces_plus_z() {
        let r = rectangle(&Mat4::IDENTITY, 0);
        let [a, b, c] = r.triangle(0);
        assert!((b - a).cross(c - a).z > 0.0);
    }
}
