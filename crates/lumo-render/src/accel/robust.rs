//! PLOC builds guarded against the input on which PLOC degenerates to quadratic time.
//!
//! PLOC merges two clusters when each is the other's cheapest neighbour within a window of
//! the Morton order. obvhs breaks cost ties towards the farthest neighbour ahead, so on ties
//! almost no pair is mutual and each pass merges O(1) pairs: O(n) passes of O(n) work, and a
//! chain-shaped tree. Ties arise from
//! * identical boxes (N copies of one triangle: 100,000 took over 2 minutes), and
//! * costs that overflow to +∞ (geometry around 1e30: every surface area is infinite).
//!
//! A third cause is boxes that nearly all cover one another (a triangle fan): merges then cost
//! about the same, few are mutual, and such input goes to a median build instead
//! ([`super::median`]); so does a fourth, equal boxes at equal steps along a line, whose
//! neighbouring merges all cost the same ([`super::ploc_stall`]).
//!
//! [`build_bvh2`] removes the first two causes before PLOC sees the boxes: more than
//! [`MAX_PLAIN_DUPLICATES`] identical boxes become one cluster (a multi-primitive leaf, which
//! the wide collapse splits into a balanced subtree), and geometry too large for finite f32
//! areas is scaled by a power of two for the build. Ordinary input (extent ≤ 1e18, at most a
//! few identical boxes: the two triangles of an axis-aligned quad share theirs) takes the
//! plain path, so its tree, and every image, is the same bit for bit as before.

use std::collections::HashMap;

use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::Bvh2;
use obvhs::ploc::{PlocBuilder, PlocSearchDistance, SortPrecision};

use super::median::{median_build, overlaps_heavily};
use super::ploc_stall::{ploc_stalls, SEARCH_DISTANCE};

/// Largest extent the build takes unscaled: the half area of a box this size (3·1e36) stays
/// well inside f32's range (3.4e38), so no merge cost overflows.
const MAX_BUILD_EXTENT: f64 = 1e18;

/// Most identical boxes left to PLOC as they are. A handful costs PLOC a handful of extra
/// passes; the bound keeps every ordinary mesh (quads: pairs of triangles with one box) on the
/// plain path.
const MAX_PLAIN_DUPLICATES: u32 = 8;

/// How [`build_bvh2`] builds.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BuildOptions {
    /// PLOC passes that search only the next neighbour (cheaper, lower quality).
    pub search_depth_threshold: usize,
    /// Batch ratio of the reinsertion optimiser after PLOC (0: none).
    pub reinsertion: f32,
}

/// Builds a binary BVH over `boxes` (primitive `i` has box `boxes[i]`) in O(n log n) time
/// whatever the input; leaves may hold several primitives with identical boxes.
pub(crate) fn build_bvh2(boxes: &[Aabb], options: BuildOptions) -> Bvh2 {
    // Groups of identical boxes, numbered in order of first appearance (deterministic).
    let mut group_of = Vec::with_capacity(boxes.len());
    let mut group_size: Vec<u32> = Vec::new();
    let mut seen: HashMap<[u32; 6], u32> = HashMap::with_capacity(boxes.len());
    for b in boxes {
        let key = [b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z].map(f32::to_bits);
        let g = *seen.entry(key).or_insert_with(|| {
            group_size.push(0);
            (group_size.len() - 1) as u32
        });
        group_size[g as usize] += 1;
        group_of.push(g);
    }
    drop(seen);
    let scale = build_scale(boxes);
    let big = |g: u32| group_size[g as usize] > MAX_PLAIN_DUPLICATES;
    if scale == 1.0 && !group_of.iter().any(|&g| big(g)) {
        return ploc(boxes, options);
    }
    // Clusters: each big group as one, every other primitive on its own; `first` holds each
    // cluster's first primitive.
    let mut cluster_of = Vec::with_capacity(boxes.len());
    let mut first: Vec<u32> = Vec::new();
    let mut group_cluster = vec![u32::MAX; group_size.len()];
    for (i, &g) in group_of.iter().enumerate() {
        let c = if big(g) && group_cluster[g as usize] != u32::MAX {
            group_cluster[g as usize]
        } else {
            first.push(i as u32);
            (first.len() - 1) as u32
        };
        if big(g) {
            group_cluster[g as usize] = c;
        }
        cluster_of.push(c);
    }
    drop(group_of);
    let reps: Vec<Aabb> = first
        .iter()
        .map(|&i| {
            let b = &boxes[i as usize];
            Aabb::new(b.min * scale, b.max * scale)
        })
        .collect();
    let mut bvh = ploc(&reps, options);
    // Members of each cluster, contiguous (counting sort by cluster).
    let mut start = vec![0u32; first.len() + 1];
    for &c in &cluster_of {
        start[c as usize + 1] += 1;
    }
    for c in 0..first.len() {
        start[c + 1] += start[c];
    }
    let mut members = vec![0u32; boxes.len()];
    let mut fill = start.clone();
    for (i, &c) in cluster_of.iter().enumerate() {
        members[fill[c as usize] as usize] = i as u32;
        fill[c as usize] += 1;
    }
    // PLOC's leaves name clusters; point them at their members, with the true (unscaled)
    // box, then recompute the inner boxes from the leaves.
    for node in &mut bvh.nodes {
        if node.is_leaf() {
            let c = bvh.primitive_indices[node.first_index as usize] as usize;
            node.first_index = start[c];
            node.prim_count = start[c + 1] - start[c];
            node.set_aabb(boxes[first[c] as usize]);
        }
    }
    bvh.primitive_indices = members;
    bvh.primitives_to_nodes.clear();
    bvh.refit_all();
    bvh
}

