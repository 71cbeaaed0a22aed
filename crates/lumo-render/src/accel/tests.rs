//! The 4-wide and 8-wide BVH traversals against brute force, through [`WideBlas`] (the form
//! `Accel` uses). The 8-wide cases run where the CPU has AVX2 and FMA and say so otherwise.

use glam::{Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::Bvh2;
use obvhs::ploc::{PlocBuilder, PlocSearchDistance, SortPrecision};
use obvhs::ray::Ray;
use obvhs::rt_triangle::RtTriangle;

use crate::accel::blas::WideBlas;
use crate::accel::bvh8::Bvh8;
use crate::sampler::hash_u32;

/// A deterministic number in [0, 1) from `i`.
fn rnd(i: u32) -> f32 {
    (hash_u32(i) >> 8) as f32 / 16_777_216.0
}

/// `n` small random triangles in the unit cube.
fn soup(n: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut positions = vec![];
    for t in 0..n {
        let c = Vec3::new(rnd(9 * t), rnd(9 * t + 1), rnd(9 * t + 2));
        for k in 0..3 {
            let j = 9 * t + 3 + 2 * k;
            positions
                .push(c + 0.3 * Vec3::new(rnd(j) - 0.5, rnd(j + 1) - 0.5, rnd(j) - rnd(j + 1)));
        }
    }
    let indices = (0..n).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
    (positions, indices)
}

/// Nearest hit by testing every triangle with obvhs's own intersector.
fn brute(positions: &[Vec3], indices: &[[u32; 3]], o: Vec3, d: Vec3) -> Option<(f32, u32)> {
    let ray = Ray::new(o.into(), d.into(), 0.0, f32::INFINITY);
    let mut best: Option<(f32, u32)> = None;
    for (i, t) in indices.iter().enumerate() {
        let [a, b, c] = t.map(|v| Vec3A::from(positions[v as usize]));
        let h = RtTriangle::new(a, b, c).intersect(&ray);
        if h.is_finite() && best.is_none_or(|(bt, _)| h < bt) {
            best = Some((h, i as u32));
        }
    }
    best
}

/// Compares `bvh` with brute force on rays from outside and inside the cube.
fn check(bvh: &WideBlas, positions: &[Vec3], indices: &[[u32; 3]]) {
    let mut hits = 0;
    for r in 0..2000u32 {
        let o = Vec3::new(rnd(7 * r), rnd(7 * r + 1), rnd(7 * r + 2)) * 3.0 - Vec3::ONE;
        let target = Vec3::new(rnd(7 * r + 3), rnd(7 * r + 4), rnd(7 * r + 5));
        let d = (target - o).normalize();
        let want = brute(positions, indices, o, d);
        let got = bvh.intersect(o, d, 0.0, f32::INFINITY);
        match (want, got) {
            (None, None) => {}
            (Some((t, _)), Some(h)) => {
                hits += 1;
                assert!(
                    (t - h.t).abs() < 1e-4,
                    "ray {r}: t {} vs brute force {t}",
                    h.t
                );
                // Barycentrics reproduce the hit point on the reported triangle.
                let [a, b, c] = indices[h.triangle as usize].map(|v| positions[v as usize]);
                let p = a * (1.0 - h.u - h.v) + b * h.u + c * h.v;
                assert!((p - (o + d * h.t)).length() < 1e-4, "ray {r}");
            }
            (w, g) => panic!("ray {r}: brute force {w:?}, bvh {g:?}"),
        }
        assert_eq!(bvh.occluded(o, d, 0.0, f32::INFINITY), want.is_some());
        if let Some((t, _)) = want {
            // Nothing lies before the nearest hit.
            assert!(!bvh.occluded(o, d, 0.0, t * 0.999), "ray {r}");
            // A window that ends just past the hit sees it, one that starts past it does not
            // see this triangle.
            assert!(bvh.occluded(o, d, 0.0, t * 1.001), "ray {r}");
        }
    }
    assert!(
        hits > 200,
        "only {hits} rays hit: the test would prove little"
    );
}

/// The widths this CPU can traverse.
fn widths() -> Vec<usize> {
    if Bvh8::available() {
        vec![4, 8]
    } else {
        eprintln!("no AVX2 + FMA on this CPU: the 8-wide traversal is not tested here");
        vec![4]
    }
}

fn ploc(positions: &[Vec3], indices: &[[u32; 3]]) -> Bvh2 {
    let tris: Vec<RtTriangle> = indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| Vec3A::from(positions[v as usize]));
            RtTriangle::new(a, b, c)
        })
        .collect();
    PlocBuilder::with_capacity(tris.len()).build(
        PlocSearchDistance::Medium,
        &tris,
        (0..tris.len() as u32).collect(),
        SortPrecision::U64,
        1,
    )
}

