//! Predicts the input on which PLOC stalls because its merge costs tie: identical boxes spaced
//! evenly along a line (100,000 small triangles in a row took about 70 s to build).
//!
//! PLOC merges two clusters when each is the other's cheapest neighbour in the Morton order.
//! obvhs breaks a cost tie towards the neighbour ahead, so where every neighbouring pair
//! costs the same (equal boxes at equal steps: the Morton order of points on a line is their
//! order along it) no pair is mutual except the last, each pass merges one pair, and the build
//! does O(n) passes of O(n) work. A grid or a curve varies the costs (the Morton order jumps
//! between rows; rounding differs along a curve) and PLOC stays fast there, so no geometric
//! test (collinear centres) predicts the stall; and a line of pairs, merged in the first pass,
//! stalls only in the second. [`ploc_stalls`] therefore replays PLOC's passes (obvhs's
//! Morton order, search windows and tie rules) until the clusters are few, and calls it a
//! stall once the passes have visited [`WORK_PER_BOX`] clusters per box: O(n log n) for the
//! sort, O(n) for the passes, whose windows are of a fixed size.

use obvhs::aabb::Aabb;
use obvhs::ploc::morton::morton_encode_u64_unorm;

/// Fewest boxes checked, and the clusters left when the replay stops: PLOC's worst case on
/// this many is a fraction of a second (a row of 4,096 costs about 0.2 s), and below it
/// PLOC's last passes may merge slowly without costing much (a ring of 10,000 small
/// triangles builds in 50 ms, though its last 2,000 clusters merge a few per pass).
pub(crate) const MIN_PRIMITIVES: usize = 4096;

/// Clusters the passes may visit in all, per box, before the build counts as stalled: passes
/// that merge a fair share of their clusters visit a few per box in all (a geometric series),
/// a stalled build about n/2 per box.
const WORK_PER_BOX: usize = 16;

/// Neighbours on each side PLOC searches after its first passes: obvhs's
/// `PlocSearchDistance::Medium`, which [`super::robust`] builds with.
pub(crate) const SEARCH_DISTANCE: usize = 14;

/// Whether obvhs's PLOC, searching one neighbour for its first `near_passes` passes and
/// [`SEARCH_DISTANCE`] after, would merge almost nothing per pass on `boxes` (see the module
/// notes).
pub(crate) fn ploc_stalls(boxes: &[Aabb], near_passes: usize) -> bool {
    if boxes.len() < MIN_PRIMITIVES {
        return false;
    }
    // The Morton order obvhs sorts by: box centres scaled into the union of the boxes.
    let total = boxes.iter().fold(Aabb::empty(), |t, b| t.union(b));
    let scale = 1.0 / total.diagonal().as_dvec3();
    let offset = -total.min.as_dvec3() * scale;
    let code = |b: &Aabb| morton_encode_u64_unorm(b.center().as_dvec3() * scale + offset);
    let mut order: Vec<(u64, u32)> = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| (code(b), i as u32))
        .collect();
    order.sort_unstable();
    let mut nodes: Vec<Aabb> = order.iter().map(|&(_, i)| boxes[i as usize]).collect();
    drop(order);
    let mut best: Vec<usize> = Vec::with_capacity(nodes.len());
    let mut next: Vec<Aabb> = Vec::with_capacity(nodes.len());
    let (mut pass, mut work) = (0, 0);
    while nodes.len() > MIN_PRIMITIVES {
        let n = nodes.len();
        best.clear();
        if pass < near_passes {
            // One neighbour: node i takes its left one only when that merge is strictly
            // cheaper (obvhs's rule), the last node always its left.
            let cost = |i: usize| nodes[i].union(&nodes[i + 1]).half_area();
            let mut left = f32::INFINITY;
            for i in 0..n - 1 {
                let c = cost(i);
                best.push(if left < c { i - 1 } else { i + 1 });
                left = c;
            }
            best.push(n - 2);
        } else {
            // The cheapest within the window, the later one on a tie (obvhs's `<=`).
            for i in 0..n {
                let mut pick = (i, f32::INFINITY);
                let window = i.saturating_sub(SEARCH_DISTANCE)..(i + SEARCH_DISTANCE + 1).min(n);
                for j in window.filter(|&j| j != i) {
                    let c = nodes[i].union(&nodes[j]).half_area();
                    if c <= pick.1 {
                        pick = (j, c);
                    }
                }
                best.push(pick.0);
            }
        }
        next.clear();
        for i in 0..n {
            let j = best[i];
            if best[j] != i {
                next.push(nodes[i]);
            } else if j < i {
                // At the later node's place, as obvhs puts it.
                next.push(nodes[i].union(&nodes[j]));
            }
        }
        work += n;
        if work > WORK_PER_BOX * boxes.len() {
            return true;
        }
        std::mem::swap(&mut nodes, &mut next);
        pass += 1;
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    fn ploc_stalls3(boxes: &[Aabb]) -> bool {
        ploc_stalls(boxes, 3)
    }

    fn tri_box(a: Vec3A, b: Vec3A, c: Vec3A) -> Aabb {
        Aabb::new(a.min(b).min(c), a.max(b).max(c))
    }

    /// Small triangles at every unit step along `dir` from `from`.
    fn row(n: usize, from: Vec3A, dir: Vec3A) -> Vec<Aabb> {
        (0..n)
            .map(|i| {
                let p = from + dir * i as f32;
                tri_box(p, p + Vec3A::X * 1e-3, p + Vec3A::Y * 1e-3)
            })
            .collect()
    }

    #[test]
    fn rows_of_equal_triangles_stall() {
        assert!(ploc_stalls3(&row(10_000, Vec3A::ZERO, Vec3A::X)));
        assert!(ploc_stalls3(&row(10_000, Vec3A::ZERO, Vec3A::ONE)));
        // Two triangles per step: the first pass merges the pairs, the second stalls.
        let pairs: Vec<Aabb> = row(5_000, Vec3A::ZERO, Vec3A::X)
            .into_iter()
            .flat_map(|b| [b, b])
            .collect();
        assert!(ploc_stalls3(&pairs));
    }

    #[test]
    fn grids_curves_and_random_triangles_do_not() {
        let mut grid = vec![];
        for y in 0..100 {
            grid.extend(row(100, Vec3A::new(0.0, y as f32, 0.0), Vec3A::X));
        }
        assert!(!ploc_stalls3(&grid));
        let ring: Vec<Aabb> = (0..10_000)
            .map(|i| {
                let a = std::f32::consts::TAU * i as f32 / 10_000.0;
                let p = Vec3A::new(a.cos(), a.sin(), 0.0) * 1000.0;
                tri_box(p, p + Vec3A::X * 1e-3, p + Vec3A::Y * 1e-3)
            })
            .collect();
        assert!(!ploc_stalls3(&ring));
        // A fixed linear congruential sequence: triangles of random size and place.
        let mut s = 12345u64;
        let mut r = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        let random: Vec<Aabb> = (0..10_000)
            .map(|_| {
                let p = Vec3A::new(r(), r(), r()) * 10.0;
                tri_box(
                    p,
                    p + Vec3A::new(r(), r(), 0.0) * 0.1,
                    p + Vec3A::Y * r() * 0.1,
                )
            })
            .collect();
        assert!(!ploc_stalls3(&random));
    }
}