/// Plain obvhs PLOC (+ reinsertion) over `boxes`, or the median build where they overlap so
/// much ([`super::median`]) or their merge costs tie so evenly ([`super::ploc_stall`]) that
/// PLOC would take quadratic time.
fn ploc(boxes: &[Aabb], options: BuildOptions) -> Bvh2 {
    if overlaps_heavily(boxes) || ploc_stalls(boxes, options.search_depth_threshold) {
        return median_build(boxes);
    }
    let mut bvh = PlocBuilder::with_capacity(boxes.len()).build(
        PlocSearchDistance::from(SEARCH_DISTANCE as u32),
        boxes,
        (0..boxes.len() as u32).collect(),
        SortPrecision::U64,
        options.search_depth_threshold,
    );
    if options.reinsertion > 0.0 {
        ReinsertionOptimizer::default().run(&mut bvh, options.reinsertion, None);
    }
    bvh
}

/// The power of two that brings the extent of `boxes` within [`MAX_BUILD_EXTENT`] (1 when
/// it already is). A power of two scales every coordinate exactly (barring underflow), so
/// the build sees the same shapes.
fn build_scale(boxes: &[Aabb]) -> f32 {
    let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    for b in boxes {
        lo = lo.min(b.min);
        hi = hi.max(b.max);
    }
    // In f64: max − min of f32 coordinates can overflow f32.
    let extent = (0..3)
        .map(|a| f64::from(hi[a]) - f64::from(lo[a]))
        .fold(0.0f64, f64::max);
    if extent.is_nan() || extent <= MAX_BUILD_EXTENT {
        return 1.0;
    }
    let k = (extent / MAX_BUILD_EXTENT).log2().ceil() as i32;
    2f64.powi(-k) as f32
}

/// Sets every leaf's box to the union of its primitives' boxes (`prim_box(i)` for primitive
/// `i`), then refits the inner nodes: the refit for trees whose leaves may hold several
/// primitives.
pub(crate) fn refit_leaves(bvh: &mut Bvh2, prim_box: impl Fn(usize) -> Aabb) {
    for node in &mut bvh.nodes {
        if node.is_leaf() {
            let first = node.first_index as usize;
            let mut b = Aabb::empty();
            for &p in &bvh.primitive_indices[first..first + node.prim_count as usize] {
                b = b.union(&prim_box(p as usize));
            }
            node.set_aabb(b);
        }
    }
    bvh.refit_all();
}

#[cfg(test)]
mod tests {
    use super::*;

    const OPTIONS: BuildOptions = BuildOptions {
        search_depth_threshold: 3,
        reinsertion: 0.05,
    };

    /// Depth of the binary tree and the number of primitives in its leaves.
    fn depth_and_prims(bvh: &Bvh2) -> (usize, usize) {
        let (mut depth, mut prims) = (0, 0);
        let mut stack = vec![(0usize, 1usize)];
        while let Some((i, d)) = stack.pop() {
            let node = &bvh.nodes[i];
            depth = depth.max(d);
            if node.is_leaf() {
                prims += node.prim_count as usize;
            } else {
                stack.push((node.first_index as usize, d + 1));
                stack.push((node.first_index as usize + 1, d + 1));
            }
        }
        (depth, prims)
    }

    fn tri_box(a: Vec3A, b: Vec3A, c: Vec3A) -> Aabb {
        Aabb::new(a.min(b).min(c), a.max(b).max(c))
    }

