//! The À-Trous kernel's fast path for levels with taps at most [`MAX_STEP`] pixels apart (the
//! first five levels): all five taps of a kernel row are evaluated in one pass over the block,
//! with the accumulators in registers, every plane at a constant displacement and no column
//! clipping (the block margins cover the taps; see layout.rs).
//!
//! The per-pixel operations and their order are exactly those of the per-tap path (a tap
//! outside the image adds an exact zero instead of being skipped), so both paths give
//! bit-identical results.

use super::kernel::{normalise, tap_consts, AuxBlock, Isa, Level, SrcBlock, CM_FIXED, CM_VARIANCE};
use super::layout::{CW, M, QW};
use crate::common::fastmath::{exp2_cut, mul_add};

/// Largest tap spacing of the fused path: five taps span ±2·MAX_STEP = ±M columns.
pub(super) const MAX_STEP: usize = M / 2;

/// Planes of a block of the source buffer.
const R: usize = 0;
const V: usize = 3;
const VAR_P: usize = 4;
/// Planes of a block of the aux buffer: the variance-guided colour factor g, the luminance,
/// the features.
const G: usize = 0;
const L: usize = 1;
const F: usize = 2;
/// Accumulators: r, g, b, weight, variance.
const AN: usize = 5;

/// Block `b` of a level with `step <= MAX_STEP` into `dst` (K planes).
///
/// The fixed colour factor is formed here for this block's row alone (the variance-guided
/// one, g, is read from the aux plane, where the pair path needs it for every pixel), and the normal
/// coordinates are scaled by 1/step in the kernel (`sqrt(l.normal_factor)`), so no pass
/// writes them into the full-image aux planes before the level (at 1080p each such plane is
/// ≈ 11 MB of memory traffic per level). Scaling a difference by a power of 2 is exact.
pub(super) fn block_fused<const NF: usize, const CM: u8, const VAR: bool>(
    l: &Level,
    b: usize,
    dst: &mut [f32],
) {
    let lay = l.lay;
    let (c, y) = lay.strip_row(b);
    let (_, len) = lay.strip(c);
    let src_block = |yy: usize| l.src_block(c, yy);
    let aux_block = |yy: usize| l.aux_block(c, yy);
    let (p, pa) = (src_block(y), aux_block(y));
    let mut cp = [0.0f32; CW];
    let valid = &p[V * QW + M..][..len];
    match CM {
        CM_VARIANCE => cp[..len].copy_from_slice(&pa[G * QW + M..][..len]),
        CM_FIXED => {
            for (o, &v) in cp[..len].iter_mut().zip(valid) {
                *o = l.color_scale * v;
            }
        }
        _ => {}
    }
    // The normal weight's 1/stepwidth² as a scale on the normal differences (exact: a power
    // of 2; see `Level::normal_factor`).
    let ns = l.normal_factor.sqrt();
    let mut acc = [0.0f32; AN * CW];
    let mut first = true;
    for ky in 0..5 {
        let yy = y as isize + (ky as isize - 2) * l.step as isize;
        if yy < 0 || yy >= lay.h as isize {
            continue;
        }
        let (q, qa) = (src_block(yy as usize), aux_block(yy as usize));
        let mut c0 = [0.0f32; 5];
        let mut cut = [0.0f32; 5];
        for kx in 0..5 {
            (c0[kx], cut[kx]) = tap_consts(kx, ky);
        }
        let t = Taps {
            cp: &cp,
            ns,
            len,
            step: l.step,
            c0,
            cut,
            // The first row's sums start from 0 in registers: the same bits as from a
            // cleared accumulator, without clearing it.
            first,
        };
        first = false;
        match l.isa {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `Isa::Avx2` is only chosen after run-time detection of AVX2 and FMA.
            Isa::Avx2 => unsafe { fused_avx2::<NF, CM, VAR>(p, pa, q, qa, &mut acc, &t) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `Isa::Avx512` is only chosen after run-time detection of AVX-512F and FMA.
            Isa::Avx512 => unsafe { fused_avx512::<NF, CM, VAR>(p, pa, q, qa, &mut acc, &t) },
            _ => fused_base::<NF, CM, VAR>(p, pa, q, qa, &mut acc, &t),
        }
    }
    dst.fill(0.0);
    if first {
        // No row of taps inside the image (never for a valid layout): nothing contributed.
        return;
    }
    normalise::<VAR>(&acc, CW, 0, dst, M, len);
}

/// What one row of taps needs besides the blocks.
struct Taps<'a> {
    /// The centre pixels' colour factor (0 where the centre is missing).
    cp: &'a [f32; CW],
    /// Scale of the normal differences.
    ns: f32,
    len: usize,
    step: usize,
    c0: [f32; 5],
    cut: [f32; 5],
    /// The first row of taps: the sums start at 0 instead of being read.
    first: bool,
}

