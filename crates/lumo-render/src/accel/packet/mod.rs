//! Traversal of the 8-wide BVH ([`crate::accel::wide`]) by packets of 16 rays, for the wavefront
//! integrator ([`crate::integrators::path::wavefront`]).
//!
//! Why: one ray at a time, a Cornell-box query tests one node and ~2.2 leaf packets at ~140
//! cycles, most of it branches (which children were hit, in what order, which triangle is
//! nearest) rather than arithmetic. A packet tests each child box and each triangle against
//! sixteen rays with one set of vector operations (one AVX-512 register or two AVX2 ones),
//! so the branches are paid once per packet. Rays are lanes; the node's children and the
//! leaf's triangles are splatted one at a time.
//!
//! The arithmetic per lane is exactly the single-ray traversal's ([`crate::accel::bvh8`]): the same
//! slab distances, near-plane choice, 2-ulp widening and Möller–Trumbore variant with the
//! same fused multiply-adds, and the same tie rule between equally distant triangles (the
//! lower triangle index wins), so a packet finds bit for bit the hit each of its rays finds
//! alone. The kernels are plain loops over lane arrays that the compiler vectorises under
//! the enabled target features; the module is only used where [`crate::accel::bvh8::Bvh8`] exists
//! (AVX2 + FMA).

// Lane loops index several arrays in lockstep by lane: the form the vectoriser turns into one
// vector operation per statement.
#![allow(clippy::needless_range_loop)]

use glam::Vec3;

use crate::accel::stack::{sort_farthest_first, with_stack, TraversalStack, CULL_SLACK};
use crate::accel::wide::{WideBvh, EMPTY, LEAF};
use kernels::{hit_box, hit_triangle, keep, Masks};

/// Rays per packet.
pub use lumo_simd::LANES;

/// One f32 per lane, aligned for full-width vector loads.
use lumo_simd::Lanes;

/// Up to [`LANES`] rays, structure of arrays. Lanes past `count` are ignored.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct RayPacket {
    /// Origins, per axis.
    pub o: [Lanes; 3],
    /// Directions, per axis.
    pub d: [Lanes; 3],
    /// Smallest accepted ray parameter.
    pub tmin: Lanes,
    /// Largest accepted ray parameter.
    pub tmax: Lanes,
    /// Number of rays in use (the first `count` lanes).
    pub count: usize,
}

impl Default for RayPacket {
    fn default() -> Self {
        RayPacket {
            o: [[0.0; LANES]; 3],
            d: [[1.0; LANES]; 3],
            tmin: [0.0; LANES],
            tmax: [0.0; LANES],
            count: 0,
        }
    }
}

impl RayPacket {
    /// Sets lane `lane` to `origin + t·dir`, t in [tmin, tmax], and makes sure it is counted.
    #[inline]
    pub fn set(&mut self, lane: usize, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) {
        for axis in 0..3 {
            self.o[axis][lane] = origin[axis];
            self.d[axis][lane] = dir[axis];
        }
        self.tmin[lane] = tmin;
        self.tmax[lane] = tmax;
        self.count = self.count.max(lane + 1);
    }

    /// Bit `i` set for each lane in use.
    #[inline]
    fn used(&self) -> u32 {
        if self.count >= 32 {
            u32::MAX
        } else {
            (1u32 << self.count) - 1
        }
    }
}

/// The nearest hits of a packet's rays: `id[i] == EMPTY` where ray `i` hit nothing.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct PacketHits {
    /// Ray parameter of the hit.
    pub t: Lanes,
    /// Barycentric weight of the second vertex.
    pub u: Lanes,
    /// Barycentric weight of the third vertex.
    pub v: Lanes,
    /// Mesh triangle index, or `EMPTY`.
    pub id: [u32; LANES],
}

/// A packet prepared for traversal: reciprocal directions and near-plane choices per lane.
#[repr(C, align(64))]
struct Prepared {
    o: [Lanes; 3],
    d: [Lanes; 3],
    inv: [Lanes; 3],
    /// All ones where the direction's component is negative (the near plane is `hi`).
    neg: [[u32; LANES]; 3],
    tmin: Lanes,
}