    /// Boxes of an n × n grid of quads on the plane z = 0, times `scale`: two triangles per
    /// quad, which share one box.
    fn grid(n: usize, scale: f32) -> Vec<Aabb> {
        let mut out = vec![];
        for y in 0..n {
            for x in 0..n {
                let p = Vec3A::new(x as f32, y as f32, 0.0);
                let (a, b, c, d) = (p, p + Vec3A::X, p + Vec3A::Y, p + Vec3A::X + Vec3A::Y);
                out.push(tri_box(a * scale, b * scale, d * scale));
                out.push(tri_box(a * scale, d * scale, c * scale));
            }
        }
        out
    }

    // The unguarded PLOC builds a chain (depth in the thousands) on both inputs below, in
    // seconds at these sizes and minutes at 100,000 triangles.

    #[test]
    fn identical_triangles_build_a_shallow_tree() {
        let one = tri_box(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
        // Mostly copies of one triangle, plus a few others so the tree is not a single leaf.
        let mut boxes = vec![one; 20_000];
        boxes.extend(grid(10, 3.0));
        let bvh = build_bvh2(&boxes, OPTIONS);
        let (depth, prims) = depth_and_prims(&bvh);
        assert_eq!(prims, boxes.len(), "every primitive in one leaf");
        assert!(depth <= 40, "depth {depth}");
        let mut seen: Vec<u32> = bvh.primitive_indices.clone();
        seen.sort_unstable();
        assert!(seen.iter().copied().eq(0..boxes.len() as u32));
    }

    /// A 200,000-triangle fan (a triangulated n-gon) took PLOC quadratic time; it now goes to
    /// the median build and comes out balanced.
    #[test]
    fn a_triangle_fan_builds_a_shallow_tree() {
        let n = 200_000;
        let at = |i: usize| {
            let a = std::f32::consts::TAU * i as f32 / n as f32;
            Vec3A::new(a.cos(), a.sin(), 0.0)
        };
        let boxes: Vec<Aabb> = (1..n - 1)
            .map(|i| tri_box(at(0), at(i), at(i + 1)))
            .collect();
        let bvh = build_bvh2(&boxes, OPTIONS);
        let (depth, prims) = depth_and_prims(&bvh);
        assert_eq!(prims, boxes.len());
        assert!(depth <= 20, "depth {depth}");
    }

    #[test]
    fn huge_coordinates_build_a_shallow_tree() {
        let boxes = grid(100, 1e30);
        let bvh = build_bvh2(&boxes, OPTIONS);
        let (depth, prims) = depth_and_prims(&bvh);
        assert_eq!(prims, boxes.len());
        assert!(depth <= 60, "depth {depth}");
        // The boxes are the true (unscaled) ones.
        let root = bvh.nodes[0].aabb();
        assert_eq!(root.max.x, 100.0 * 1e30);
    }

    #[test]
    fn ordinary_input_takes_the_plain_path() {
        // Quads (pairs of identical boxes) and a few more copies, up to the bound.
        let mut boxes = grid(30, 1.0);
        boxes.extend([boxes[0]; MAX_PLAIN_DUPLICATES as usize - 2]);
        let a = build_bvh2(&boxes, OPTIONS);
        let b = ploc(&boxes, OPTIONS);
        // A large tessellated plane (ties in its costs, but PLOC's window sees past them)
        // is not taken for a stalling row.
        assert!(!ploc_stalls(
            &grid(100, 1.0),
            OPTIONS.search_depth_threshold
        ));
        assert_eq!(a.primitive_indices, b.primitive_indices);
        assert_eq!(a.nodes.len(), b.nodes.len());
        for (x, y) in a.nodes.iter().zip(&b.nodes) {
            assert_eq!((x.first_index, x.prim_count), (y.first_index, y.prim_count));
            assert_eq!((x.aabb().min, x.aabb().max), (y.aabb().min, y.aabb().max));
        }
    }

    /// 100,000 small triangles in a row took about 70 s (PLOC merged one pair per pass); the
    /// median build makes a balanced tree of them.
    #[test]
    fn a_row_of_small_triangles_builds_a_shallow_tree_quickly() {
        let boxes: Vec<Aabb> = (0..100_000)
            .map(|i| {
                let p = Vec3A::new(i as f32, 0.0, 0.0);
                tri_box(p, p + Vec3A::X * 1e-3, p + Vec3A::Y * 1e-3)
            })
            .collect();
        let start = std::time::Instant::now();
        let bvh = build_bvh2(&boxes, OPTIONS);
        let took = start.elapsed();
        let (depth, prims) = depth_and_prims(&bvh);
        assert_eq!(prims, boxes.len());
        assert!(depth <= 20, "depth {depth}");
        // A sanity bound, not a performance test: the stalled build took minutes.
        assert!(took.as_secs() < 10, "{took:?}");
    }
}
