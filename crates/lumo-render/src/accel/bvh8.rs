//! Traversal of the 8-wide BVH ([`crate::accel::wide`]) one ray at a time with AVX2 + FMA,
//! chosen at run time where the CPU has them (the build stays baseline x86-64).
//!
//! Why: with 4-wide nodes and 4-triangle leaves a Cornell-box ray tested 3.2 nodes and 2.3
//! packets at ~670 instructions per closest-hit query, half of a path's instructions in all.
//! Eight lanes halve the tree's depth and the number of leaves a ray visits, and the AVX
//! encoding's three-operand form drops the register copies the SSE code needs; the measured
//! effect is in docs/renderer.md.
//!
//! The triangle test is [`crate::accel::bvh4`]'s, with the cross and dot products as fused
//! multiply-adds: hits agree with the 4-wide traversal to rounding, not bit for bit.

use glam::Vec3;

use crate::accel::packet::{self, PacketHits, RayPacket};
#[cfg(target_arch = "x86_64")]
use crate::accel::stack::with_stack;
use crate::accel::wide::{TriHit, WideBvh};

/// The 8-wide BVH of one mesh. Exists only where AVX2 and FMA were detected, which is what
/// makes its safe methods sound.
#[derive(Clone, Debug)]
pub struct Bvh8 {
    tree: WideBvh<8>,
}

impl Bvh8 {
    /// Whether this CPU can traverse an 8-wide BVH.
    pub fn available() -> bool {
        // The hardware, not the `LUMO_SIMD` cap: the cap changes speed only, and
        // `LUMO_BVH_WIDTH=4` is what chooses the 4-wide tree.
        lumo_simd::Isa::hardware() >= lumo_simd::Isa::Avx2
    }

    /// Wraps `tree` if this CPU has AVX2 and FMA.
    pub fn new(tree: WideBvh<8>) -> Option<Self> {
        Self::available().then_some(Bvh8 { tree })
    }

    /// The tree (for tests and statistics).
    #[cfg_attr(not(test), allow(dead_code))]
    pub(crate) fn tree(&self) -> &WideBvh<8> {
        &self.tree
    }

