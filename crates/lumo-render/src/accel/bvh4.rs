//! Traversal of the 4-wide BVH ([`crate::accel::wide`]) one ray at a time with 4-lane SIMD
//! (glam's `Vec4`: SSE2 on x86-64, NEON/scalar elsewhere): the portable traversal, used where
//! the 8-wide AVX2 one ([`crate::accel::bvh8`]) is not available.
//!
//! Why not obvhs's compressed CWBVH: its nodes are quantised for GPU memory bandwidth, so a
//! scalar CPU traversal spends most of its time decoding child boxes and walking leaf
//! triangles one by one through a callback; for the small and mid-sized scenes lumo renders
//! that decode cost dominated the per-ray time.

use glam::{BVec4A, Vec3, Vec4};

use crate::accel::stack::{
    descend_any, descend_nearest, keep_nearest, pop_closer, with_stack, TraversalStack, CULL_SLACK,
};
use crate::accel::wide::{ray_slopes, TriHit, WideBvh, LEAF};

/// The 4-wide BVH of one mesh.
pub type Bvh4 = WideBvh<4>;
type Node = crate::accel::wide::Node<4>;
type Packet = crate::accel::wide::Packet<4>;

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
        let (inv, near) = ray_slopes(dir);
        RayData {
            o: [origin.x, origin.y, origin.z].map(Vec4::splat),
            d: [dir.x, dir.y, dir.z].map(Vec4::splat),
            inv: [inv.x, inv.y, inv.z].map(Vec4::splat),
            near,
        }
    }
}

/// Slab test of a ray against the four boxes of `node`: the lanes hit within [tmin, tmax]
/// and their entry distances.
#[inline(always)]
fn hit_boxes(node: &Node, r: &RayData, tmin: f32, tmax: f32) -> (u32, Vec4) {
    let p = &node.planes;
    let slab = |axis: usize| {
        let near = Vec4::from_array(p[2 * axis + r.near[axis]]);
        let far = Vec4::from_array(p[2 * axis + 1 - r.near[axis]]);
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
    let [v0x, v0y, v0z] = packet.v0.map(Vec4::from_array);
    let [e1x, e1y, e1z] = packet.e1.map(Vec4::from_array);
    let [e2x, e2y, e2z] = packet.e2.map(Vec4::from_array);
    let [nx, ny, nz] = packet.n.map(Vec4::from_array);
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
    /// Nearest hit of `origin + t·dir` with t in [tmin, tmax].
    #[inline]
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<TriHit> {
        if self.nodes.is_empty() {
            return None;
        }
        let r = RayData::new(origin, dir);
        with_stack(self.stack_need, |stack| self.closest(&r, tmin, tmax, stack))
    }

    /// True if anything hits `origin + t·dir` with t in [tmin, tmax].
    #[inline]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let r = RayData::new(origin, dir);
        with_stack(self.stack_need, |stack| self.any(&r, tmin, tmax, stack))
    }

    /// Closest-hit traversal: nearest child first, the others pushed with their entry
    /// distance so they are skipped once a closer hit is known.
    fn closest(
        &self,
        r: &RayData,
        tmin: f32,
        mut tmax: f32,
        mut stack: TraversalStack<(u32, f32)>,
    ) -> Option<TriHit> {
        let mut best: Option<TriHit> = None;
        let mut current = 0u32;
        loop {
            if current & LEAF != 0 {
                let packet = &self.packets[(current & !LEAF) as usize];
                let (mask, t, u, v) = hit_packet(packet, r, tmin, tmax);
                let bits = mask.bitmask();
                if bits != 0 {
                    let (t, u, v) = (t.to_array(), u.to_array(), v.to_array());
                    keep_nearest(bits, [&t, &u, &v], &packet.id, &mut tmax, &mut best);
                }
            } else {
                let node = &self.nodes[current as usize];
                let (bits, tnear) = hit_boxes(node, r, tmin, tmax * CULL_SLACK);
                if bits != 0 {
                    current = if bits.is_power_of_two() {
                        // One child hit (the common case near the leaves): no ordering.
                        node.child[bits.trailing_zeros() as usize]
                    } else {
                        descend_nearest(&node.child, &tnear.to_array(), bits, &mut stack)
                    };
                    continue;
                }
            }
            match pop_closer(&mut stack, tmax * CULL_SLACK) {
                Some(child) => current = child,
                None => return best,
            }
        }
    }

    /// Any-hit traversal: stops at the first triangle hit, in no particular order.
    fn any(&self, r: &RayData, tmin: f32, tmax: f32, mut stack: TraversalStack<u32>) -> bool {
        let mut current = 0u32;
        loop {
            if current & LEAF != 0 {
                let packet = &self.packets[(current & !LEAF) as usize];
                if hit_packet(packet, r, tmin, tmax).0.any() {
                    return true;
                }
            } else {
                let node = &self.nodes[current as usize];
                let (bits, _) = hit_boxes(node, r, tmin, tmax);
                if bits != 0 {
                    current = descend_any(&node.child, bits, &mut stack);
                    continue;
                }
            }
            match stack.pop() {
                Some(child) => current = child,
                None => return false,
            }
        }
    }
}
