//! The data of a W-wide BVH over one mesh's triangles (W = 4 for the SSE traversal in
//! [`crate::accel::bvh4`], W = 8 for the AVX2 one in [`crate::accel::bvh8`]), and its construction as a
//! collapse of obvhs's binary PLOC tree, which stays the source of truth for building and
//! refitting.
//!
//! Each node stores its W children's boxes as structure-of-arrays so one set of vector
//! operations tests all W slabs; each leaf is one packet of up to W triangles, also
//! structure-of-arrays, tested together.

use glam::{Vec3, Vec3A};
use obvhs::bvh2::Bvh2;

/// Child slot with nothing in it.
pub(crate) const EMPTY: u32 = u32::MAX;
/// Set in a child reference that names a leaf packet rather than an inner node.
pub(crate) const LEAF: u32 = 0x8000_0000;

/// One inner node: the boxes of up to W children, one lane per child.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(crate) struct Node<const W: usize> {
    /// lo.x, hi.x, lo.y, hi.y, lo.z, hi.z, each over the W children. Indexed by
    /// `2·axis + (direction negative)` for the near plane, so traversal needs no min/max.
    /// Empty slots hold lo = +∞, hi = −∞, which no ray enters.
    pub planes: [[f32; W]; 6],
    /// Inner node index, `LEAF | packet index`, or `EMPTY`.
    pub child: [u32; W],
}

/// Up to W triangles, one lane each, in the form of the Möller–Trumbore variant with a
/// precomputed normal (v0, e1 = v0 − v1, e2 = v2 − v0, n = e1 × e2). Unused lanes are NaN,
/// which fails every comparison.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(crate) struct Packet<const W: usize> {
    pub v0: [[f32; W]; 3],
    pub e1: [[f32; W]; 3],
    pub e2: [[f32; W]; 3],
    pub n: [[f32; W]; 3],
    /// Mesh triangle index per lane (`EMPTY` in unused lanes).
    pub id: [u32; W],
}

/// The nearest triangle hit of a traversal.
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

/// The W-wide BVH of one mesh (traversal: [`crate::accel::bvh4`], [`crate::accel::bvh8`]).
#[derive(Clone, Debug)]
pub struct WideBvh<const W: usize> {
    pub(crate) nodes: Vec<Node<W>>,
    pub(crate) packets: Vec<Packet<W>>,
    /// Stack entries a traversal may need (W − 1 per level below the root, plus one).
    pub(crate) stack_need: usize,
}

impl<const W: usize> Default for WideBvh<W> {
    fn default() -> Self {
        Self {
            nodes: Vec::new(),
            packets: Vec::new(),
            stack_need: 0,
        }
    }
}

/// A ray's reciprocal direction and, per axis, whether it points to negative coordinates
/// (which picks the near slab plane).
#[inline(always)]
pub(crate) fn ray_slopes(dir: Vec3) -> (Vec3A, [usize; 3]) {
    // A zero component would give 0·∞ = NaN in the slab test; a tiny one gives a huge but
    // finite slope with the same meaning (the ray runs parallel to that slab). Done on all
    // three lanes at once: this runs for every ray.
    let d = Vec3A::from(dir);
    let tiny = d.abs().cmplt(Vec3A::splat(1e-30));
    let inv = Vec3A::select(tiny, Vec3A::splat(1e30).copysign(d), Vec3A::ONE / d);
    let neg = inv.cmplt(Vec3A::ZERO).bitmask();
    (
        inv,
        [neg & 1, (neg >> 1) & 1, (neg >> 2) & 1].map(|b| b as usize),
    )
}

impl<const W: usize> WideBvh<W> {
    /// Collapses `bvh2` (whose leaves index `bvh2.primitive_indices`) over the triangles
    /// `positions`/`indices` of one mesh.
    pub fn from_bvh2(bvh2: &Bvh2, positions: &[Vec3], indices: &[[u32; 3]]) -> Self {
        let mut out = WideBvh::default();
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
        out.stack_need = (W - 1) * depth + 1;
        out
    }

    /// Number of inner nodes and of leaf packets (for tests and statistics).
    #[cfg_attr(not(test), allow(dead_code))]
    pub(crate) fn size(&self) -> (usize, usize) {
        (self.nodes.len(), self.packets.len())
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
struct Builder<'a, const W: usize> {
    bvh2: &'a Bvh2,
    counts: &'a [u32],
    positions: &'a [Vec3],
    indices: &'a [[u32; 3]],
    out: &'a mut WideBvh<W>,
}

impl<const W: usize> Builder<'_, W> {
    /// Emits the W-wide node for binary node `root` and, recursively, everything below it;
    /// returns the depth (in W-wide levels) of the emitted subtree.
    fn node(&mut self, root: usize) -> usize {
        let index = self.empty_node();
        // Open binary nodes, largest surface area first, until there are W children or
        // every child is small enough for a leaf packet.
        let mut kids: Vec<usize> = if self.bvh2.nodes[root].is_leaf() || self.small(root) {
            vec![root]
        } else {
            let l = self.bvh2.nodes[root].first_index as usize;
            vec![l, l + 1]
        };
        while kids.len() < W {
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

    /// Appends an inner node with W empty slots; returns its index.
    fn empty_node(&mut self) -> usize {
        let (inf, ninf) = ([f32::INFINITY; W], [f32::NEG_INFINITY; W]);
        self.out.nodes.push(Node {
            planes: [inf, ninf, inf, ninf, inf, ninf],
            child: [EMPTY; W],
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
        self.counts[c] as usize <= W || self.bvh2.nodes[c].is_leaf()
    }

    /// The mesh triangles under binary node `c`.
    fn prims(&self, c: usize) -> Vec<u32> {
        let mut prims = Vec::with_capacity(W);
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
        if prims.len() <= W {
            return (LEAF | self.packet(prims), 0);
        }
        let index = self.empty_node();
        let chunk = prims.len().div_ceil(W);
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

    /// Emits the packet of up to W triangles `prims`; returns its index.
    fn packet(&mut self, prims: &[u32]) -> u32 {
        let nan = [f32::NAN; W];
        let mut pk = Packet {
            v0: [nan; 3],
            e1: [nan; 3],
            e2: [nan; 3],
            n: [nan; 3],
            id: [EMPTY; W],
        };
        for (lane, &p) in prims.iter().enumerate() {
            let [a, b, c] = self.indices[p as usize].map(|i| self.positions[i as usize]);
            let (e1, e2) = (a - b, c - a);
            let n = e1.cross(e2);
            for axis in 0..3 {
                pk.v0[axis][lane] = a[axis];
                pk.e1[axis][lane] = e1[axis];
                pk.e2[axis][lane] = e2[axis];
                pk.n[axis][lane] = n[axis];
            }
            pk.id[lane] = p;
        }
        self.out.packets.push(pk);
        (self.out.packets.len() - 1) as u32
    }
}
