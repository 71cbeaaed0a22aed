//! The photon kd-tree of the progressive client–server paper (§3.4): it balances *space*, not
//! photons. It starts as one leaf spanning the scene's box; a leaf that would hold more than
//! [`LEAF_MAX`] photons is split in half across its box's longest side, so adding photons only
//! ever splits the leaves they land in — no rebalancing, and a map that can grow while it is
//! read between insertions.
//!
//! Leaves keep their photons as a singly linked list threaded through the photon array
//! (`next`), so a node is 16 bytes and a photon pays 4 bytes for its place in the tree: no
//! per-leaf allocation. Positions and links live apart from the rest of a photon (16 bytes
//! against 40), so a range query's walk touches only them until a photon is inside.

use glam::Vec3;

/// Most photons a leaf holds before it splits (the paper found 5–6 best).
pub const LEAF_MAX: u32 = 6;

/// Deepest a leaf may be; below it leaves grow past [`LEAF_MAX`]. Coincident photons cannot be
/// separated by any split, and 48 halvings of a box already reach below f32 resolution
/// relative to the scene.
pub const MAX_DEPTH: u32 = 48;

/// End of a leaf's list.
const NIL: u32 = u32::MAX;

/// One stored photon: a particle that arrived at a non-delta surface after at least one
/// bounce (direct light is next-event estimation's job).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Photon {
    /// Where it landed.
    pub p: Vec3,
    /// Unit direction back towards where it came from (the light side).
    pub wi: Vec3,
    /// Geometric normal of the surface it landed on (gathers skip photons of surfaces facing
    /// elsewhere, which would leak light round corners).
    pub ng: Vec3,
    /// Flux it carries (the light path's weight before the arrival half of the shading-normal
    /// correction, which the gather applies).
    pub power: Vec3,
    /// Segments of its light path (2: light → first bounce → here).
    pub depth: u32,
}

/// A photon's position and its leaf link: what a range query reads for every candidate.
#[derive(Clone, Copy, Debug)]
struct Point {
    p: Vec3,
    /// Next photon in the same leaf.
    next: u32,
}

/// The rest of a photon, read only for those within the query's radius.
#[derive(Clone, Copy, Debug)]
struct Payload {
    wi: Vec3,
    ng: Vec3,
    power: Vec3,
    depth: u32,
}

#[derive(Clone, Copy, Debug)]
struct Node {
    /// 0–2: inner node split on that axis; [`LEAF`]: a leaf.
    axis: u32,
    /// Inner: index of the lower child (the upper is `child + 1`). Leaf: head of its list.
    link: u32,
    /// Inner: the split coordinate. Leaf: unused.
    split: f32,
    /// Leaf: photons in its list. Inner: unused.
    count: u32,
}

const LEAF: u32 = 3;

impl Node {
    fn leaf() -> Self {
        Node {
            axis: LEAF,
            link: NIL,
            split: 0.0,
            count: 0,
        }
    }
}

/// The kd-tree and the photons it indexes.
#[derive(Clone, Debug)]
pub struct KdTree {
    lo: Vec3,
    hi: Vec3,
    nodes: Vec<Node>,
    points: Vec<Point>,
    /// Parallel to `points`.
    payload: Vec<Payload>,
}

impl KdTree {
    /// An empty tree over the box `lo..hi` (the scene's); photons outside it still go in, into
    /// the border leaves.
    pub fn new(lo: Vec3, hi: Vec3) -> Self {
        KdTree {
            lo,
            hi,
            nodes: vec![Node::leaf()],
            points: Vec::new(),
            payload: Vec::new(),
        }
    }