#[test]
fn collapsed_ploc_tree_matches_brute_force() {
    // 300 triangles: several levels at either width; 37: a root with partly empty slots.
    for n in [300, 37] {
        let (positions, indices) = soup(n);
        let bvh2 = ploc(&positions, &indices);
        for w in widths() {
            let bvh = WideBlas::build_width(w, &bvh2, &positions, &indices);
            match (&bvh, w) {
                (WideBlas::Four(_), 4) | (WideBlas::Eight(_), 8) => {}
                _ => panic!("asked for width {w}, got {bvh:?}"),
            }
            check(&bvh, &positions, &indices);
        }
    }
}

#[test]
fn a_binary_leaf_with_many_triangles_keeps_them_all() {
    // One leaf holding every triangle: the collapse must chain packets under inner nodes
    // rather than drop triangles past the W-th.
    let (positions, indices) = soup(40);
    let mut bounds = Aabb::empty();
    for p in &positions {
        bounds.extend(Vec3A::from(*p));
    }
    let bvh2 = Bvh2 {
        nodes: vec![Bvh2Node::new(bounds, 40, 0)],
        primitive_indices: (0..40).collect(),
        ..Default::default()
    };
    for w in widths() {
        let bvh = WideBlas::build_width(w, &bvh2, &positions, &indices);
        let packets = match &bvh {
            // Four chunks of 10, each split again into packets of 3, 3, 3 and 1.
            WideBlas::Four(b) => b.size().1,
            // Eight chunks of 5, each one packet.
            WideBlas::Eight(b) => b.tree().size().1,
        };
        assert_eq!(packets, if w == 4 { 16 } else { 8 }, "width {w}");
        check(&bvh, &positions, &indices);
    }
}

#[test]
fn deep_trees_use_the_heap_stack() {
    // A binary tree that is a chain (each inner node: one triangle and the rest) collapses into
    // a wide tree about n/(W−1) levels deep, whose traversal stack outgrows the inline arrays:
    // every hit must still be found.
    let n = 400u32;
    let mut positions = vec![];
    for t in 0..n {
        let x = t as f32 / n as f32;
        positions.extend([
            Vec3::new(x, 0.0, 0.0),
            Vec3::new(x, 1.0, 0.0),
            Vec3::new(x, 0.0, 1.0),
        ]);
    }
    let indices: Vec<[u32; 3]> = (0..n).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
    let bounds = |tris: std::ops::Range<u32>| {
        let mut b = Aabb::empty();
        for t in tris {
            for v in indices[t as usize] {
                b.extend(Vec3A::from(positions[v as usize]));
            }
        }
        b
    };
    // Node 2k: inner over triangles k.., children at 2k+1 (leaf k) and 2k+2 (the rest).
    let mut nodes = vec![];
    for k in 0..n - 1 {
        nodes.push(Bvh2Node::new(bounds(k..n), 0, 2 * k + 1));
        nodes.push(Bvh2Node::new(bounds(k..k + 1), 1, k));
    }
    nodes.push(Bvh2Node::new(bounds(n - 1..n), 1, n - 1));
    let bvh2 = Bvh2 {
        nodes,
        primitive_indices: (0..n).collect(),
        ..Default::default()
    };
    for w in widths() {
        let bvh = WideBlas::build_width(w, &bvh2, &positions, &indices);
        let need = match &bvh {
            WideBlas::Four(b) => b.stack_need,
            WideBlas::Eight(b) => b.tree().stack_need,
        };
        assert!(
            need > 64,
            "width {w}: stack need {need}, the inline stacks would do"
        );
        for k in 0..50u32 {
            let y = 0.05 + 0.4 * rnd(k);
            // Along +x through every triangle: the first one is at x = 0, t = 1.
            let o = Vec3::new(-1.0, y, 0.2);
            let h = bvh.intersect(o, Vec3::X, 0.0, f32::INFINITY).expect("hit");
            assert!(
                (h.t - 1.0).abs() < 1e-5 && h.triangle == 0,
                "width {w}: {h:?}"
            );
            // Starting inside the line: the next triangle ahead, and the one behind.
            let o2 = Vec3::new((n / 2) as f32 / n as f32 + 0.5 / n as f32, y, 0.2);
            let h2 = bvh.intersect(o2, Vec3::X, 0.0, f32::INFINITY).expect("hit");
            assert_eq!(h2.triangle, n / 2 + 1, "width {w}");
            let h3 = bvh
                .intersect(o2, Vec3::NEG_X, 0.0, f32::INFINITY)
                .expect("hit");
            assert_eq!(h3.triangle, n / 2, "width {w}");
            assert!(bvh.occluded(o2, Vec3::NEG_X, 0.0, 1.0), "width {w}");
            assert!(
                !bvh.occluded(o2, Vec3::NEG_X, 0.0, 0.1 / n as f32),
                "width {w}"
            );
        }
    }
}

