//! The lane-wise pieces of packet traversal: lane masks (with the single-ray code's NaN rules,
//! `crate::geometry::vmax`/`vmin`), one node's box test and one triangle's intersection
//! against all sixteen rays.

use super::{Lanes, PacketHits, Prepared, LANES};
use crate::accel::wide::{Node, Packet};
use crate::geometry::{vmax, vmin};

/// `b` where the mask is set, else `a`.
#[inline(always)]
pub(super) fn pick(mask: u32, a: f32, b: f32) -> f32 {
    f32::from_bits((a.to_bits() & !mask) | (b.to_bits() & mask))
}

/// Lane-mask operations, which the compiler does not form well from plain loops (a bool
/// array became a chain of byte extracts): one implementation per instruction set, each with
/// its compare-to-bitmask instructions.
pub(super) trait Masks {
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
pub(super) fn bits_mut(x: &mut Lanes) -> &mut [u32; LANES] {
    // SAFETY: f32 and u32 have the same size and alignment, and every bit pattern is valid
    // for both.
    unsafe { &mut *(x as *mut Lanes).cast::<[u32; LANES]>() }
}

/// The bits of a lane array.
#[inline(always)]
pub(super) fn bits(x: &Lanes) -> &[u32; LANES] {
    // SAFETY: as in `bits_mut`.
    unsafe { &*(x as *const Lanes).cast::<[u32; LANES]>() }
}

/// All ones in the lanes whose bit is set.
#[inline(always)]
pub(super) fn expand(bits: u32) -> [u32; LANES] {
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
pub(super) unsafe fn hit_box<M: Masks>(
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
pub(super) unsafe fn hit_triangle<M: Masks>(
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
/// (or as near, with a lower index: the single-ray tie rule, [`crate::accel::stack::keep_nearest`]).
///
/// # Safety
/// The CPU must support `M`'s instruction set.
#[inline(always)]
pub(super) unsafe fn keep<M: Masks>(hit: u32, id: u32, tuv: &[Lanes; 3], best: &mut PacketHits) {
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