    /// Nearest hit of `origin + t·dir` with t in [tmin, tmax].
    #[inline]
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<TriHit> {
        if self.tree.nodes.is_empty() {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        {
            with_stack(self.tree.stack_need, |stack| {
                // SAFETY: a `Bvh8` exists only where AVX2 and FMA were detected (`new`).
                unsafe { avx2::closest(&self.tree, 0, origin, dir, tmin, tmax, stack) }
            })
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = (origin, dir, tmin, tmax);
            unreachable!("Bvh8::new returns None without AVX2")
        }
    }

    /// Nearest hits of a packet of rays (the same hits as [`Bvh8::intersect`] per ray).
    #[inline]
    pub fn intersect_packet(&self, rays: &RayPacket) -> PacketHits {
        packet::closest(&self.tree, rays)
    }

    /// Bit `i` set if ray `i` of the packet hits anything.
    #[inline]
    pub fn occluded_packet(&self, rays: &RayPacket) -> u32 {
        packet::any(&self.tree, rays)
    }

    /// True if anything hits `origin + t·dir` with t in [tmin, tmax].
    #[inline]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        if self.tree.nodes.is_empty() {
            return false;
        }
        #[cfg(target_arch = "x86_64")]
        {
            with_stack(self.tree.stack_need, |stack| {
                // SAFETY: a `Bvh8` exists only where AVX2 and FMA were detected (`new`).
                unsafe { avx2::any(&self.tree, 0, origin, dir, tmin, tmax, stack) }
            })
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = (origin, dir, tmin, tmax);
            unreachable!("Bvh8::new returns None without AVX2")
        }
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2 {
    use std::arch::x86_64::*;

    use glam::Vec3;

    use crate::accel::stack::{
        descend_any, descend_nearest, keep_nearest, pop_closer, TraversalStack, CULL_SLACK,
    };
    use crate::accel::wide::{ray_slopes, Node, Packet, TriHit, WideBvh, LEAF};

    /// A ray splatted over eight lanes, and its near-plane choice per axis.
    struct Ray8 {
        o: [__m256; 3],
        d: [__m256; 3],
        inv: [__m256; 3],
        near: [usize; 3],
        tmin: __m256,
    }

    impl Ray8 {
        #[inline(always)]
        unsafe fn new(origin: Vec3, dir: Vec3, tmin: f32) -> Ray8 {
            let (inv, near) = ray_slopes(dir);
            // SAFETY: the caller runs with AVX enabled.
            unsafe {
                Ray8 {
                    o: [
                        _mm256_set1_ps(origin.x),
                        _mm256_set1_ps(origin.y),
                        _mm256_set1_ps(origin.z),
                    ],
                    d: [
                        _mm256_set1_ps(dir.x),
                        _mm256_set1_ps(dir.y),
                        _mm256_set1_ps(dir.z),
                    ],
                    inv: [
                        _mm256_set1_ps(inv.x),
                        _mm256_set1_ps(inv.y),
                        _mm256_set1_ps(inv.z),
                    ],
                    near,
                    tmin: _mm256_set1_ps(tmin),
                }
            }
        }
    }

    /// An aligned 8-lane load.
    #[inline(always)]
    unsafe fn ld(a: &[f32; 8]) -> __m256 {
        // SAFETY: nodes and packets are 32-byte aligned and each array's offset in them is a
        // multiple of 32.
        unsafe { _mm256_load_ps(a.as_ptr()) }
    }

    /// Slab test against the eight boxes of `node`: the lanes hit within [tmin, tmax] and
    /// their entry distances.
    #[inline(always)]
    unsafe fn hit_boxes(node: &Node<8>, r: &Ray8, tmax: __m256) -> (u32, __m256) {
        // SAFETY: the caller runs with AVX2 and FMA enabled.
        unsafe {
            // Written out per axis rather than as a closure: closures do not inherit the
            // caller's target features, and one that is not inlined passes vectors through
            // memory.
            let p = &node.planes;
            let [ox, oy, oz] = r.o;
            let [ix, iy, iz] = r.inv;
            let [ax, ay, az] = r.near;
            let nx = _mm256_mul_ps(_mm256_sub_ps(ld(&p[ax]), ox), ix);
            let fx = _mm256_mul_ps(_mm256_sub_ps(ld(&p[1 - ax]), ox), ix);
            let ny = _mm256_mul_ps(_mm256_sub_ps(ld(&p[2 + ay]), oy), iy);
            let fy = _mm256_mul_ps(_mm256_sub_ps(ld(&p[3 - ay]), oy), iy);
            let nz = _mm256_mul_ps(_mm256_sub_ps(ld(&p[4 + az]), oz), iz);
            let fz = _mm256_mul_ps(_mm256_sub_ps(ld(&p[5 - az]), oz), iz);
            let t0 = _mm256_max_ps(_mm256_max_ps(nx, ny), _mm256_max_ps(nz, r.tmin));
            // Widened by 2 ulp-ish (Ize 2013) so rounding in the slab distances never culls a
            // box the ray actually touches.
            let t1 = _mm256_mul_ps(
                _mm256_min_ps(_mm256_min_ps(fx, fy), _mm256_min_ps(fz, tmax)),
                _mm256_set1_ps(1.000_000_4),
            );
            let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1);
            (_mm256_movemask_ps(hit) as u32, t0)
        }
    }

