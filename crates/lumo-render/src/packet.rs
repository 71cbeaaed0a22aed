//! Traversal of the 8-wide BVH ([`crate::bvh_wide`]) by packets of 16 rays, for the wavefront
//! integrator ([`crate::wavefront`]).
//!
//! Why: one ray at a time, a Cornell-box query tests one node and ~2.2 leaf packets at ~140
//! cycles, most of it branches (which children were hit, in what order, which triangle is
//! nearest) rather than arithmetic. A packet tests each child box and each triangle against
//! sixteen rays with one set of vector operations (one AVX-512 register or two AVX2 ones),
//! so the branches are paid once per packet. Rays are lanes; the node's children and the
//! leaf's triangles are splatted one at a time.
//!
//! The arithmetic per lane is exactly the single-ray traversal's ([`crate::bvh8`]): the same
//! slab distances, near-plane choice, 2-ulp widening and Möller–Trumbore variant with the
//! same fused multiply-adds, and the same tie rule between equally distant triangles (the
//! lower triangle index wins), so a packet finds bit for bit the hit each of its rays finds
//! alone. The kernels are plain loops over lane arrays that the compiler vectorises under
//! the enabled target features; the module is only used where [`crate::bvh8::Bvh8`] exists
//! (AVX2 + FMA).

// Lane loops index several arrays in lockstep by lane: the form the vectoriser turns into one
// vector operation per statement.
#![allow(clippy::needless_range_loop)]

use glam::Vec3;

use crate::bvh_stack::{sort_farthest_first, with_stack, TraversalStack, CULL_SLACK};
use crate::bvh_wide::{Node, Packet, WideBvh, EMPTY, LEAF};

/// Rays per packet.
pub const LANES: usize = 16;

/// One f32 per lane, aligned for full-width vector loads.
type Lanes = [f32; LANES];

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

