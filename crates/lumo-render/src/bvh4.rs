//! A 4-wide BVH over one mesh's triangles, traversed one ray at a time with 4-lane SIMD
//! (glam's `Vec4`: SSE2 on x86-64, NEON/scalar elsewhere).
//!
//! Each node stores its four children's boxes as structure-of-arrays so one set of vector
//! operations tests all four slabs; each leaf is one packet of up to four triangles, also
//! structure-of-arrays, tested together. The tree is a collapse of obvhs's binary PLOC tree,
//! which stays the source of truth for building and refitting.
//!
//! Why not obvhs's compressed CWBVH: its nodes are quantised for GPU memory bandwidth, so a
//! scalar CPU traversal spends most of its time decoding child boxes and walking leaf
//! triangles one by one through a callback; for the small and mid-sized scenes lumo renders
//! that decode cost dominated the per-ray time.

use glam::{BVec4A, Vec3, Vec3A, Vec4};
use obvhs::bvh2::Bvh2;

/// Child slot with nothing in it.
const EMPTY: u32 = u32::MAX;
/// Set in a child reference that names a leaf packet rather than an inner node.
const LEAF: u32 = 0x8000_0000;
/// Most triangles in one leaf (one SIMD packet).
const LEAF_SIZE: usize = 4;
/// Traversal stack entries kept on the machine stack (enough for 10 levels, ~10⁶ triangles);
/// deeper trees use a heap stack. Kept small because the array is zeroed for every ray.
const INLINE_STACK: usize = 32;

/// One inner node: the boxes of up to four children, one lane per child.
#[derive(Clone, Copy, Debug)]
struct Node {
    /// lo.x, hi.x, lo.y, hi.y, lo.z, hi.z, each over the four children. Indexed by
    /// `2·axis + (direction negative)` for the near plane, so traversal needs no min/max.
    planes: [Vec4; 6],
    /// Inner node index, `LEAF | packet index`, or `EMPTY`.
    child: [u32; 4],
}

/// Up to four triangles, one lane each, in the form of the Möller–Trumbore variant with a
/// precomputed normal (v0, e1 = v0 − v1, e2 = v2 − v0, n = e1 × e2). Unused lanes are NaN,
/// which fails every comparison.
#[derive(Clone, Copy, Debug)]
struct Packet {
    v0: [Vec4; 3],
    e1: [Vec4; 3],
    e2: [Vec4; 3],
    n: [Vec4; 3],
    /// Mesh triangle index per lane (`EMPTY` in unused lanes).
    id: [u32; 4],
}

/// A ray prepared for traversal: per-axis splats and the near-plane choice.
struct RayData {
    o: [Vec4; 3],
    d: [Vec4; 3],
    inv: [Vec4; 3],
    near: [usize; 3],
}

impl RayData {
    #[inline]
    fn new(origin: Vec3, dir: Vec3) -> Self {
        // A zero component would give 0·∞ = NaN in the slab test; a tiny one gives a huge but
        // finite slope with the same meaning (the ray runs parallel to that slab). Done on
        // all three lanes at once: this runs for every ray.
        let d = Vec3A::from(dir);
        let tiny = d.abs().cmplt(Vec3A::splat(1e-30));
        let inv = Vec3A::select(tiny, Vec3A::splat(1e30).copysign(d), Vec3A::ONE / d);
        let neg = inv.cmplt(Vec3A::ZERO).bitmask();
        RayData {
            o: [origin.x, origin.y, origin.z].map(Vec4::splat),
            d: [dir.x, dir.y, dir.z].map(Vec4::splat),
            inv: [inv.x, inv.y, inv.z].map(Vec4::splat),
            near: [neg & 1, (neg >> 1) & 1, (neg >> 2) & 1].map(|b| b as usize),
        }
    }
}

/// The nearest triangle hit found by [`Bvh4::intersect`].
#[derive(Clone, Copy, Debug)]
pub struct TriHit {
    /// Ray parameter.
    pub t: f32,
    /// Mesh triangle index.
    pub triangle: u32,
    /// Barycentric weight of the second vertex.
    pub u: f32,
    /// Barycentric weight of the third vertex.
    pub v: f32,
}