/// Packets of 1–16 rays through the 8-wide tree find, per ray, exactly the single-ray hit and
/// occlusion, with rays that share origins and with ties (a grid of coplanar triangles hit on
/// their shared edges). Fails if a lane is skipped, a mask bit is mixed up, the box culling
/// drops a lane too early, or ties resolve by visiting order.
#[test]
fn packets_find_the_single_ray_hits_bit_for_bit() {
    use crate::accel::packet::{RayPacket, LANES};
    if !Bvh8::available() {
        eprintln!("no AVX2 + FMA on this CPU: packet traversal is not used or tested here");
        return;
    }
    // A random soup plus a 6×6 grid of quads (two triangles each) in the plane z = 0.5.
    let (mut positions, mut indices) = soup(300);
    for gy in 0..6u32 {
        for gx in 0..6u32 {
            let base = positions.len() as u32;
            for (dx, dy) in [(0, 0), (1, 0), (1, 1), (0, 1)] {
                positions.push(Vec3::new(
                    (gx + dx) as f32 / 6.0,
                    (gy + dy) as f32 / 6.0,
                    0.5,
                ));
            }
            indices.push([base, base + 1, base + 2]);
            indices.push([base, base + 2, base + 3]);
        }
    }
    let bvh2 = ploc(&positions, &indices);
    let WideBlas::Eight(bvh) = WideBlas::build_width(8, &bvh2, &positions, &indices) else {
        panic!("8-wide tree expected");
    };
    let (mut hits, mut blocked, mut ties) = (0, 0, 0);
    for p in 0..400u32 {
        let count = 1 + (p as usize % LANES);
        let mut rays = RayPacket::default();
        for lane in 0..count {
            let r = p * 16 + lane as u32;
            // Every third packet shares one origin (camera-like); some rays aim at grid
            // vertices and edges, where neighbouring triangles tie.
            let o = if p.is_multiple_of(3) {
                Vec3::new(rnd(7 * p), rnd(7 * p + 1), 2.5)
            } else {
                Vec3::new(rnd(7 * r), rnd(7 * r + 1), rnd(7 * r + 2)) * 3.0 - Vec3::ONE
            };
            let target = if r.is_multiple_of(4) {
                ties += 1;
                Vec3::new((r % 7) as f32 / 6.0, ((r / 7) % 7) as f32 / 6.0, 0.5)
            } else {
                Vec3::new(rnd(7 * r + 3), rnd(7 * r + 4), rnd(7 * r + 5))
            };
            let tmax = if r.is_multiple_of(5) {
                1.5
            } else {
                f32::INFINITY
            };
            rays.set(lane, o, (target - o).normalize(), 0.0, tmax);
        }
        let got = bvh.intersect_packet(&rays);
        let occluded = bvh.occluded_packet(&rays);
        // The AVX2 kernels (what AVX2-only CPUs run) agree with the widest one here.
        let got2 = crate::accel::packet::closest_at(false, bvh.tree(), &rays);
        let occluded2 = crate::accel::packet::any_at(false, bvh.tree(), &rays);
        assert_eq!(occluded2, occluded, "packet {p}: AVX2 any-hit kernel");
        for lane in 0..count {
            assert_eq!(
                (
                    got2.t[lane].to_bits(),
                    got2.u[lane].to_bits(),
                    got2.v[lane].to_bits()
                ),
                (
                    got.t[lane].to_bits(),
                    got.u[lane].to_bits(),
                    got.v[lane].to_bits()
                ),
                "packet {p} lane {lane}: AVX2 closest-hit kernel"
            );
            assert_eq!(got2.id[lane], got.id[lane], "packet {p} lane {lane}");
        }
        assert_eq!(
            occluded >> count,
            0,
            "packet {p}: bits past the rays in use"
        );
        for lane in 0..count {
            let o = Vec3::new(rays.o[0][lane], rays.o[1][lane], rays.o[2][lane]);
            let d = Vec3::new(rays.d[0][lane], rays.d[1][lane], rays.d[2][lane]);
            let want = bvh.intersect(o, d, 0.0, rays.tmax[lane]);
            match want {
                None => assert_eq!(got.id[lane], u32::MAX, "packet {p} lane {lane}"),
                Some(h) => {
                    hits += 1;
                    let g = (got.t[lane], got.u[lane], got.v[lane], got.id[lane]);
                    assert_eq!(
                        (g.0.to_bits(), g.1.to_bits(), g.2.to_bits(), g.3),
                        (h.t.to_bits(), h.u.to_bits(), h.v.to_bits(), h.triangle),
                        "packet {p} lane {lane}"
                    );
                }
            }
            let want_blocked = bvh.occluded(o, d, 0.0, rays.tmax[lane]);
            blocked += want_blocked as u32;
            assert_eq!(
                occluded >> lane & 1 == 1,
                want_blocked,
                "packet {p} lane {lane}"
            );
        }
    }
    assert!(
        hits > 1000 && blocked > 1000 && ties > 500,
        "{hits} hits, {blocked} blocked"
    );
}
