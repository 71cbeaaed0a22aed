//! The flat query ([`super`]) against the instance tree it replaces, bit for bit: nearest hits
//! (distance, instance, triangle, barycentrics) and occlusion, ray by ray and in packets.

use glam::{Mat4, Vec3};
use lumo_scene::{builtin_scene, Scene};

use crate::accel::packet::{RayPacket, LANES};
use crate::accel::{Accel, Hit};
use crate::sampler::hash_u32;
use crate::test_shapes::{add_exact_sphere, translate_instances};

/// A deterministic number in [0, 1) from `i`.
fn rnd(i: u32) -> f32 {
    (hash_u32(i) >> 8) as f32 / 16_777_216.0
}

/// The Cornell box (walls and boxes merged into the static BVH) with `n` exact spheres: some
/// large and cutting the walls, some lamp-sized, one placed by an instance transform.
fn cornell_with_spheres(n: u32) -> Scene {
    let mut scene = builtin_scene("cornell").expect("built-in");
    let material = scene.meshes[0].material;
    for k in 0..n {
        let c = Vec3::new(rnd(5 * k), rnd(5 * k + 1), rnd(5 * k + 2)) * 2.0 - Vec3::ONE;
        let r = if k % 2 == 0 {
            0.02 + 0.05 * rnd(5 * k + 3)
        } else {
            0.1 + 0.4 * rnd(5 * k + 3)
        };
        let mesh = add_exact_sphere(&mut scene, c, r, material, false);
        if k == 1 {
            translate_instances(&mut scene, mesh, Vec3::new(0.1, -0.05, 0.02));
        }
    }
    scene
}

/// A ray numbered `r`: from inside the box or outside it, aimed at a sphere's centre for
/// every third, with a finite `tmax` for every fifth.
fn ray(scene: &Scene, r: u32) -> (Vec3, Vec3, f32) {
    let o = Vec3::new(rnd(7 * r), rnd(7 * r + 1), rnd(7 * r + 2)) * 3.0 - Vec3::splat(1.5);
    let spheres: Vec<Mat4> = scene
        .meshes
        .iter()
        .filter_map(|m| m.analytic.map(|a| a.to_mesh))
        .collect();
    let target = if r.is_multiple_of(3) && !spheres.is_empty() {
        let m = spheres[r as usize / 3 % spheres.len()];
        // Near the centre, and sometimes near the rim.
        m.transform_point3(Vec3::new(rnd(7 * r + 3), rnd(7 * r + 4), rnd(7 * r + 5)) * 1.9 - 0.95)
    } else {
        Vec3::new(rnd(7 * r + 3), rnd(7 * r + 4), rnd(7 * r + 5)) * 2.0 - Vec3::ONE
    };
    let tmax = if r.is_multiple_of(5) {
        0.2 + 2.0 * rnd(7 * r + 6)
    } else {
        f32::INFINITY
    };
    ((o), (target - o).normalize(), tmax)
}

#[test]
fn flat_queries_match_the_instance_tree() {
    for n in [1, 3, 8] {
        let scene = cornell_with_spheres(n);
        scene.validate().expect("valid scene");
        let flat = Accel::build(&scene);
        assert!(flat.flat(), "{n} spheres: the flat query should apply");
        let mut tree = Accel::build(&scene);
        tree.flat_boxes.clear();
        let (mut sphere_hits, mut wall_hits, mut blocked) = (0, 0, 0);
        for p in 0..300u32 {
            let count = 1 + (p as usize % LANES);
            let mut rays = RayPacket::default();
            for lane in 0..count {
                let r = p * LANES as u32 + lane as u32;
                let (o, d, tmax) = ray(&scene, r);
                rays.set(lane, o, d, 0.0, tmax);
                let want = tree.intersect(o, d, 0.0, tmax);
                assert_eq!(
                    Hit::bits(flat.intersect(o, d, 0.0, tmax)),
                    Hit::bits(want),
                    "{n} spheres, ray {r}"
                );
                let occluded = tree.occluded(o, d, 0.0, tmax);
                assert_eq!(
                    flat.occluded(o, d, 0.0, tmax),
                    occluded,
                    "{n} spheres, ray {r}"
                );
                blocked += occluded as u32;
                if let Some(h) = want {
                    if scene.meshes[scene.instances[h.instance as usize].mesh]
                        .analytic
                        .is_some()
                    {
                        sphere_hits += 1;
                    } else {
                        wall_hits += 1;
                    }
                }
            }
            let mut got = [None; LANES];
            flat.intersect_packet(&rays, &mut got);
            let mask = flat.occluded_packet(&rays);
            assert_eq!(
                mask >> count,
                0,
                "{n} spheres, packet {p}: bits past the rays"
            );
            for (lane, &hit) in got.iter().enumerate().take(count) {
                let r = p * LANES as u32 + lane as u32;
                let (o, d, tmax) = ray(&scene, r);
                assert_eq!(
                    Hit::bits(hit),
                    Hit::bits(tree.intersect(o, d, 0.0, tmax)),
                    "{n} spheres, packet ray {r}"
                );
                assert_eq!(
                    mask >> lane & 1 == 1,
                    tree.occluded(o, d, 0.0, tmax),
                    "{n} spheres, packet ray {r}"
                );
            }
        }
        assert!(
            sphere_hits > 200 && wall_hits > 200 && blocked > 400,
            "{n} spheres: {sphere_hits} sphere hits, {wall_hits} other hits, {blocked} blocked"
        );
    }
}

#[test]
fn many_shapes_or_moved_meshes_keep_the_instance_tree() {
    let scene = cornell_with_spheres(super::MAX_SHAPES as u32 + 1);
    assert!(!Accel::build(&scene).flat());
    let mut scene = cornell_with_spheres(2);
    scene.instances[0].transform = Mat4::from_translation(Vec3::X);
    assert!(!Accel::build(&scene).flat());
}