impl Prepared {
    #[inline(always)]
    fn new(rays: &RayPacket) -> Self {
        let mut p = Prepared {
            o: rays.o,
            d: rays.d,
            inv: [[0.0; LANES]; 3],
            neg: [[0; LANES]; 3],
            tmin: rays.tmin,
        };
        // The single-ray traversal's slopes (`bvh_wide::ray_slopes`), lane by lane, so both compute
        // the same slab distances.
        for axis in 0..3 {
            for i in 0..LANES {
                let d = rays.d[axis][i];
                let inv = if d.abs() < 1e-30 {
                    1e30f32.copysign(d)
                } else {
                    1.0 / d
                };
                p.inv[axis][i] = inv;
                p.neg[axis][i] = if inv < 0.0 { u32::MAX } else { 0 };
            }
        }
        p
    }
}

/// A pushed subtree: its node reference, the lanes that entered its box and where.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Entry {
    tnear: Lanes,
    node: u32,
    lanes: u32,
}

/// A subtree entered by at most this many rays of a packet is traversed by each of them alone
/// (the single-ray 8-wide traversal): a packet's box test costs sixteen lanes whatever the
/// number of rays still in it, so once rays diverge (secondary rays in a large scene) single
/// rays are cheaper. Measured on the Cornell box and its 18k-triangle variant (docs/renderer.md).
const FEW_LANES: u32 = 3;

/// Ray `i` of a packet.
#[inline(always)]
fn lane_ray(rays: &RayPacket, i: usize) -> (Vec3, Vec3) {
    (
        Vec3::new(rays.o[0][i], rays.o[1][i], rays.o[2][i]),
        Vec3::new(rays.d[0][i], rays.d[1][i], rays.d[2][i]),
    )
}

/// Closest-hit traversal of the subtree `node` by each ray of `lanes` alone, merged into the
/// packet's hits with the same tie rule.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[inline(never)]
unsafe fn closest_alone(
    tree: &WideBvh<8>,
    node: u32,
    rays: &RayPacket,
    mut lanes: u32,
    best: &mut PacketHits,
    cull: &mut Lanes,
) {
    while lanes != 0 {
        let i = lanes.trailing_zeros() as usize;
        lanes &= lanes - 1;
        let (o, d) = lane_ray(rays, i);
        #[cfg(target_arch = "x86_64")]
        let hit = with_stack(tree.stack_need, |stack| {
            // SAFETY: per this function's contract.
            unsafe {
                crate::accel::bvh8::avx2::closest(tree, node, o, d, rays.tmin[i], best.t[i], stack)
            }
        });
        #[cfg(not(target_arch = "x86_64"))]
        let hit: Option<crate::accel::wide::TriHit> =
            unreachable!("Bvh8 exists only on x86-64: {o}{d}{node}{tree:?}");
        if let Some(h) = hit {
            if h.t < best.t[i] || (h.t == best.t[i] && h.triangle < best.id[i]) {
                best.t[i] = h.t;
                best.u[i] = h.u;
                best.v[i] = h.v;
                best.id[i] = h.triangle;
                cull[i] = h.t * CULL_SLACK;
            }
        }
    }
}

/// Any-hit traversal of the subtree `node` by each ray of `lanes` alone: the lanes blocked.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[inline(never)]
unsafe fn any_alone(tree: &WideBvh<8>, node: u32, rays: &RayPacket, lanes: u32) -> u32 {
    let mut blocked = 0;
    let mut rest = lanes;
    while rest != 0 {
        let i = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        let (o, d) = lane_ray(rays, i);
        #[cfg(target_arch = "x86_64")]
        let hit = with_stack(tree.stack_need, |stack| {
            // SAFETY: per this function's contract.
            unsafe {
                crate::accel::bvh8::avx2::any(tree, node, o, d, rays.tmin[i], rays.tmax[i], stack)
            }
        });
        #[cfg(not(target_arch = "x86_64"))]
        let hit: bool = unreachable!("Bvh8 exists only on x86-64: {o}{d}{node}{tree:?}");
        blocked |= (hit as u32) << i;
    }
    blocked
}

