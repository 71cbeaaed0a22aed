//! Primitive meshes with Mitsuba's conventions, so scenes written for Mitsuba map exactly.

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
        analytic: None,
    }
    .transformed(to_world)
}

/// An axis-aligned box between `lo` and `hi` (a convenience over [`cube`]).
pub fn aabox(lo: Vec3, hi: Vec3, material: usize) -> Mesh {
    let m = Mat4::from_translation((lo + hi) * 0.5) * Mat4::from_scale((hi - lo) * 0.5);
    cube(&m, material)
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