#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn fused_base<const NF: usize, const CM: u8, const VAR: bool>(
    p: &SrcBlock,
    pa: &AuxBlock,
    q: &SrcBlock,
    qa: &AuxBlock,
    acc: &mut [f32; AN * CW],
    t: &Taps,
) {
    fused_impl::<NF, CM, VAR, false>(p, pa, q, qa, acc, t)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
#[inline(never)]
unsafe fn fused_avx2<const NF: usize, const CM: u8, const VAR: bool>(
    p: &SrcBlock,
    pa: &AuxBlock,
    q: &SrcBlock,
    qa: &AuxBlock,
    acc: &mut [f32; AN * CW],
    t: &Taps,
) {
    fused_impl::<NF, CM, VAR, true>(p, pa, q, qa, acc, t)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
#[allow(clippy::too_many_arguments)]
#[inline(never)]
unsafe fn fused_avx512<const NF: usize, const CM: u8, const VAR: bool>(
    p: &SrcBlock,
    pa: &AuxBlock,
    q: &SrcBlock,
    qa: &AuxBlock,
    acc: &mut [f32; AN * CW],
    t: &Taps,
) {
    fused_impl::<NF, CM, VAR, true>(p, pa, q, qa, acc, t)
}

/// Five taps `step` apart of one kernel row, accumulated for `len` centre pixels.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn fused_impl<const NF: usize, const CM: u8, const VAR: bool, const FMA: bool>(
    p: &SrcBlock,
    pa: &AuxBlock,
    q: &SrcBlock,
    qa: &AuxBlock,
    acc: &mut [f32; AN * CW],
    t: &Taps,
) {
    let Taps {
        cp,
        ns,
        c0,
        cut,
        first,
        ..
    } = *t;
    // Clamps that tell the compiler every index below is in bounds.
    let len = t.len.min(CW);
    let step = t.step.min(MAX_STEP);
    // Normal coordinates come first (with positions or the background flag after them).
    let normals = if NF >= 4 { 3 } else { 0 };
    let offs = [M - 2 * step, M - step, M, M + step, M + 2 * step];
    for i in 0..len {
        let (mut ar, mut ag, mut ab, mut aw, mut av) = if first {
            (0.0, 0.0, 0.0, 0.0, 0.0)
        } else {
            (
                acc[i],
                acc[CW + i],
                acc[2 * CW + i],
                acc[3 * CW + i],
                if VAR { acc[4 * CW + i] } else { 0.0 },
            )
        };
        // A macro, not a closure: closures are not reliably inlined into the AVX2 copy, and an
        // out-of-line one would call `fmaf` from the library.
        macro_rules! tap {
            ($k:expr) => {{
                let k = $k;
                let j = i + offs[k];
                let qr = q[R * QW + j];
                let qg = q[(R + 1) * QW + j];
                let qb = q[(R + 2) * QW + j];
                let mut e = 0.0f32;
                if CM == CM_FIXED {
                    let dr = p[R * QW + M + i] - qr;
                    let dg = p[(R + 1) * QW + M + i] - qg;
                    let db = p[(R + 2) * QW + M + i] - qb;
                    let d2 = mul_add::<FMA>(db, db, mul_add::<FMA>(dg, dg, dr * dr));
                    e = d2 * cp[i];
                }
                if CM == CM_VARIANCE {
                    e = (pa[L * QW + M + i] - qa[L * QW + j]).abs() * cp[i];
                }
                for f in 0..NF {
                    let mut d = pa[(F + f) * QW + M + i] - qa[(F + f) * QW + j];
                    if f < normals {
                        d *= ns;
                    }
                    e = mul_add::<FMA>(d, d, e);
                }
                let wgt = exp2_cut::<FMA>(c0[k] - e, cut[k]) * q[V * QW + j];
                ar = mul_add::<FMA>(wgt, qr, ar);
                ag = mul_add::<FMA>(wgt, qg, ag);
                ab = mul_add::<FMA>(wgt, qb, ab);
                aw += wgt;
                if VAR {
                    av = mul_add::<FMA>(wgt * wgt, q[VAR_P * QW + j], av);
                }
            }};
        }
        tap!(0);
        tap!(1);
        tap!(2);
        tap!(3);
        tap!(4);
        acc[i] = ar;
        acc[CW + i] = ag;
        acc[2 * CW + i] = ab;
        acc[3 * CW + i] = aw;
        if VAR {
            acc[4 * CW + i] = av;
        }
    }
}