/// The closest-hit traversal, compiled once per instruction set by the wrappers below.
///
/// # Safety
/// The CPU must support `M`'s instruction set and FMA.
#[inline(always)]
unsafe fn closest_impl<M: Masks>(
    tree: &WideBvh<8>,
    rays: &RayPacket,
    mut stack: TraversalStack<Entry>,
) -> PacketHits {
    let r = Prepared::new(rays);
    let mut best = PacketHits {
        t: rays.tmax,
        u: [0.0; LANES],
        v: [0.0; LANES],
        id: [EMPTY; LANES],
    };
    // Boxes are culled against the best hit with slack, as in the single-ray traversal.
    let mut cull = [0.0f32; LANES];
    for i in 0..LANES {
        cull[i] = best.t[i] * CULL_SLACK;
    }
    let mut current = 0u32;
    let mut lanes = rays.used();
    let mut tnear = [[0.0f32; LANES]; 8];
    let mut tuv = [[0.0f32; LANES]; 3];
    loop {
        if current & LEAF != 0 {
            let pk = &tree.packets[(current & !LEAF) as usize];
            // The triangles are tested against the best hits at the leaf's entry, so the tests
            // do not wait for each other's merges; `keep` compares with the current best.
            let tmax = best.t;
            for j in 0..8 {
                let id = pk.id[j];
                if id == EMPTY {
                    break;
                }
                // SAFETY: the caller runs with `M`'s instruction set and FMA.
                let hit = unsafe { hit_triangle::<M>(pk, j, &r, &tmax, &mut tuv) } & lanes;
                // Unconditionally: whether any lane hits is data-dependent and mispredicted
                // often; merging an empty mask is cheaper than a wrong guess.
                // SAFETY: as above.
                unsafe { keep::<M>(hit, id, &tuv, &mut best) };
            }
            // Only box tests read the culling distances: once per leaf is enough.
            for i in 0..LANES {
                cull[i] = best.t[i] * CULL_SLACK;
            }
        } else if lanes.count_ones() <= FEW_LANES {
            // SAFETY: the caller runs with AVX2 and FMA.
            unsafe { closest_alone(tree, current, rays, lanes, &mut best, &mut cull) };
        } else {
            let node = &tree.nodes[current as usize];
            let mut hits = [(0u32, 0u32, f32::INFINITY); 8];
            let mut n = 0;
            for c in 0..8 {
                if node.child[c] == EMPTY {
                    continue;
                }
                // SAFETY: as above.
                let m = unsafe { hit_box::<M>(node, c, &r, &cull, &mut tnear[c]) } & lanes;
                if m != 0 {
                    // Ordered by the entry distance of the first lane that entered. The nearest
                    // entry over all of them (a 16-lane masked reduction per child) cost more
                    // than its better order saved: without it, Cornell +2.6 %, cornell-spheres
                    // +3.9 %, atrium ±0.
                    hits[n] = (c as u32, m, tnear[c][m.trailing_zeros() as usize]);
                    n += 1;
                }
            }
            if n > 0 {
                let hits = &mut hits[..n];
                sort_farthest_first(hits, |h| h.2);
                for &(c, m, _) in &hits[..n - 1] {
                    stack.push(Entry {
                        tnear: tnear[c as usize],
                        node: node.child[c as usize],
                        lanes: m,
                    });
                }
                let (c, m, _) = hits[n - 1];
                current = node.child[c as usize];
                lanes = m;
                continue;
            }
        }
        loop {
            let Some(e) = stack.pop() else {
                return best;
            };
            // Lanes whose hit so far is nearer than the subtree's box drop out.
            // SAFETY: as above.
            let m = e.lanes & unsafe { M::le(&e.tnear, &cull) };
            if m != 0 {
                current = e.node;
                lanes = m;
                break;
            }
        }
    }
}

