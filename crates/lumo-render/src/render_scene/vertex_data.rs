//! Per-vertex data at a hit that only some materials need (glTF `COLOR_0`'s alpha for
//! opacity masks, `TANGENT` for normal maps), interpolated on demand.

use glam::{Vec3, Vec4};
use lumo_scene::Mesh;

use super::{RenderScene, Surface};

impl RenderScene {
    /// The triangle mesh under `s`, its corners' vertex indices and the hit's barycentric
    /// weights. The surface record does not keep the hit's barycentrics, so they are recovered
    /// from the hit point and the triangle's corners: only the meshes that need per-vertex
    /// data beyond the normal, uv and colour pay for it. `None` for analytic shapes.
    fn corners(&self, s: &Surface) -> Option<(&Mesh, [usize; 3], [f32; 3])> {
        let inst = self.scene.instances.get(s.instance as usize)?;
        let mesh = &self.scene.meshes[inst.mesh];
        if mesh.analytic.is_some() {
            return None;
        }
        let idx = mesh.indices.get(s.triangle as usize)?.map(|i| i as usize);
        let place = &self.placements[s.instance as usize];
        let [p0, p1, p2] = idx.map(|i| {
            let p = mesh.positions[i];
            if place.identity {
                p
            } else {
                place.to_world.transform_point3(p)
            }
        });
        // Areas against the triangle's normal.
        let (e1, e2, d) = (p1 - p0, p2 - p0, s.p - p0);
        let n = e1.cross(e2);
        let nn = n.length_squared();
        if nn == 0.0 || !nn.is_finite() {
            return Some((mesh, idx, [1.0, 0.0, 0.0]));
        }
        let u = (d.cross(e2).dot(n) / nn).clamp(0.0, 1.0);
        let v = (e1.cross(d).dot(n) / nn).clamp(0.0, 1.0 - u);
        Some((mesh, idx, [1.0 - u - v, u, v]))
    }

    /// The mesh's vertex alpha interpolated at `s` (1 for meshes without alpha).
    pub(super) fn vertex_alpha(&self, s: &Surface) -> f32 {
        if self.mesh_of(s).is_none_or(|m| m.alphas.is_empty()) {
            return 1.0;
        }
        let Some((mesh, idx, w)) = self.corners(s) else {
            return 1.0;
        };
        let a: f32 = (0..3).map(|k| mesh.alphas[idx[k]] * w[k]).sum();
        a.clamp(0.0, 1.0)
    }

    /// The mesh's tangent interpolated at `s` in world space, with its handedness in w
    /// (`None` for meshes without tangents or where it vanishes).
    pub(super) fn vertex_tangent(&self, s: &Surface) -> Option<Vec4> {
        if self.mesh_of(s)?.tangents.is_empty() {
            return None;
        }
        let (mesh, idx, w) = self.corners(s)?;
        let t: Vec3 = (0..3)
            .map(|k| mesh.tangents[idx[k]].truncate() * w[k])
            .sum();
        // The handedness of the corner that weighs most (corners of one uv island agree).
        let k = (0..3).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap_or(0);
        let hand = mesh.tangents[idx[k]].w;
        let place = &self.placements[s.instance as usize];
        // No handedness flip under a mirroring placement: the shading normal follows the
        // world winding there, which flips with the mirror, so normal × tangent still gives
        // the carried bitangent (`Mesh::transformed`, which keeps the winding, flips w).
        let t = if place.identity {
            t
        } else {
            place.to_world.transform_vector3(t)
        };
        t.try_normalize().map(|t| t.extend(hand))
    }

    fn mesh_of(&self, s: &Surface) -> Option<&Mesh> {
        let inst = self.scene.instances.get(s.instance as usize)?;
        self.scene.meshes.get(inst.mesh)
    }
}

#[cfg(test)]
mod tests {
    use glam::{Mat4, Vec3};
    use lumo_scene::shapes::rectangle;
    use lumo_scene::{BsdfSpec, Instance, Material, Scene, Texture};

    use crate::render_scene::RenderScene;

    /// The opacity a ray straight down onto the plane z = `z` meets at (x, y): the mask's
    /// factor 0.8 × vertex alpha rising linearly from 0 at x = −1 to 1 at x = 1, thresholded
    /// at the hit for MASK (`cutoff`).
    fn opacities(cutoff: Option<f32>) -> Vec<(f32, f32, f32)> {
        let mut scene = Scene::empty(crate::test_camera::camera_facing_origin(Vec3::new(
            0.0, 0.0, 5.0,
        )));
        let mut m = Material::diffuse("leaf", Vec3::splat(0.5));
        m.bsdf = BsdfSpec::Mask {
            opacity: Texture::Constant(Vec3::splat(0.8)),
            cutoff,
            nested: Box::new(m.bsdf),
        };
        let m = scene.add_material(m);
        let mut quad = rectangle(&Mat4::IDENTITY, m);
        // Corners (−1, −1), (1, −1), (1, 1), (−1, 1).
        quad.alphas = vec![0.0, 1.0, 1.0, 0.0];
        let mesh = scene.add_mesh(quad);
        // A second placement, stretched along y and moved down, to exercise the transform.
        scene.instances.push(Instance {
            mesh,
            transform: Mat4::from_translation(Vec3::new(0.0, 0.0, -3.0))
                * Mat4::from_scale(Vec3::new(1.0, 2.0, 1.0)),
        });
        let rs = RenderScene::new(scene).expect("scene");
        let mut out = Vec::new();
        for i in 0..40 {
            for (y, z) in [(0.3, 0.0), (-1.5, -3.0)] {
                let x = -0.975 + i as f32 * 0.05;
                let origin = Vec3::new(x, y, z + 1.0);
                let hit = rs
                    .accel
                    .intersect(origin, -Vec3::Z, 0.0, 2.0)
                    .expect("the ray meets the quad");
                let s = rs.surface(&hit, origin, -Vec3::Z);
                out.push((x, z, rs.bsdf(&s).opacity()));
            }
        }
        out
    }