/// The wide BVH of one mesh.
#[derive(Clone, Debug, Default)]
pub struct Bvh4 {
    nodes: Vec<Node>,
    packets: Vec<Packet>,
    /// Stack entries a traversal may need (3 per level below the root, plus one).
    stack_need: usize,
}

/// Slab test of a ray against the four boxes of `node`: the lanes hit within [tmin, tmax]
/// and their entry distances.
#[inline(always)]
fn hit_boxes(node: &Node, r: &RayData, tmin: f32, tmax: f32) -> (u32, Vec4) {
    let p = &node.planes;
    let slab = |axis: usize| {
        let near = p[2 * axis + r.near[axis]];
        let far = p[2 * axis + 1 - r.near[axis]];
        (
            (near - r.o[axis]) * r.inv[axis],
            (far - r.o[axis]) * r.inv[axis],
        )
    };
    let (nx, fx) = slab(0);
    let (ny, fy) = slab(1);
    let (nz, fz) = slab(2);
    let t0 = nx.max(ny).max(nz.max(Vec4::splat(tmin)));
    // Widened by 2 ulp-ish (Ize 2013) so rounding in the slab distances never culls a box the
    // ray actually touches.
    let t1 = fx.min(fy).min(fz.min(Vec4::splat(tmax))) * Vec4::splat(1.000_000_4);
    (t0.cmple(t1).bitmask(), t0)
}

/// Tests the ray against the triangles of `packet`: the lanes hit within [tmin, tmax] and
/// their (t, u, v).
#[inline(always)]
fn hit_packet(packet: &Packet, r: &RayData, tmin: f32, tmax: f32) -> (BVec4A, Vec4, Vec4, Vec4) {
    let [v0x, v0y, v0z] = packet.v0;
    let [e1x, e1y, e1z] = packet.e1;
    let [e2x, e2y, e2z] = packet.e2;
    let [nx, ny, nz] = packet.n;
    let [dx, dy, dz] = r.d;
    let (cx, cy, cz) = (v0x - r.o[0], v0y - r.o[1], v0z - r.o[2]);
    // r = d × c
    let (rx, ry, rz) = (dy * cz - dz * cy, dz * cx - dx * cz, dx * cy - dy * cx);
    let det = nx * dx + ny * dy + nz * dz;
    // det = 0 (ray in the triangle's plane) gives inv = ±∞ and u, v, w of ±∞ or NaN, of
    // which at least one fails its test.
    let inv = det.recip();
    let u = (rx * e2x + ry * e2y + rz * e2z) * inv;
    let v = (rx * e1x + ry * e1y + rz * e1z) * inv;
    let w = Vec4::ONE - u - v;
    let t = (nx * cx + ny * cy + nz * cz) * inv;
    let zero = Vec4::ZERO;
    let mask = u.cmpge(zero)
        & v.cmpge(zero)
        & w.cmpge(zero)
        & t.cmpge(Vec4::splat(tmin))
        & t.cmple(Vec4::splat(tmax));
    (mask, t, u, v)
}

impl Bvh4 {
    /// Collapses `bvh2` (whose leaves index `bvh2.primitive_indices`) over the triangles
    /// `positions`/`indices` of one mesh.
    pub fn from_bvh2(bvh2: &Bvh2, positions: &[Vec3], indices: &[[u32; 3]]) -> Self {
        let mut out = Bvh4::default();
        if bvh2.nodes.is_empty() || indices.is_empty() {
            return out;
        }
        let counts = subtree_counts(bvh2);
        let mut builder = Builder {
            bvh2,
            counts: &counts,
            positions,
            indices,
            out: &mut out,
        };
        let depth = builder.node(0);
        out.stack_need = 3 * depth + 1;
        out
    }

    /// Nearest hit of `origin + t·dir` with t in [tmin, tmax].
    #[inline]
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<TriHit> {
        if self.nodes.is_empty() {
            return None;
        }
        let r = RayData::new(origin, dir);
        if self.stack_need <= INLINE_STACK {
            let mut stack = [(0u32, 0f32); INLINE_STACK];
            self.closest(&r, tmin, tmax, &mut stack)
        } else {
            let mut stack = vec![(0u32, 0f32); self.stack_need];
            self.closest(&r, tmin, tmax, &mut stack)
        }
    }