/// The any-hit traversal: bit `i` of the result is set if ray `i` hits anything.
///
/// # Safety
/// As [`closest_impl`].
#[inline(always)]
unsafe fn any_impl<M: Masks>(
    tree: &WideBvh<8>,
    rays: &RayPacket,
    mut stack: TraversalStack<(u32, u32)>,
) -> u32 {
    let r = Prepared::new(rays);
    let tmax = rays.tmax;
    let mut done = 0u32;
    let mut current = 0u32;
    let mut lanes = rays.used();
    let mut tnear = [0.0f32; LANES];
    let mut tuv = [[0.0f32; LANES]; 3];
    loop {
        if current & LEAF != 0 {
            let pk = &tree.packets[(current & !LEAF) as usize];
            for j in 0..8 {
                if pk.id[j] == EMPTY || lanes == 0 {
                    break;
                }
                // SAFETY: the caller runs with `M`'s instruction set and FMA.
                let hit = unsafe { hit_triangle::<M>(pk, j, &r, &tmax, &mut tuv) } & lanes;
                done |= hit;
                lanes &= !hit;
            }
        } else if lanes.count_ones() <= FEW_LANES {
            // SAFETY: the caller runs with AVX2 and FMA.
            done |= unsafe { any_alone(tree, current, rays, lanes) };
        } else {
            let node = &tree.nodes[current as usize];
            let mut next: Option<(u32, u32)> = None;
            for c in 0..8 {
                let child = node.child[c];
                if child == EMPTY {
                    continue;
                }
                // SAFETY: as above.
                let m = unsafe { hit_box::<M>(node, c, &r, &tmax, &mut tnear) } & lanes;
                if m != 0 {
                    if let Some(prev) = next.replace((child, m)) {
                        stack.push(prev);
                    }
                }
            }
            if let Some((child, m)) = next {
                current = child;
                lanes = m;
                continue;
            }
        }
        loop {
            let Some((node, m)) = stack.pop() else {
                return done;
            };
            let m = m & !done;
            if m != 0 {
                current = node;
                lanes = m;
                break;
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod dispatch;
mod kernels;

/// What a packet that hits nothing reports.
fn no_hits(rays: &RayPacket) -> PacketHits {
    PacketHits {
        t: rays.tmax,
        u: [0.0; LANES],
        v: [0.0; LANES],
        id: [EMPTY; LANES],
    }
}

/// Nearest hits of the packet's rays in `tree`. Only called through [`crate::accel::bvh8::Bvh8`],
/// which exists only on x86-64 where AVX2 and FMA were detected.
pub(crate) fn closest(tree: &WideBvh<8>, rays: &RayPacket) -> PacketHits {
    closest_at(true, tree, rays)
}

/// [`closest`] with the AVX2 kernel even where AVX-512 exists if `avx512` is false (tests run
/// both).
pub(crate) fn closest_at(avx512: bool, tree: &WideBvh<8>, rays: &RayPacket) -> PacketHits {
    if tree.nodes.is_empty() || rays.count == 0 {
        return no_hits(rays);
    }
    #[cfg(target_arch = "x86_64")]
    {
        with_stack(tree.stack_need, |stack| {
            // SAFETY: `Bvh8` (the only caller) exists only where AVX2 and FMA were detected;
            // the AVX-512 variant additionally checks its own features.
            unsafe {
                if avx512 && dispatch::has_avx512() {
                    dispatch::closest_avx512(tree, rays, stack)
                } else {
                    dispatch::closest_avx2(tree, rays, stack)
                }
            }
        })
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        unreachable!("Bvh8 exists only on x86-64")
    }
}

/// Bit `i` set if ray `i` of the packet hits anything in `tree` (same caller rule as
/// [`closest`]).
pub(crate) fn any(tree: &WideBvh<8>, rays: &RayPacket) -> u32 {
    any_at(true, tree, rays)
}

/// [`any`] with the choice of kernel of [`closest_at`].
pub(crate) fn any_at(avx512: bool, tree: &WideBvh<8>, rays: &RayPacket) -> u32 {
    if tree.nodes.is_empty() || rays.count == 0 {
        return 0;
    }
    #[cfg(target_arch = "x86_64")]
    {
        with_stack(tree.stack_need, |stack| {
            // SAFETY: as in `closest`.
            unsafe {
                if avx512 && dispatch::has_avx512() {
                    dispatch::any_avx512(tree, rays, stack)
                } else {
                    dispatch::any_avx2(tree, rays, stack)
                }
            }
        })
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        unreachable!("Bvh8 exists only on x86-64")
    }
}
