//! Test fixture: exact (analytic) spheres added to a scene as the Mitsuba loader adds them, a
//! tessellated proxy for bounds and viewers with the exact sphere the renderer intersects
//! (shared by the tests of the flat query and of the vector bounce's sphere lights).

use glam::{Mat4, Vec3};
use lumo_scene::{Analytic, AnalyticKind, Scene};

/// Adds a sphere of `radius` at `centre` with `material` (normals inward if `flip_normals`)
/// and returns its mesh index.
pub(crate) fn add_exact_sphere(
    scene: &mut Scene,
    centre: Vec3,
    radius: f32,
    material: usize,
    flip_normals: bool,
) -> usize {
    let placed = Mat4::from_translation(centre) * Mat4::from_scale(Vec3::splat(radius));
    let mut ball = lumo_scene::shapes::sphere(&placed, material, 6, 12);
    ball.analytic = Some(Analytic {
        kind: AnalyticKind::Sphere,
        to_mesh: placed,
        flip_normals,
    });
    scene.add_mesh(ball)
}

/// Places the instances of `mesh` by a translation by `by` (a shape the instance tree must
/// transform, not only the static BVH's identity).
pub(crate) fn translate_instances(scene: &mut Scene, mesh: usize, by: Vec3) {
    for inst in scene.instances.iter_mut().filter(|i| i.mesh == mesh) {
        inst.transform = Mat4::from_translation(by);
    }
}