/// `x86 maxps` semantics (the second operand when either is NaN), as the single-ray code.
#[inline(always)]
fn vmax(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// `x86 minps` semantics.
#[inline(always)]
fn vmin(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// `b` where the mask is set, else `a`.
#[inline(always)]
fn pick(mask: u32, a: f32, b: f32) -> f32 {
    f32::from_bits((a.to_bits() & !mask) | (b.to_bits() & mask))
}

/// Lane-mask operations, which the compiler does not form well from plain loops (a bool
/// array became a chain of byte extracts): one implementation per instruction set, each with
/// its compare-to-bitmask instructions.
trait Masks {
    /// Bit `i` set where `a[i] <= b[i]` (false if either is NaN).
    ///
    /// # Safety
    /// The CPU must support the implementation's instruction set.
    unsafe fn le(a: &Lanes, b: &Lanes) -> u32;
    /// Bit `i` set where `a[i] < b[i]`.
    ///
    /// # Safety
    /// As [`Masks::le`].
    unsafe fn lt(a: &Lanes, b: &Lanes) -> u32;
    /// Bit `i` set where `a[i] == b[i]`.
    ///
    /// # Safety
    /// As [`Masks::le`].
    unsafe fn eq(a: &Lanes, b: &Lanes) -> u32;
    /// Bit `i` set where `a[i] < b[i]`, unsigned.
    ///
    /// # Safety
    /// As [`Masks::le`].
    unsafe fn lt_u32(a: &[u32; LANES], b: &[u32; LANES]) -> u32;
    /// `a[i] = b[i]` in the lanes whose bit is set (any 32-bit lanes, as bits).
    ///
    /// # Safety
    /// As [`Masks::le`].
    #[inline(always)]
    unsafe fn blend(mask: u32, a: &mut [u32; LANES], b: &[u32; LANES]) {
        let m = expand(mask);
        for i in 0..LANES {
            a[i] = (a[i] & !m[i]) | (b[i] & m[i]);
        }
    }
}

/// The bits of a lane array, for [`Masks::blend`].
#[inline(always)]
fn bits_mut(x: &mut Lanes) -> &mut [u32; LANES] {
    // SAFETY: f32 and u32 have the same size and alignment, and every bit pattern is valid
    // for both.
    unsafe { &mut *(x as *mut Lanes).cast::<[u32; LANES]>() }
}

/// The bits of a lane array.
#[inline(always)]
fn bits(x: &Lanes) -> &[u32; LANES] {
    // SAFETY: as in `bits_mut`.
    unsafe { &*(x as *const Lanes).cast::<[u32; LANES]>() }
}

/// All ones in the lanes whose bit is set.
#[inline(always)]
fn expand(bits: u32) -> [u32; LANES] {
    let mut m = [0u32; LANES];
    for (i, v) in m.iter_mut().enumerate() {
        *v = ((bits >> i) & 1).wrapping_neg();
    }
    m
}

/// Slab test of every lane against child `c` of `node`: the lanes that enter the box within
/// [tmin, tmax] and their entry distances.
///
/// # Safety
/// The CPU must support `M`'s instruction set.
#[inline(always)]
unsafe fn hit_box<M: Masks>(
    node: &Node<8>,
    c: usize,
    r: &Prepared,
    tmax: &Lanes,
    tnear: &mut Lanes,
) -> u32 {
    let p = &node.planes;
    let (lx, hx, ly, hy, lz, hz) = (p[0][c], p[1][c], p[2][c], p[3][c], p[4][c], p[5][c]);
    let mut tfar = [0.0f32; LANES];
    for i in 0..LANES {
        let ax = (lx - r.o[0][i]) * r.inv[0][i];
        let bx = (hx - r.o[0][i]) * r.inv[0][i];
        let ay = (ly - r.o[1][i]) * r.inv[1][i];
        let by = (hy - r.o[1][i]) * r.inv[1][i];
        let az = (lz - r.o[2][i]) * r.inv[2][i];
        let bz = (hz - r.o[2][i]) * r.inv[2][i];
        let (nx, fx) = (pick(r.neg[0][i], ax, bx), pick(r.neg[0][i], bx, ax));
        let (ny, fy) = (pick(r.neg[1][i], ay, by), pick(r.neg[1][i], by, ay));
        let (nz, fz) = (pick(r.neg[2][i], az, bz), pick(r.neg[2][i], bz, az));
        tnear[i] = vmax(vmax(nx, ny), vmax(nz, r.tmin[i]));
        tfar[i] = vmin(vmin(fx, fy), vmin(fz, tmax[i])) * 1.000_000_4;
    }
    // SAFETY: the caller runs with `M`'s instruction set.
    unsafe { M::le(tnear, &tfar) }
}

/// Tests every lane against triangle `j` of `pk`: the lanes hit within [tmin, tmax], with
/// (t, u, v) written for all lanes.
///
/// # Safety
/// The CPU must support `M`'s instruction set and FMA (else `mul_add` is a library call).
#[inline(always)]
unsafe fn hit_triangle<M: Masks>(
    pk: &Packet<8>,
    j: usize,
    r: &Prepared,
    tmax: &Lanes,
    tuv: &mut [Lanes; 3],
) -> u32 {
    let v0 = [pk.v0[0][j], pk.v0[1][j], pk.v0[2][j]];
    let e1 = [pk.e1[0][j], pk.e1[1][j], pk.e1[2][j]];
    let e2 = [pk.e2[0][j], pk.e2[1][j], pk.e2[2][j]];
    let n = [pk.n[0][j], pk.n[1][j], pk.n[2][j]];
    let mut w = [0.0f32; LANES];
    for i in 0..LANES {
        let (dx, dy, dz) = (r.d[0][i], r.d[1][i], r.d[2][i]);
        let cx = v0[0] - r.o[0][i];
        let cy = v0[1] - r.o[1][i];
        let cz = v0[2] - r.o[2][i];
        // r = d × c, each component one rounding of its product difference (fmsub).
        let rx = dy.mul_add(cz, -(dz * cy));
        let ry = dz.mul_add(cx, -(dx * cz));
        let rz = dx.mul_add(cy, -(dy * cx));
        let det = n[2].mul_add(dz, n[1].mul_add(dy, n[0] * dx));
        let inv = 1.0 / det;
        let u = e2[2].mul_add(rz, e2[1].mul_add(ry, e2[0] * rx)) * inv;
        let v = e1[2].mul_add(rz, e1[1].mul_add(ry, e1[0] * rx)) * inv;
        w[i] = (1.0 - u) - v;
        tuv[0][i] = n[2].mul_add(cz, n[1].mul_add(cy, n[0] * cx)) * inv;
        tuv[1][i] = u;
        tuv[2][i] = v;
    }
    const ZERO: Lanes = [0.0; LANES];
    // SAFETY: the caller runs with `M`'s instruction set.
    unsafe {
        M::le(&ZERO, &tuv[1])
            & M::le(&ZERO, &tuv[2])
            & M::le(&ZERO, &w)
            & M::le(&r.tmin, &tuv[0])
            & M::le(&tuv[0], tmax)
    }
}

/// Keeps, in the lanes `hit`, triangle `id`'s hit where it is nearer than the best so far
/// (or as near, with a lower index: the single-ray tie rule, [`crate::bvh_stack::keep_nearest`]).
///
/// # Safety
/// The CPU must support `M`'s instruction set.
#[inline(always)]
unsafe fn keep<M: Masks>(hit: u32, id: u32, tuv: &[Lanes; 3], best: &mut PacketHits) {
    let ids = [id; LANES];
    // All in vector registers and mask bits: the merges of a leaf's triangles form a chain, so
    // its latency is what a leaf costs.
    // SAFETY: the caller runs with `M`'s instruction set.
    unsafe {
        let nearer = M::lt(&tuv[0], &best.t);
        let tied = M::eq(&tuv[0], &best.t) & M::lt_u32(&ids, &best.id);
        let take = hit & (nearer | tied);
        M::blend(take, bits_mut(&mut best.t), bits(&tuv[0]));
        M::blend(take, bits_mut(&mut best.u), bits(&tuv[1]));
        M::blend(take, bits_mut(&mut best.v), bits(&tuv[2]));
        M::blend(take, &mut best.id, &ids);
    }
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
            unsafe { crate::bvh8::avx2::closest(tree, node, o, d, rays.tmin[i], best.t[i], stack) }
        });
        #[cfg(not(target_arch = "x86_64"))]
        let hit: Option<crate::bvh_wide::TriHit> =
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
            unsafe { crate::bvh8::avx2::any(tree, node, o, d, rays.tmin[i], rays.tmax[i], stack) }
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
mod dispatch {
    use std::arch::x86_64::*;

    use super::*;

    /// AVX-512: one compare into a mask register.
    pub(super) struct Avx512;

    /// `cmp(a, b)` over all sixteen lanes into a mask register.
    macro_rules! avx512_mask {
        ($a:expr, $b:expr, $pred:ident) => {{
            let (a, b): (&Lanes, &Lanes) = ($a, $b);
            let (a, b) = (_mm512_loadu_ps(a.as_ptr()), _mm512_loadu_ps(b.as_ptr()));
            u32::from(_mm512_cmp_ps_mask::<$pred>(a, b))
        }};
    }

    impl Masks for Avx512 {
        #[inline(always)]
        unsafe fn le(a: &Lanes, b: &Lanes) -> u32 {
            // SAFETY: AVX-512 F per the trait's contract; both arrays hold 16 floats.
            unsafe { avx512_mask!(a, b, _CMP_LE_OQ) }
        }
        #[inline(always)]
        unsafe fn lt(a: &Lanes, b: &Lanes) -> u32 {
            // SAFETY: as in `le`.
            unsafe { avx512_mask!(a, b, _CMP_LT_OQ) }
        }
        #[inline(always)]
        unsafe fn eq(a: &Lanes, b: &Lanes) -> u32 {
            // SAFETY: as in `le`.
            unsafe { avx512_mask!(a, b, _CMP_EQ_OQ) }
        }
        #[inline(always)]
        unsafe fn lt_u32(a: &[u32; LANES], b: &[u32; LANES]) -> u32 {
            // SAFETY: as in `le`.
            unsafe {
                let a = _mm512_loadu_si512(a.as_ptr().cast());
                let b = _mm512_loadu_si512(b.as_ptr().cast());
                u32::from(_mm512_cmplt_epu32_mask(a, b))
            }
        }
        #[inline(always)]
        unsafe fn blend(mask: u32, a: &mut [u32; LANES], b: &[u32; LANES]) {
            // SAFETY: as in `le`.
            unsafe {
                let va = _mm512_loadu_si512(a.as_ptr().cast());
                let vb = _mm512_loadu_si512(b.as_ptr().cast());
                let r = _mm512_mask_blend_epi32(mask as __mmask16, va, vb);
                _mm512_storeu_si512(a.as_mut_ptr().cast(), r);
            }
        }
    }

    /// AVX2: two 8-lane compares and their sign masks.
    pub(super) struct Avx2;

    /// `movemask(cmp(a, b))` over both halves.
    macro_rules! avx2_mask {
        ($a:expr, $b:expr, $pred:ident) => {{
            let (a, b): (&Lanes, &Lanes) = ($a, $b);
            let lo =
                _mm256_cmp_ps::<$pred>(_mm256_loadu_ps(a.as_ptr()), _mm256_loadu_ps(b.as_ptr()));
            let hi = _mm256_cmp_ps::<$pred>(
                _mm256_loadu_ps(a.as_ptr().add(8)),
                _mm256_loadu_ps(b.as_ptr().add(8)),
            );
            (_mm256_movemask_ps(lo) as u32) | ((_mm256_movemask_ps(hi) as u32) << 8)
        }};
    }

    impl Masks for Avx2 {
        #[inline(always)]
        unsafe fn le(a: &Lanes, b: &Lanes) -> u32 {
            // SAFETY: AVX per the trait's contract; both arrays hold 16 floats.
            unsafe { avx2_mask!(a, b, _CMP_LE_OQ) }
        }
        #[inline(always)]
        unsafe fn lt(a: &Lanes, b: &Lanes) -> u32 {
            // SAFETY: as in `le`.
            unsafe { avx2_mask!(a, b, _CMP_LT_OQ) }
        }
        #[inline(always)]
        unsafe fn eq(a: &Lanes, b: &Lanes) -> u32 {
            // SAFETY: as in `le`.
            unsafe { avx2_mask!(a, b, _CMP_EQ_OQ) }
        }
        #[inline(always)]
        unsafe fn lt_u32(a: &[u32; LANES], b: &[u32; LANES]) -> u32 {
            // SAFETY: as in `le`. Unsigned order is signed order with the top bits flipped.
            unsafe {
                let flip = _mm256_set1_epi32(i32::MIN);
                let mut bits = 0;
                for k in [0, 8] {
                    let x = _mm256_xor_si256(_mm256_loadu_si256(a.as_ptr().add(k).cast()), flip);
                    let y = _mm256_xor_si256(_mm256_loadu_si256(b.as_ptr().add(k).cast()), flip);
                    let lt = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(y, x)));
                    bits |= (lt as u32) << k;
                }
                bits
            }
        }
    }

    /// # Safety
    /// The CPU must support AVX-512 F/VL, AVX2 and FMA.
    #[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
    pub(super) unsafe fn closest_avx512(
        tree: &WideBvh<8>,
        rays: &RayPacket,
        stack: TraversalStack<Entry>,
    ) -> PacketHits {
        // SAFETY: the features are enabled here.
        unsafe { closest_impl::<Avx512>(tree, rays, stack) }
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn closest_avx2(
        tree: &WideBvh<8>,
        rays: &RayPacket,
        stack: TraversalStack<Entry>,
    ) -> PacketHits {
        // SAFETY: the features are enabled here.
        unsafe { closest_impl::<Avx2>(tree, rays, stack) }
    }

    /// # Safety
    /// The CPU must support AVX-512 F/VL, AVX2 and FMA.
    #[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
    pub(super) unsafe fn any_avx512(
        tree: &WideBvh<8>,
        rays: &RayPacket,
        stack: TraversalStack<(u32, u32)>,
    ) -> u32 {
        // SAFETY: the features are enabled here.
        unsafe { any_impl::<Avx512>(tree, rays, stack) }
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn any_avx2(
        tree: &WideBvh<8>,
        rays: &RayPacket,
        stack: TraversalStack<(u32, u32)>,
    ) -> u32 {
        // SAFETY: the features are enabled here.
        unsafe { any_impl::<Avx2>(tree, rays, stack) }
    }

    /// Whether the AVX-512 kernels can run here (and `LUMO_SIMD` does not rule them out).
    pub(super) fn has_avx512() -> bool {
        crate::simd_level::simd_level() >= 2
    }
}

/// What a packet that hits nothing reports.
fn no_hits(rays: &RayPacket) -> PacketHits {
    PacketHits {
        t: rays.tmax,
        u: [0.0; LANES],
        v: [0.0; LANES],
        id: [EMPTY; LANES],
    }
}

/// Nearest hits of the packet's rays in `tree`. Only called through [`crate::bvh8::Bvh8`],
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