    /// BLEND: the opacity is the factor × the vertex alpha interpolated at the hit.
    #[test]
    fn vertex_alpha_multiplies_the_opacity() {
        for (x, z, o) in opacities(None) {
            let want = 0.8 * (x + 1.0) / 2.0;
            assert!((o - want).abs() < 1e-4, "x {x} z {z}: {o} vs {want}");
        }
    }

    /// MASK: opaque exactly where factor × vertex alpha ≥ the cutoff (x ≥ 0.25 for 0.5), the
    /// edge following the interpolated alpha rather than the vertices.
    #[test]
    fn mask_cutoff_applies_after_the_vertex_alpha() {
        for (x, z, o) in opacities(Some(0.5)) {
            let want = if x >= 0.25 { 1.0 } else { 0.0 };
            assert_eq!(o, want, "x {x} z {z}");
        }
    }
}

#[cfg(test)]
mod tangent_tests {
    use glam::{Mat4, Vec3, Vec4};
    use lumo_scene::shapes::rectangle;
    use lumo_scene::{Instance, Material, Scene, Texture};

    use crate::render_scene::RenderScene;

    /// The world normal a constant normal-map texel `c` gives where a ray straight down meets
    /// the z = 0 quad (uvs along x and y, so ∂p/∂u = +x) whose vertices carry `tangents`,
    /// placed as is and mirrored in x.
    fn mapped(tangents: Vec<Vec4>, c: Vec3) -> [Vec3; 2] {
        let mut scene = Scene::empty(crate::test_camera::camera_facing_origin(Vec3::new(
            0.0, 0.0, 5.0,
        )));
        let m = scene.add_material(Material::diffuse("m", Vec3::splat(0.5)));
        let mut quad = rectangle(&Mat4::IDENTITY, m);
        quad.tangents = tangents;
        let mesh = scene.add_mesh(quad);
        scene.instances.push(Instance {
            mesh,
            transform: Mat4::from_translation(Vec3::new(0.0, 0.0, -3.0))
                * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)),
        });
        let rs = RenderScene::new(scene).expect("scene");
        [0.0f32, -3.0].map(|z| {
            let origin = Vec3::new(0.3, 0.2, z + 1.0);
            let hit = rs
                .accel
                .intersect(origin, -Vec3::Z, 0.0, 2.0)
                .expect("a hit");
            let s = rs.surface(&hit, origin, -Vec3::Z);
            let local = rs
                .normal_mapped(&s, &Texture::Constant(c), 0.0)
                .expect("a tilted normal");
            s.frame.to_world(local)
        })
    }

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b.normalize()).abs().max_element() < 1e-5
    }

    /// A texel tilted along the tangent follows the given tangent (+y), not ∂p/∂u (+x). The
    /// mirrored placement faces −z (lumo's shading normal follows the world winding).
    #[test]
    fn the_given_tangent_orients_the_normal_map() {
        let tilt_t = Vec3::new(0.8, 0.5, 1.0); // (0.6, 0, 1) in tangent space
        let [plain, mirrored] = mapped(vec![Vec4::new(0.0, 1.0, 0.0, 1.0); 4], tilt_t);
        assert!(close(plain, Vec3::new(0.0, 0.6, 1.0)), "{plain}");
        assert!(close(mirrored, Vec3::new(0.0, 0.6, -1.0)), "{mirrored}");
        // Without tangents: ∂p/∂u, +x (−x under the mirror, which reverses u's direction).
        let [plain, mirrored] = mapped(Vec::new(), tilt_t);
        assert!(close(plain, Vec3::new(0.6, 0.0, 1.0)), "{plain}");
        assert!(close(mirrored, Vec3::new(-0.6, 0.0, -1.0)), "{mirrored}");
    }

    /// The tangent's w turns the bitangent (n × t = z × y = −x for w = 1, +x for w = −1),
    /// and a given tangent equal to ∂p/∂u with w = 1 is the generated frame, placed as is or
    /// mirrored.
    #[test]
    fn the_tangent_handedness_turns_the_bitangent() {
        let tilt_b = Vec3::new(0.5, 0.8, 1.0); // (0, 0.6, 1) in tangent space
        let [plain, mirrored] = mapped(vec![Vec4::new(0.0, 1.0, 0.0, 1.0); 4], tilt_b);
        assert!(close(plain, Vec3::new(-0.6, 0.0, 1.0)), "{plain}");
        assert!(close(mirrored, Vec3::new(0.6, 0.0, -1.0)), "{mirrored}");
        let [plain, mirrored] = mapped(vec![Vec4::new(0.0, 1.0, 0.0, -1.0); 4], tilt_b);
        assert!(close(plain, Vec3::new(0.6, 0.0, 1.0)), "{plain}");
        assert!(close(mirrored, Vec3::new(-0.6, 0.0, -1.0)), "{mirrored}");
        for c in [tilt_b, Vec3::new(0.7, 0.2, 0.9)] {
            let given = mapped(vec![Vec4::new(1.0, 0.0, 0.0, 1.0); 4], c);
            let generated = mapped(Vec::new(), c);
            for (g, d) in given.iter().zip(&generated) {
                assert!((*g - *d).abs().max_element() < 1e-5, "{g} vs {d}");
            }
        }
    }
}
