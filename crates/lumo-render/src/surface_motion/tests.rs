use super::*;
use crate::test_camera::camera_facing_origin;
use lumo_scene::shapes::rectangle;
use lumo_scene::{Instance, Material};

/// A 2 × 2 quad at z = 0 seen from +z, as its own mesh (mesh 0) and as a second, rigid copy
/// (mesh 1) beside it.
fn two_quads() -> Scene {
    let mut scene = Scene::empty(camera_facing_origin(Vec3::new(0.0, 0.0, 8.0)));
    let m = scene.add_material(Material::diffuse("m", Vec3::splat(0.5)));
    scene.add_mesh(rectangle(
        &Mat4::from_translation(Vec3::new(-1.2, 0.0, 0.0)),
        m,
    ));
    let rigid = scene.add_mesh(rectangle(&Mat4::IDENTITY, m));
    scene.instances.last_mut().expect("added").transform =
        Mat4::from_translation(Vec3::new(1.2, 0.0, 0.0));
    assert_eq!(rigid, 1);
    scene
}

/// The world point of `hit` under the scene as it is.
fn hit_point(scene: &Scene, hit: &PixelHit) -> Vec3 {
    let inst: &Instance = &scene.instances[hit.instance as usize];
    let mesh = &scene.meshes[inst.mesh];
    let [a, b, c] = mesh.indices[hit.triangle as usize].map(|i| mesh.positions[i as usize]);
    let [u, v] = hit.uv;
    inst.transform
        .transform_point3(a * (1.0 - u - v) + b * u + c * v)
}

/// A sheared quad (x += 0.3 · y, a deformation no transform of the instance describes) and a
/// moved instance: the step back on the deforming mesh is exactly the shear undone plus the
/// instance's own motion, and NaN on the mesh not listed as deforming and where the ray hits
/// nothing.
#[test]
fn the_step_back_undoes_a_deformation_and_the_instance_motion() {
    let scene = two_quads();
    let then = MeshPoses::capture(&scene, &[0]);
    let mut rs = RenderScene::new(scene).expect("valid scene");
    for p in &mut rs.scene.meshes[0].positions {
        p.x += 0.3 * (p.y + 1.0);
    }
    rs.scene.instances[0].transform = Mat4::from_translation(Vec3::new(0.0, 0.1, 0.0));
    rs.update(&[0]).expect("refit");
    assert!(then.deformed_since(&rs.scene));
    assert!(!MeshPoses::capture(&rs.scene, &[0]).deformed_since(&rs.scene));
    let (w, h) = (48, 32);
    let camera = PinholeCamera::new(&rs.scene.camera, w, h);
    let hits = pixel_hits(&rs, &camera, w, h);
    let back = deformation_back(&rs.scene, &hits, &then);
    let (mut deformed, mut rigid, mut missed) = (0, 0, 0);
    for (hit, step) in hits.iter().zip(&back) {
        match hit.instance {
            0 => {
                deformed += 1;
                // Now the point is at ((x0 − 1.2) + 0.3 (y0 + 1), y0 + 0.1) for its rest
                // point (x0 − 1.2, y0): the step back is (−0.3 (y0 + 1), −0.1).
                let p = hit_point(&rs.scene, hit);
                let y0 = p.y - 0.1;
                let want = Vec3::new(-0.3 * (y0 + 1.0), -0.1, 0.0);
                assert!((*step - want).length() < 1e-5, "{step} vs {want}");
            }
            1 => {
                rigid += 1;
                assert!(step.is_nan());
            }
            _ => {
                missed += 1;
                assert!(step.is_nan());
            }
        }
    }
    assert!(
        deformed > 100 && rigid > 100 && missed > 100,
        "{deformed} {rigid} {missed}"
    );
}

/// The hits are those `instance_ids` reports, and a changed vertex count gives no step.
#[test]
fn hits_match_instance_ids_and_a_changed_mesh_gives_no_step() {
    let scene = two_quads();
    let mut then = MeshPoses::capture(&scene, &[0, 1, 7]);
    assert_eq!(then.meshes.len(), 2, "mesh 7 does not exist");
    let rs = RenderScene::new(scene).expect("valid scene");
    let camera = PinholeCamera::new(&rs.scene.camera, 24, 16);
    let hits = pixel_hits(&rs, &camera, 24, 16);
    let ids = crate::instance_ids(&rs, &camera, 24, 16);
    assert!(hits.iter().zip(&ids).all(|(h, &i)| h.instance == i));
    // Nothing moved: every step on a mesh is zero.
    let back = deformation_back(&rs.scene, &hits, &then);
    assert!(hits
        .iter()
        .zip(&back)
        .all(|(h, s)| (h.instance == u32::MAX) == s.is_nan() && (s.is_nan() || *s == Vec3::ZERO)));
    then.meshes[0].1.pop();
    let back = deformation_back(&rs.scene, &hits, &then);
    assert!(hits
        .iter()
        .zip(&back)
        .all(|(h, s)| (h.instance == 1) != s.is_nan()));
}

/// Forward, as re-shading uses it: a point hit on the quad before it was sheared and moved
/// is carried to the same barycentric place on the deformed quad, exactly where the shear
/// and the motion take it, and its `then` is the point the ray hit.
#[test]
fn a_point_hit_before_a_deformation_is_carried_to_its_place_after() {
    let scene = two_quads();
    let then = MeshPoses::capture(&scene, &[0]);
    let mut rs = RenderScene::new(scene).expect("valid scene");
    let (w, h) = (48, 32);
    let camera = PinholeCamera::new(&rs.scene.camera, w, h);
    let hits = pixel_hits(&rs, &camera, w, h);
    let first = crate::camera_hits(&rs, &camera, w, h);
    for p in &mut rs.scene.meshes[0].positions {
        p.x += 0.3 * (p.y + 1.0);
    }
    rs.scene.instances[0].transform = Mat4::from_translation(Vec3::new(0.0, 0.1, 0.0));
    rs.update(&[0]).expect("refit");
    let mut carried = 0;
    for (i, (hit, ray_hit)) in hits.iter().zip(&first).enumerate() {
        let d = deformed_point(&rs.scene, hit, &then);
        if hit.instance != 0 {
            assert!(d.is_none(), "only the deforming mesh's points are carried");
            continue;
        }
        let d = d.expect("a point on the deforming mesh");
        let (o, dir) = crate::pixel_centre_ray(&camera, i % w, i / w);
        let was = o + dir * ray_hit.expect("a hit").t;
        assert!((d.then - was).length() < 1e-5, "{} vs {was}", d.then);
        let want = Vec3::new(was.x + 0.3 * (was.y + 1.0), was.y + 0.1, was.z);
        assert!((d.now - want).length() < 1e-5, "{} vs {want}", d.now);
        carried += 1;
    }
    assert!(carried > 100, "{carried} points");
}