    /// True if anything hits `origin + t·dir` with t in [tmin, tmax].
    #[inline]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let r = RayData::new(origin, dir);
        if self.stack_need <= INLINE_STACK {
            let mut stack = [0u32; INLINE_STACK];
            self.any(&r, tmin, tmax, &mut stack)
        } else {
            let mut stack = vec![0u32; self.stack_need];
            self.any(&r, tmin, tmax, &mut stack)
        }
    }

    /// Closest-hit traversal: nearest child first, the others pushed with their entry
    /// distance so they are skipped once a closer hit is known.
    fn closest(
        &self,
        r: &RayData,
        tmin: f32,
        mut tmax: f32,
        stack: &mut [(u32, f32)],
    ) -> Option<TriHit> {
        let mut best: Option<TriHit> = None;
        let mut sp = 0usize;
        let mut current = 0u32;
        loop {
            if current & LEAF != 0 {
                let packet = &self.packets[(current & !LEAF) as usize];
                let (mask, t, u, v) = hit_packet(packet, r, tmin, tmax);
                let mut bits = mask.bitmask();
                if bits != 0 {
                    let (t, u, v) = (t.to_array(), u.to_array(), v.to_array());
                    while bits != 0 {
                        let lane = bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        if t[lane] <= tmax {
                            tmax = t[lane];
                            best = Some(TriHit {
                                t: t[lane],
                                triangle: packet.id[lane],
                                u: u[lane],
                                v: v[lane],
                            });
                        }
                    }
                }
            } else {
                let node = &self.nodes[current as usize];
                let (mut bits, tnear) = hit_boxes(node, r, tmin, tmax);
                if bits != 0 {
                    let first = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    if bits == 0 {
                        // One child hit (the common case near the leaves): no ordering.
                        current = node.child[first];
                        continue;
                    }
                    let tn = tnear.to_array();
                    // Gather the hit children, then order them far to near on the stack
                    // and descend into the nearest directly.
                    let mut hits = [(node.child[first], tn[first]), (0, 0.0), (0, 0.0), (0, 0.0)];
                    let mut n = 1;
                    while bits != 0 {
                        let lane = bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        hits[n] = (node.child[lane], tn[lane]);
                        n += 1;
                    }
                    let hits = &mut hits[..n];
                    // Insertion sort, descending by distance (n ≤ 4).
                    for i in 1..n {
                        let mut j = i;
                        while j > 0 && hits[j - 1].1 < hits[j].1 {
                            hits.swap(j - 1, j);
                            j -= 1;
                        }
                    }
                    for &h in &hits[..n - 1] {
                        stack[sp] = h;
                        sp += 1;
                    }
                    current = hits[n - 1].0;
                    continue;
                }
            }
            // Pop the next subtree that can still hold a closer hit.
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let (child, t) = stack[sp];
                if t <= tmax {
                    current = child;
                    break;
                }
            }
        }
    }

    /// Any-hit traversal: stops at the first triangle hit, in no particular order.
    fn any(&self, r: &RayData, tmin: f32, tmax: f32, stack: &mut [u32]) -> bool {
        let mut sp = 0usize;
        let mut current = 0u32;
        loop {
            if current & LEAF != 0 {
                let packet = &self.packets[(current & !LEAF) as usize];
                if hit_packet(packet, r, tmin, tmax).0.any() {
                    return true;
                }
            } else {
                let node = &self.nodes[current as usize];
                let (mut bits, _) = hit_boxes(node, r, tmin, tmax);
                if bits != 0 {
                    let lane = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    while bits != 0 {
                        stack[sp] = node.child[bits.trailing_zeros() as usize];
                        sp += 1;
                        bits &= bits - 1;
                    }
                    current = node.child[lane];
                    continue;
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            current = stack[sp];
        }
    }
}

/// Number of primitives under each node of `bvh2`.
fn subtree_counts(bvh2: &Bvh2) -> Vec<u32> {
    let mut counts = vec![0u32; bvh2.nodes.len()];
    // Iterative post-order: children are visited before their parent.
    let mut stack = vec![(0usize, false)];
    while let Some((i, expanded)) = stack.pop() {
        let node = &bvh2.nodes[i];
        if node.is_leaf() {
            counts[i] = node.prim_count;
        } else if expanded {
            let l = node.first_index as usize;
            counts[i] = counts[l] + counts[l + 1];
        } else {
            let l = node.first_index as usize;
            stack.push((i, true));
            stack.push((l, false));
            stack.push((l + 1, false));
        }
    }
    counts
}

/// State of one collapse.
struct Builder<'a> {
    bvh2: &'a Bvh2,
    counts: &'a [u32],
    positions: &'a [Vec3],
    indices: &'a [[u32; 3]],
    out: &'a mut Bvh4,
}