    /// The box the root node splits.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (self.lo, self.hi)
    }

    /// Photons stored.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when no photon is stored.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Nodes (inner and leaves).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Bytes the tree uses per stored photon, nodes included (for memory bounds).
    pub const BYTES_PER_PHOTON: usize =
        std::mem::size_of::<Point>() + std::mem::size_of::<Payload>() + std::mem::size_of::<Node>();

    /// Removes every photon, keeping the allocations.
    pub fn clear(&mut self) {
        self.nodes.clear();
        self.nodes.push(Node::leaf());
        self.points.clear();
        self.payload.clear();
    }

    /// Makes room for `n` more photons, growing geometrically but never past `cap` photons
    /// (a plain `Vec` doubling could allocate up to twice the map's bound).
    pub fn reserve(&mut self, n: usize, cap: usize) {
        let len = self.points.len();
        let target = (len + n).max(2 * len).min(cap.max(len + n));
        self.points.reserve_exact(target - len);
        self.payload.reserve_exact(target - len);
        // Leaves hold about three photons once split, and there are as many inner nodes:
        // fewer nodes than photons except where photons cluster.
        self.nodes
            .reserve_exact(target.saturating_sub(self.nodes.len()));
    }

    /// Adds one photon: descends to its leaf, links it in and splits the leaf while it holds
    /// more than [`LEAF_MAX`].
    pub fn insert(&mut self, photon: Photon) {
        let index = self.points.len() as u32;
        self.points.push(Point {
            p: photon.p,
            next: NIL,
        });
        self.payload.push(Payload {
            wi: photon.wi,
            ng: photon.ng,
            power: photon.power,
            depth: photon.depth,
        });
        let (mut lo, mut hi) = (self.lo, self.hi);
        let mut node = 0usize;
        let mut depth = 0;
        while self.nodes[node].axis != LEAF {
            let n = self.nodes[node];
            let a = n.axis as usize;
            if photon.p[a] < n.split {
                hi[a] = n.split;
                node = n.link as usize;
            } else {
                lo[a] = n.split;
                node = n.link as usize + 1;
            }
            depth += 1;
        }
        self.points[index as usize].next = self.nodes[node].link;
        self.nodes[node].link = index;
        self.nodes[node].count += 1;
        // A split can leave all photons on one side (they were clustered): keep splitting
        // that side.
        while self.nodes[node].count > LEAF_MAX && depth < MAX_DEPTH {
            let ext = hi - lo;
            let a = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let split = 0.5 * (lo[a] + hi[a]);
            let child = self.nodes.len() as u32;
            self.nodes.push(Node::leaf());
            self.nodes.push(Node::leaf());
            let mut item = self.nodes[node].link;
            while item != NIL {
                let after = self.points[item as usize].next;
                let side = (self.points[item as usize].p[a] >= split) as u32;
                let c = (child + side) as usize;
                self.points[item as usize].next = self.nodes[c].link;
                self.nodes[c].link = item;
                self.nodes[c].count += 1;
                item = after;
            }
            self.nodes[node] = Node {
                axis: a as u32,
                link: child,
                split,
                count: 0,
            };
            let lower = self.nodes[child as usize].count;
            if lower > LEAF_MAX {
                hi[a] = split;
                node = child as usize;
            } else {
                lo[a] = split;
                node = child as usize + 1;
            }
            depth += 1;
        }
    }

    /// Calls `f` for every photon within distance `r` of `x` (`|p − x|² ≤ r²`).
    pub fn for_each_within(&self, x: Vec3, r: f32, mut f: impl FnMut(&Photon)) {
        let r2 = r * r;
        // Depth is bounded by MAX_DEPTH, so a fixed stack suffices.
        let mut stack = [0u32; MAX_DEPTH as usize + 2];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let n = self.nodes[stack[top] as usize];
            if n.axis == LEAF {
                let mut item = n.link;
                while item != NIL {
                    let pt = self.points[item as usize];
                    if (pt.p - x).length_squared() <= r2 {
                        let pl = self.payload[item as usize];
                        f(&Photon {
                            p: pt.p,
                            wi: pl.wi,
                            ng: pl.ng,
                            power: pl.power,
                            depth: pl.depth,
                        });
                    }
                    item = pt.next;
                }
                continue;
            }
            let d = x[n.axis as usize] - n.split;
            // Both sides when the sphere straddles the plane; the near side only otherwise.
            if d - r < 0.0 {
                stack[top] = n.link;
                top += 1;
            }
            if d + r >= 0.0 {
                stack[top] = n.link + 1;
                top += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::PixelSampler;

    fn photon(p: Vec3) -> Photon {
        Photon {
            p,
            wi: Vec3::Z,
            ng: Vec3::Z,
            power: Vec3::ONE,
            depth: 2,
        }
    }

    #[test]
    fn range_query_equals_brute_force() {
        let mut tree = KdTree::new(Vec3::splat(-1.0), Vec3::new(2.0, 1.0, 0.5));
        let mut s = PixelSampler::new(1, 2, 3, 4);
        let mut pts = Vec::new();
        for i in 0..5000 {
            let u = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
            // A third clustered on a plane and a few coincident, as photons on walls are;
            // a few outside the box.
            let p = match i % 3 {
                0 => Vec3::new(u.x * 3.0 - 1.0, 0.25, u.z * 1.5 - 1.0),
                1 if i % 97 == 1 => Vec3::splat(0.3),
                _ => Vec3::new(u.x * 3.4 - 1.2, u.y * 2.0 - 1.0, u.z * 1.5 - 1.0),
            };
            pts.push(p);
            tree.insert(photon(p));
        }
        assert_eq!(tree.len(), pts.len());
        for q in 0..300 {
            let c = Vec3::new(s.next_1d() * 3.0 - 1.0, s.next_1d() * 2.0 - 1.0, 0.0);
            let c = if q % 10 == 0 { Vec3::splat(0.3) } else { c };
            let r = 0.02 + 0.3 * s.next_1d();
            let mut got: Vec<[u32; 3]> = Vec::new();
            tree.for_each_within(c, r, |ph| got.push(ph.p.to_array().map(f32::to_bits)));
            let mut want: Vec<[u32; 3]> = pts
                .iter()
                .filter(|p| (**p - c).length_squared() <= r * r)
                .map(|p| p.to_array().map(f32::to_bits))
                .collect();
            got.sort();
            want.sort();
            assert_eq!(got, want, "query {q} at {c} radius {r}");
        }
    }

    #[test]
    fn leaves_split_below_the_threshold() {
        let mut tree = KdTree::new(Vec3::ZERO, Vec3::ONE);
        let mut s = PixelSampler::new(5, 6, 7, 8);
        for _ in 0..2000 {
            tree.insert(photon(Vec3::new(s.next_1d(), s.next_1d(), s.next_1d())));
        }
        let leaves: Vec<&Node> = tree.nodes.iter().filter(|n| n.axis == LEAF).collect();
        assert!(leaves.iter().all(|n| n.count <= LEAF_MAX));
        assert_eq!(leaves.iter().map(|n| n.count).sum::<u32>(), 2000);
        // Coincident photons stop at the depth limit instead of splitting for ever.
        for _ in 0..50 {
            tree.insert(photon(Vec3::splat(0.5)));
        }
        let mut n = 0;
        tree.for_each_within(Vec3::splat(0.5), 0.0, |_| n += 1);
        assert_eq!(n, 50);
        tree.clear();
        assert!(tree.is_empty() && tree.node_count() == 1);
    }
}
