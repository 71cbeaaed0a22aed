//! Per-vertex alpha (glTF `COLOR_0`'s fourth component) at a hit, for opacity masks.

use super::{RenderScene, Surface};

impl RenderScene {
    /// The mesh's vertex alpha interpolated at `s` (1 for meshes without alpha). The surface
    /// record does not keep the hit's barycentrics, so they are recovered from the hit point
    /// and the triangle's corners: only masked meshes with vertex alpha pay for it.
    pub(super) fn vertex_alpha(&self, s: &Surface) -> f32 {
        let Some(inst) = self.scene.instances.get(s.instance as usize) else {
            return 1.0;
        };
        let mesh = &self.scene.meshes[inst.mesh];
        if mesh.alphas.is_empty() || mesh.analytic.is_some() {
            return 1.0;
        }
        let Some(&tri) = mesh.indices.get(s.triangle as usize) else {
            return 1.0;
        };
        let [i0, i1, i2] = tri.map(|i| i as usize);
        let place = &self.placements[s.instance as usize];
        let [p0, p1, p2] = [i0, i1, i2].map(|i| {
            let p = mesh.positions[i];
            if place.identity {
                p
            } else {
                place.to_world.transform_point3(p)
            }
        });
        // Barycentrics of the point in the triangle's plane (areas against the normal).
        let (e1, e2, d) = (p1 - p0, p2 - p0, s.p - p0);
        let n = e1.cross(e2);
        let nn = n.length_squared();
        if nn == 0.0 || !nn.is_finite() {
            return mesh.alphas[i0].clamp(0.0, 1.0);
        }
        let u = (d.cross(e2).dot(n) / nn).clamp(0.0, 1.0);
        let v = (e1.cross(d).dot(n) / nn).clamp(0.0, 1.0 - u);
        let a = mesh.alphas[i0] * (1.0 - u - v) + mesh.alphas[i1] * u + mesh.alphas[i2] * v;
        a.clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use glam::{Mat4, Vec3};
    use lumo_scene::shapes::rectangle;
    use lumo_scene::{BsdfSpec, Camera, FovAxis, Instance, Material, Scene, Texture};

    use crate::render_scene::RenderScene;

    /// The opacity a ray straight down onto the plane z = `z` meets at (x, y): the mask's
    /// factor 0.8 × vertex alpha rising linearly from 0 at x = −1 to 1 at x = 1, thresholded
    /// at the hit for MASK (`cutoff`).
    fn opacities(cutoff: Option<f32>) -> Vec<(f32, f32, f32)> {
        let mut scene = Scene::empty(Camera {
            origin: Vec3::new(0.0, 0.0, 5.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov: 40.0,
            fov_axis: FovAxis::X,
            lens: Default::default(),
            filter: Default::default(),
        });
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