impl Builder<'_> {
    /// Emits the 4-wide node for binary node `root` and, recursively, everything below it;
    /// returns the depth (in 4-wide levels) of the emitted subtree.
    fn node(&mut self, root: usize) -> usize {
        let index = self.empty_node();
        // Open binary nodes, largest surface area first, until there are four children or
        // every child is small enough for a leaf packet.
        let mut kids: Vec<usize> = if self.bvh2.nodes[root].is_leaf() || self.small(root) {
            vec![root]
        } else {
            let l = self.bvh2.nodes[root].first_index as usize;
            vec![l, l + 1]
        };
        while kids.len() < 4 {
            let Some((k, _)) = kids
                .iter()
                .enumerate()
                .filter(|(_, &c)| !self.small(c))
                .map(|(k, &c)| (k, self.bvh2.nodes[c].aabb().half_area()))
                .max_by(|a, b| a.1.total_cmp(&b.1))
            else {
                break;
            };
            let l = self.bvh2.nodes[kids[k]].first_index as usize;
            kids[k] = l;
            kids.push(l + 1);
        }
        let mut depth = 1;
        for (lane, &c) in kids.iter().enumerate() {
            let b = self.bvh2.nodes[c].aabb();
            self.set_box(index, lane, b.min.into(), b.max.into());
            let child = if self.small(c) {
                let prims = self.prims(c);
                let (child, d) = self.leaf(&prims);
                depth = depth.max(1 + d);
                child
            } else {
                let child = self.out.nodes.len() as u32;
                depth = depth.max(1 + self.node(c));
                child
            };
            self.out.nodes[index].child[lane] = child;
        }
        depth
    }

    /// Appends an inner node with four empty slots; returns its index.
    fn empty_node(&mut self) -> usize {
        self.out.nodes.push(Node {
            planes: [
                Vec4::INFINITY,
                Vec4::NEG_INFINITY,
                Vec4::INFINITY,
                Vec4::NEG_INFINITY,
                Vec4::INFINITY,
                Vec4::NEG_INFINITY,
            ],
            child: [EMPTY; 4],
        });
        self.out.nodes.len() - 1
    }

    fn set_box(&mut self, node: usize, lane: usize, lo: Vec3, hi: Vec3) {
        let planes = &mut self.out.nodes[node].planes;
        for axis in 0..3 {
            planes[2 * axis][lane] = lo[axis];
            planes[2 * axis + 1][lane] = hi[axis];
        }
    }

    /// True when binary node `c` becomes a leaf: its subtree fits in one packet, or it is a
    /// binary leaf (which cannot be opened; see [`Builder::leaf`] for large ones).
    fn small(&self, c: usize) -> bool {
        self.counts[c] as usize <= LEAF_SIZE || self.bvh2.nodes[c].is_leaf()
    }

    /// The mesh triangles under binary node `c`.
    fn prims(&self, c: usize) -> Vec<u32> {
        let mut prims = Vec::with_capacity(LEAF_SIZE);
        let mut stack = vec![c];
        while let Some(i) = stack.pop() {
            let node = &self.bvh2.nodes[i];
            if node.is_leaf() {
                let first = node.first_index as usize;
                let range = first..first + node.prim_count as usize;
                prims.extend_from_slice(&self.bvh2.primitive_indices[range]);
            } else {
                let l = node.first_index as usize;
                stack.push(l + 1);
                stack.push(l);
            }
        }
        prims
    }

    /// A child reference for triangles `prims`: one packet when they fit, otherwise (a binary
    /// leaf with many triangles; PLOC builds one-triangle leaves, so only for foreign trees)
    /// an inner node over chunks of them. Returns the reference and the levels it adds.
    fn leaf(&mut self, prims: &[u32]) -> (u32, usize) {
        if prims.len() <= LEAF_SIZE {
            return (LEAF | self.packet(prims), 0);
        }
        let index = self.empty_node();
        let chunk = prims.len().div_ceil(4);
        let mut depth = 0;
        for (lane, part) in prims.chunks(chunk).enumerate() {
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for &p in part {
                for i in self.indices[p as usize] {
                    lo = lo.min(self.positions[i as usize]);
                    hi = hi.max(self.positions[i as usize]);
                }
            }
            self.set_box(index, lane, lo, hi);
            let (child, d) = self.leaf(part);
            depth = depth.max(d);
            self.out.nodes[index].child[lane] = child;
        }
        (index as u32, depth + 1)
    }

    /// Emits the packet of up to [`LEAF_SIZE`] triangles `prims`; returns its index.
    fn packet(&mut self, prims: &[u32]) -> u32 {
        let nan = f32::NAN;
        let mut lanes = [[nan; 12]; 4];
        let mut id = [EMPTY; 4];
        for (lane, &p) in prims.iter().enumerate() {
            let [a, b, c] = self.indices[p as usize].map(|i| self.positions[i as usize]);
            let (e1, e2) = (a - b, c - a);
            let n = e1.cross(e2);
            lanes[lane] = [
                a.x, a.y, a.z, e1.x, e1.y, e1.z, e2.x, e2.y, e2.z, n.x, n.y, n.z,
            ];
            id[lane] = p;
        }
        let col = |k: usize| Vec4::new(lanes[0][k], lanes[1][k], lanes[2][k], lanes[3][k]);
        self.out.packets.push(Packet {
            v0: [col(0), col(1), col(2)],
            e1: [col(3), col(4), col(5)],
            e2: [col(6), col(7), col(8)],
            n: [col(9), col(10), col(11)],
            id,
        });
        (self.out.packets.len() - 1) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use obvhs::aabb::Aabb;
    use obvhs::bvh2::node::Bvh2Node;
    use obvhs::ploc::{PlocBuilder, PlocSearchDistance, SortPrecision};
    use obvhs::ray::Ray;
    use obvhs::rt_triangle::RtTriangle;

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
    fn check(bvh: &Bvh4, positions: &[Vec3], indices: &[[u32; 3]]) {
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
                (w, g) => panic!("ray {r}: brute force {w:?}, bvh4 {g:?}"),
            }
            assert_eq!(bvh.occluded(o, d, 0.0, f32::INFINITY), want.is_some());
            if let Some((t, _)) = want {
                // Nothing lies before the nearest hit.
                assert!(!bvh.occluded(o, d, 0.0, t * 0.999), "ray {r}");
            }
        }
        assert!(
            hits > 200,
            "only {hits} rays hit: the test would prove little"
        );
    }

    #[test]
    fn collapsed_ploc_tree_matches_brute_force() {
        let (positions, indices) = soup(300);
        let tris: Vec<RtTriangle> = indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| Vec3A::from(positions[v as usize]));
                RtTriangle::new(a, b, c)
            })
            .collect();
        let bvh2 = PlocBuilder::with_capacity(tris.len()).build(
            PlocSearchDistance::Medium,
            &tris,
            (0..tris.len() as u32).collect(),
            SortPrecision::U64,
            1,
        );
        check(
            &Bvh4::from_bvh2(&bvh2, &positions, &indices),
            &positions,
            &indices,
        );
    }

    #[test]
    fn a_binary_leaf_with_many_triangles_keeps_them_all() {
        // One leaf holding every triangle: the collapse must chain packets under inner nodes
        // (two levels for 40 triangles) rather than drop triangles past the fourth.
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
        let bvh = Bvh4::from_bvh2(&bvh2, &positions, &indices);
        // Four chunks of 10, each split again into packets of 3, 3, 3 and 1.
        assert_eq!(bvh.packets.len(), 16);
        check(&bvh, &positions, &indices);
    }
}
