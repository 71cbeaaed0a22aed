//! A top-down object-median build: the fallback of [`super::robust::build_bvh2`] for boxes that
//! overlap so much that PLOC degenerates to quadratic time.
//!
//! PLOC merges mutual nearest neighbours along the Morton order. When nearly every box covers
//! nearly the whole mesh — the triangles of a fan, as in a triangulated n-gon or a disk's cap —
//! merging any two costs about the same, few neighbours are mutual, and each pass merges a
//! handful of pairs: a 20,000-triangle fan took 1.1 s and a 200,000-vertex polygon did not
//! finish in 20 s. Splitting at the median centroid along the longest axis takes O(n log n)
//! whatever the boxes; on such input no tree is good for traversal anyway, so the build's
//! cost is what matters.

use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::Bvh2;

/// Fewest boxes for which [`overlaps_heavily`] may send a build here: PLOC's worst case on
/// fewer is a few milliseconds, and every ordinary small mesh keeps its PLOC tree.
const MIN_PRIMITIVES: usize = 2048;

/// The overlap above which PLOC is not used: the sum of the boxes' surface areas over the
/// surface area of their union. Every scene in `scenes/` and the built-in ones stays below 5
/// (a box's faces count once per box covering them, and an ordinary mesh covers its box a few
/// times over); a fan of n triangles is near n / 6.
const MAX_OVERLAP: f64 = 64.0;

/// Whether `boxes` overlap so much that PLOC would degenerate (see the module notes).
pub(crate) fn overlaps_heavily(boxes: &[Aabb]) -> bool {
    if boxes.len() < MIN_PRIMITIVES {
        return false;
    }
    let mut union = Aabb::empty();
    let mut sum = 0.0f64;
    for b in boxes {
        union = union.union(b);
        sum += f64::from(b.half_area());
    }
    let whole = f64::from(union.half_area());
    // Flat or point-like input (zero area) overlaps by any measure only if its boxes do.
    whole > 0.0 && sum > MAX_OVERLAP * whole
}

/// A binary BVH over `boxes` (primitive `i` has box `boxes[i]`, one primitive per leaf): each
/// node's primitives split in half at the median of their box centres along the axis where
/// the centres spread most (ties broken by index, so the tree depends only on the boxes).
pub(crate) fn median_build(boxes: &[Aabb]) -> Bvh2 {
    let n = boxes.len();
    let mut order: Vec<u32> = (0..n as u32).collect();
    if n == 0 {
        return Bvh2::default();
    }
    let centre = |i: u32| {
        let b = &boxes[i as usize];
        (b.min + b.max) * 0.5
    };
    let mut nodes = Vec::with_capacity(2 * n - 1);
    nodes.push(Bvh2Node::new(Aabb::empty(), 0, 0));
    let mut max_depth = 1;
    // (node, first primitive in `order`, end, depth)
    let mut stack = vec![(0usize, 0usize, n, 1usize)];
    while let Some((node, lo, hi, depth)) = stack.pop() {
        max_depth = max_depth.max(depth);
        if hi - lo == 1 {
            nodes[node] = Bvh2Node::new(boxes[order[lo] as usize], 1, lo as u32);
            continue;
        }
        let prims = &mut order[lo..hi];
        let (mut low, mut high) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
        for &p in prims.iter() {
            let c = centre(p);
            low = low.min(c);
            high = high.max(c);
        }
        let spread = high - low;
        let axis = if spread.x >= spread.y && spread.x >= spread.z {
            0
        } else if spread.y >= spread.z {
            1
        } else {
            2
        };
        let mid = prims.len() / 2;
        prims.select_nth_unstable_by(mid, |&a, &b| {
            centre(a)[axis].total_cmp(&centre(b)[axis]).then(a.cmp(&b))
        });
        let left = nodes.len();
        nodes.push(Bvh2Node::new(Aabb::empty(), 0, 0));
        nodes.push(Bvh2Node::new(Aabb::empty(), 0, 0));
        nodes[node] = Bvh2Node::new(Aabb::empty(), 0, left as u32);
        stack.push((left, lo, lo + mid, depth + 1));
        stack.push((left + 1, lo + mid, hi, depth + 1));
    }
    let mut bvh = Bvh2 {
        nodes,
        primitive_indices: order,
        children_are_ordered_after_parents: true,
        max_depth: max_depth.max(obvhs::bvh2::DEFAULT_MAX_STACK_DEPTH),
        ..Bvh2::default()
    };
    bvh.refit_all();
    bvh
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The boxes of a fan of `n` triangles around the origin in the plane z = 0.
    fn fan(n: usize) -> Vec<Aabb> {
        let at = |i: usize| {
            let a = std::f32::consts::TAU * i as f32 / n as f32;
            Vec3A::new(a.cos(), a.sin(), 0.0)
        };
        (0..n)
            .map(|i| {
                let (b, c) = (at(i), at(i + 1));
                Aabb::new(Vec3A::ZERO.min(b).min(c), Vec3A::ZERO.max(b).max(c))
            })
            .collect()
    }

    /// A grid of `n`×`n` unit squares' boxes.
    fn grid(n: usize) -> Vec<Aabb> {
        let mut out = vec![];
        for y in 0..n {
            for x in 0..n {
                let p = Vec3A::new(x as f32, y as f32, 0.0);
                out.push(Aabb::new(p, p + Vec3A::new(1.0, 1.0, 0.0)));
            }
        }
        out
    }

    #[test]
    fn fans_overlap_heavily_and_grids_do_not() {
        assert!(overlaps_heavily(&fan(4096)));
        assert!(
            !overlaps_heavily(&fan(MIN_PRIMITIVES - 1)),
            "small meshes stay on PLOC"
        );
        assert!(!overlaps_heavily(&grid(100)));
    }

    /// Every primitive sits in exactly one leaf whose box is its own, every inner box is its
    /// children's union, and the depth is ⌈log2 n⌉ + 1.
    #[test]
    fn the_median_tree_is_balanced_and_tight() {
        let boxes = fan(10_000);
        let bvh = median_build(&boxes);
        let mut seen = vec![false; boxes.len()];
        let mut stack = vec![(0usize, 1usize)];
        let mut depth = 0;
        while let Some((i, d)) = stack.pop() {
            depth = depth.max(d);
            let node = &bvh.nodes[i];
            if node.is_leaf() {
                assert_eq!(node.prim_count, 1);
                let p = bvh.primitive_indices[node.first_index as usize] as usize;
                assert!(!seen[p], "primitive {p} twice");
                seen[p] = true;
                assert_eq!(node.aabb().min, boxes[p].min);
                assert_eq!(node.aabb().max, boxes[p].max);
            } else {
                let (l, r) = (node.first_index as usize, node.first_index as usize + 1);
                let u = bvh.nodes[l].aabb().union(bvh.nodes[r].aabb());
                assert_eq!((node.aabb().min, node.aabb().max), (u.min, u.max));
                stack.push((l, d + 1));
                stack.push((r, d + 1));
            }
        }
        assert!(seen.iter().all(|&s| s), "every primitive in a leaf");
        assert_eq!(depth, 15, "10,000 leaves: depth ⌈log2⌉ + 1");
        assert_eq!(bvh.nodes.len(), 2 * boxes.len() - 1);
    }
}