    /// Tests the ray against the triangles of `pk`: the lanes hit within [tmin, tmax] and
    /// their (t, u, v).
    #[inline(always)]
    unsafe fn hit_packet(pk: &Packet<8>, r: &Ray8, tmax: __m256) -> (u32, __m256, __m256, __m256) {
        // SAFETY: the caller runs with AVX2 and FMA enabled.
        unsafe {
            let [dx, dy, dz] = r.d;
            let cx = _mm256_sub_ps(ld(&pk.v0[0]), r.o[0]);
            let cy = _mm256_sub_ps(ld(&pk.v0[1]), r.o[1]);
            let cz = _mm256_sub_ps(ld(&pk.v0[2]), r.o[2]);
            // r = d × c
            let rx = _mm256_fmsub_ps(dy, cz, _mm256_mul_ps(dz, cy));
            let ry = _mm256_fmsub_ps(dz, cx, _mm256_mul_ps(dx, cz));
            let rz = _mm256_fmsub_ps(dx, cy, _mm256_mul_ps(dy, cx));
            let (nx, ny, nz) = (ld(&pk.n[0]), ld(&pk.n[1]), ld(&pk.n[2]));
            let det = dot3(nx, ny, nz, dx, dy, dz);
            // det = 0 (ray in the triangle's plane) gives inv = ±∞ and u, v, w of ±∞ or NaN,
            // of which at least one fails its test.
            let inv = _mm256_div_ps(_mm256_set1_ps(1.0), det);
            let u = _mm256_mul_ps(
                dot3(rx, ry, rz, ld(&pk.e2[0]), ld(&pk.e2[1]), ld(&pk.e2[2])),
                inv,
            );
            let v = _mm256_mul_ps(
                dot3(rx, ry, rz, ld(&pk.e1[0]), ld(&pk.e1[1]), ld(&pk.e1[2])),
                inv,
            );
            let w = _mm256_sub_ps(_mm256_sub_ps(_mm256_set1_ps(1.0), u), v);
            let t = _mm256_mul_ps(dot3(nx, ny, nz, cx, cy, cz), inv);
            let zero = _mm256_setzero_ps();
            let m = _mm256_and_ps(
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GE_OQ>(u, zero),
                    _mm256_cmp_ps::<_CMP_GE_OQ>(v, zero),
                ),
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GE_OQ>(w, zero),
                    _mm256_and_ps(
                        _mm256_cmp_ps::<_CMP_GE_OQ>(t, r.tmin),
                        _mm256_cmp_ps::<_CMP_LE_OQ>(t, tmax),
                    ),
                ),
            );
            (_mm256_movemask_ps(m) as u32, t, u, v)
        }
    }

    /// a·b over three lane-wise coordinates.
    #[inline(always)]
    unsafe fn dot3(
        ax: __m256,
        ay: __m256,
        az: __m256,
        bx: __m256,
        by: __m256,
        bz: __m256,
    ) -> __m256 {
        // SAFETY: the caller runs with AVX2 and FMA enabled.
        unsafe { _mm256_fmadd_ps(az, bz, _mm256_fmadd_ps(ay, by, _mm256_mul_ps(ax, bx))) }
    }

    /// The eight lanes of `v`.
    #[inline(always)]
    unsafe fn lanes(v: __m256) -> [f32; 8] {
        let mut a = [0.0f32; 8];
        // SAFETY: `a` holds eight floats; the caller runs with AVX enabled.
        unsafe { _mm256_storeu_ps(a.as_mut_ptr(), v) };
        a
    }

    /// Closest-hit traversal of the subtree at `start` (0: the whole tree): nearest child
    /// first, the others pushed with their entry distance so they are skipped once a closer
    /// hit is known.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA. (`stack` must hold `tree.stack_need` entries, or a
    /// push panics.)
    #[target_feature(enable = "avx2,fma")]
    pub(crate) unsafe fn closest(
        tree: &WideBvh<8>,
        start: u32,
        origin: Vec3,
        dir: Vec3,
        tmin: f32,
        mut tmax: f32,
        mut stack: TraversalStack<(u32, f32)>,
    ) -> Option<TriHit> {
        // SAFETY: AVX2 and FMA are enabled in this function.
        let r = unsafe { Ray8::new(origin, dir, tmin) };
        let mut best: Option<TriHit> = None;
        let mut current = start;
        loop {
            if current & LEAF != 0 {
                let pk = &tree.packets[(current & !LEAF) as usize];
                // SAFETY: as above.
                let (bits, t, u, v) = unsafe { hit_packet(pk, &r, _mm256_set1_ps(tmax)) };
                if bits != 0 {
                    // SAFETY: as above.
                    let (t, u, v) = unsafe { (lanes(t), lanes(u), lanes(v)) };
                    keep_nearest(bits, [&t, &u, &v], &pk.id, &mut tmax, &mut best);
                }
            } else {
                let node = &tree.nodes[current as usize];
                let cull = _mm256_set1_ps(tmax * CULL_SLACK);
                // SAFETY: as above.
                let (bits, tnear) = unsafe { hit_boxes(node, &r, cull) };
                if bits != 0 {
                    current = if bits.is_power_of_two() {
                        // One child hit (the common case near the leaves): no ordering.
                        node.child[bits.trailing_zeros() as usize]
                    } else {
                        // SAFETY: as above.
                        descend_nearest(&node.child, &unsafe { lanes(tnear) }, bits, &mut stack)
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

    /// Any-hit traversal of the subtree at `start`: stops at the first triangle hit, in no
    /// particular order.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA. (`stack` must hold `tree.stack_need` entries, or a
    /// push panics.)
    #[target_feature(enable = "avx2,fma")]
    pub(crate) unsafe fn any(
        tree: &WideBvh<8>,
        start: u32,
        origin: Vec3,
        dir: Vec3,
        tmin: f32,
        tmax: f32,
        mut stack: TraversalStack<u32>,
    ) -> bool {
        // SAFETY: AVX2 and FMA are enabled in this function.
        let r = unsafe { Ray8::new(origin, dir, tmin) };
        let vtmax = _mm256_set1_ps(tmax);
        let mut current = start;
        loop {
            if current & LEAF != 0 {
                let pk = &tree.packets[(current & !LEAF) as usize];
                // SAFETY: as above.
                if unsafe { hit_packet(pk, &r, vtmax) }.0 != 0 {
                    return true;
                }
            } else {
                let node = &tree.nodes[current as usize];
                // SAFETY: as above.
                let (bits, _) = unsafe { hit_boxes(node, &r, vtmax) };
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
