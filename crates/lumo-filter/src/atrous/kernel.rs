//! The À-Trous kernel for one block (strip × row) of one level, with the edge weights folded
//! into a single base-2 exponent per tap: weight = 2^(log2 h − e)·valid_q, where e is the
//! colour term plus the squared distance of feature coordinates that were scaled so that e is
//! already in log2 units.
//!
//! Two paths compute the same thing: the fused one (fused.rs) for levels whose taps
//! stay within the block margins, and the per-tap one here for wider levels (6th and later).
//! Both are compiled twice: for baseline x86-64 (SSE2) and, chosen at run time, with AVX2 +
//! FMA. The FMA copy rounds each fused multiply-add once instead of twice, so its results
//! differ from the baseline copy in the last bits (relative ~1e-6); each copy on its own is
//! deterministic and independent of the thread count (blocks are computed independently, with
//! no reductions across lanes or threads).

use super::fused::{block_fused, MAX_STEP};
use super::layout::{Layout, M, QW};
use super::B3;
use crate::common::fastmath::{exp2_cut, mul_add, EXP_CUTOFF};

/// Source planes per block: r, g, b, validity, variance.
pub(super) const K: usize = 5;
/// Largest number of feature coordinates: normal xyz, position xyz (the background flag is
/// folded into the position when there is one, see atrous.rs).
pub(super) const MAX_NF: usize = 6;
/// Aux planes per block: colour factor, luminance, then up to [`MAX_NF`] features.
pub(super) const KA: usize = 2 + MAX_NF;

/// Colour-weight modes: none.
pub(super) const CM_NONE: u8 = 0;
/// Fixed colour σ: squared RGB distance.
pub(super) const CM_FIXED: u8 = 1;
/// Variance-guided: absolute luminance distance.
pub(super) const CM_VARIANCE: u8 = 2;

/// Instruction set the kernel runs with (AVX-512 runs the pair and fused paths with 16-float
/// vectors and the per-tap path in its AVX2 copy).
pub(super) use lumo_simd::Isa;

/// Which kernel path a level takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Path {
    /// The fastest one the levels allow: the level pipeline, else pairs, else fused, else
    /// per tap.
    Auto,
    /// Pairs level by level where the level allows (never the pipeline).
    #[cfg_attr(not(test), allow(dead_code))] // tests compare the paths
    Pairs,
    /// The pipeline with this many rows per task and groups of strips (as `Auto` where it
    /// cannot run).
    #[cfg_attr(not(test), allow(dead_code))] // tests compare band splits
    Bands(usize, usize),
    /// Fused where the step allows, else per tap (never pairs).
    #[cfg_attr(not(test), allow(dead_code))] // tests compare the paths
    Fused,
    /// Per tap only.
    Taps,
}

/// Per-level constants and buffers shared by all blocks.
pub(super) struct Level<'a> {
    pub lay: Layout,
    pub step: usize,
    /// K planes per block (r, g, b, validity, variance).
    pub src: &'a [f32],
    /// KA planes per block (colour factor, luminance, scaled features).
    pub aux: &'a [f32],
    /// Feature coordinates in use (1, 3, 4 or 6; with 4 or 6 the first three are normals).
    pub nf: usize,
    /// Factor on the squared normal distance (the pair and fused paths' per-level normal
    /// scale, a power of 4; the per-tap path needs the planes scaled, i.e. 1).
    pub normal_factor: f32,
    pub cm: u8,
    /// The colour factor of a valid pixel (what the aux colour plane holds inside the strip).
    pub color_scale: f32,
    /// Carry the variance (only when a later level reads it).
    pub var: bool,
    pub isa: Isa,
    /// Kernel path (tests compare them).
    pub path: Path,
}

/// A block of the source buffer: K planes of QW floats.
pub(super) type SrcBlock = [f32; K * QW];
/// A block of the aux buffer: KA planes of QW floats.
pub(super) type AuxBlock = [f32; KA * QW];

impl Level<'_> {
    /// The source block of strip `c`, row `y`.
    pub fn src_block(&self, c: usize, y: usize) -> &SrcBlock {
        self.src[self.lay.block(c, y, K)..][..K * QW]
            .try_into()
            .expect("block size")
    }

    /// The aux block of strip `c`, row `y`.
    pub fn aux_block(&self, c: usize, y: usize) -> &AuxBlock {
        self.aux[self.lay.block(c, y, KA)..][..KA * QW]
            .try_into()
            .expect("block size")
    }
}

/// Log2 of the B3 weight of tap (kx, ky) and the exponent below which its weight is 0 (the
/// paper's weights below e^-20 — their denormal products would slow everything down).
pub(super) fn tap_consts(kx: usize, ky: usize) -> (f32, f32) {
    let c0 = (B3[ky] * B3[kx]).log2();
    (c0, c0 + EXP_CUTOFF * std::f32::consts::LOG2_E)
}

/// Whether a level of `step` that does not take the pair path takes the fused one.
pub(super) fn takes_fused(path: Path, step: usize) -> bool {
    path != Path::Taps && step <= MAX_STEP
}

/// Block `b` of one level into `dst` (K planes, the block's margins are left 0).
pub(super) fn block(l: &Level, b: usize, dst: &mut [f32]) {
    let fused = takes_fused(l.path, l.step);
    macro_rules! go {
        ($nf:literal, $cm:expr, $var:literal) => {
            if fused {
                block_fused::<$nf, $cm, $var>(l, b, dst)
            } else {
                block_taps::<$nf, $cm, $var>(l, b, dst)
            }
        };
    }
    match (l.nf, l.cm, l.var) {
        (1, CM_NONE, false) => go!(1, CM_NONE, false),
        (1, CM_FIXED, false) => go!(1, CM_FIXED, false),
        (1, CM_NONE, true) => go!(1, CM_NONE, true),
        (1, _, true) => go!(1, CM_VARIANCE, true),
        (3, CM_NONE, false) => go!(3, CM_NONE, false),
        (3, CM_FIXED, false) => go!(3, CM_FIXED, false),
        (3, CM_NONE, true) => go!(3, CM_NONE, true),
        (3, _, true) => go!(3, CM_VARIANCE, true),
        (4, CM_NONE, false) => go!(4, CM_NONE, false),
        (4, CM_FIXED, false) => go!(4, CM_FIXED, false),
        (4, CM_NONE, true) => go!(4, CM_NONE, true),
        (4, _, true) => go!(4, CM_VARIANCE, true),
        (_, CM_NONE, false) => go!(6, CM_NONE, false),
        (_, CM_FIXED, false) => go!(6, CM_FIXED, false),
        (_, CM_NONE, true) => go!(6, CM_NONE, true),
        (_, _, _) => go!(6, CM_VARIANCE, true),
    }
}

multiversion! {
    /// Divides the accumulated colour by the weight sum and the variance by its square
    /// (SVGF: the variance of a weighted mean is Σw²·var / (Σw)²); validity becomes 0/1.
    /// `acc` holds 5 accumulator planes `stride` apart from column `a0`; the results go to
    /// columns `d0..d0 + len` of the block `dst`. In the AVX-512 or AVX2 copy where the CPU
    /// has one (the baseline's 4-wide loop was ~7 % of a 512² filter).
    pub(super) fn normalise<const VAR: bool>(
        acc: &[f32],
        stride: usize,
        a0: usize,
        dst: &mut [f32],
        d0: usize,
        len: usize,
    ) as normalise_impl {
        let wsum = &acc[3 * stride + a0..][..len];
        let (rgb, rest) = dst.split_at_mut(3 * QW);
        let (valid, var) = rest.split_at_mut(QW);
        let (r, rest) = rgb.split_at_mut(QW);
        let (g, b) = rest.split_at_mut(QW);
        let (ar, ag, ab) = (
            &acc[a0..][..len],
            &acc[stride + a0..][..len],
            &acc[2 * stride + a0..][..len],
        );
        let av = if VAR {
            &acc[4 * stride + a0..][..len]
        } else {
            &[][..]
        };
        let (r, g, b) = (
            &mut r[d0..][..len],
            &mut g[d0..][..len],
            &mut b[d0..][..len],
        );
        let (valid, var) = (&mut valid[d0..][..len], &mut var[d0..][..len]);
        for i in 0..len {
            let s = wsum[i];
            let has = (s > 0.0) as u8 as f32;
            // One division per pixel; 0 where nothing contributed.
            let inv = has / s.max(1e-30);
            r[i] = ar[i] * inv;
            g[i] = ag[i] * inv;
            b[i] = ab[i] * inv;
            valid[i] = has;
            if VAR {
                var[i] = av[i] * (inv * inv);
            }
        }
    }
}

/// Columns of one tap: centre columns from `x0` (block column), tap columns from `q0` (in the
/// tap's block), `len` of them.
#[derive(Clone, Copy)]
struct Tap {
    x0: usize,
    q0: usize,
    len: usize,
    c0: f32,
    cut: f32,
}

/// The per-tap path: one tap at a time over the columns where it lies inside the image; a
/// tap's columns may fall into another strip (at most two).
fn block_taps<const NF: usize, const CM: u8, const VAR: bool>(
    l: &Level,
    b: usize,
    dst: &mut [f32],
) {
    let lay = l.lay;
    let (c, y) = lay.strip_row(b);
    let (sx0, len) = lay.strip(c);
    let step = l.step as isize;
    let mut acc = vec![0.0f32; K * QW];
    let prow = &l.src[lay.block(c, y, K)..][..K * QW];
    let paux = &l.aux[lay.block(c, y, KA)..][..KA * QW];
    for ky in 0..5 {
        let yy = y as isize + (ky as isize - 2) * step;
        if yy < 0 || yy >= lay.h as isize {
            continue;
        }
        let yy = yy as usize;
        for kx in 0..5 {
            let off = (kx as isize - 2) * step;
            // Image columns of the taps that lie inside the image.
            let lo = (sx0 as isize + off).max(0) as usize;
            let hi = ((sx0 + len) as isize + off).min(lay.w as isize);
            if hi <= lo as isize {
                continue;
            }
            let hi = hi as usize;
            let (c0, cut) = tap_consts(kx, ky);
            // Split where the taps cross into the next strip.
            let mut xa = lo;
            while xa < hi {
                let cq = xa / lay.sw;
                let xb = hi.min((cq + 1) * lay.sw);
                let qrow = &l.src[lay.block(cq, yy, K)..][..K * QW];
                let qaux = &l.aux[lay.block(cq, yy, KA)..][..KA * QW];
                let t = Tap {
                    x0: M + (xa as isize - off) as usize - sx0,
                    q0: M + xa - cq * lay.sw,
                    len: xb - xa,
                    c0,
                    cut,
                };
                match l.isa {
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: `Isa::Avx2` is only chosen after run-time detection of AVX2 and
                    // FMA.
                    Isa::Avx2 | Isa::Avx512 => unsafe {
                        tap_avx2::<NF, CM, VAR>(prow, qrow, paux, qaux, &mut acc, t)
                    },
                    _ => tap_base::<NF, CM, VAR>(prow, qrow, paux, qaux, &mut acc, t),
                }
                xa = xb;
            }
        }
    }
    dst.fill(0.0);
    normalise::<VAR>(&acc, QW, M, dst, M, len);
}

/// The tap loop compiled for the baseline target. Not inlined: its slice arguments are known
/// not to alias, so the loop vectorises without run-time overlap checks.
#[inline(never)]
fn tap_base<const NF: usize, const CM: u8, const VAR: bool>(
    prow: &[f32],
    qrow: &[f32],
    paux: &[f32],
    qaux: &[f32],
    acc: &mut [f32],
    t: Tap,
) {
    tap_impl::<NF, CM, VAR, false>(prow, qrow, paux, qaux, acc, t)
}

/// The same loop compiled with AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
unsafe fn tap_avx2<const NF: usize, const CM: u8, const VAR: bool>(
    prow: &[f32],
    qrow: &[f32],
    paux: &[f32],
    qaux: &[f32],
    acc: &mut [f32],
    t: Tap,
) {
    tap_impl::<NF, CM, VAR, true>(prow, qrow, paux, qaux, acc, t)
}

/// Accumulates one tap over `t.len` columns.
#[inline(always)]
fn tap_impl<const NF: usize, const CM: u8, const VAR: bool, const FMA: bool>(
    prow: &[f32],
    qrow: &[f32],
    paux: &[f32],
    qaux: &[f32],
    acc: &mut [f32],
    t: Tap,
) {
    let len = t.len;
    let ps = |row, k| sub_row(row, k * QW + t.x0, len);
    let qs = |row, k| sub_row(row, k * QW + t.q0, len);
    let (qr, qg, qb, qv) = (qs(qrow, 0), qs(qrow, 1), qs(qrow, 2), qs(qrow, 3));
    let qvar = if VAR { qs(qrow, 4) } else { &[][..] };
    let (pr, pg, pb) = if CM == CM_FIXED {
        (ps(prow, 0), ps(prow, 1), ps(prow, 2))
    } else {
        (&[][..], &[][..], &[][..])
    };
    let pc = if CM == CM_NONE { &[][..] } else { ps(paux, 0) };
    let (pl, ql) = if CM == CM_VARIANCE {
        (ps(paux, 1), qs(qaux, 1))
    } else {
        (&[][..], &[][..])
    };
    let pf: [&[f32]; NF] = std::array::from_fn(|k| ps(paux, 2 + k));
    let qf: [&[f32]; NF] = std::array::from_fn(|k| qs(qaux, 2 + k));
    let (ar, rest) = acc.split_at_mut(QW);
    let (ag, rest) = rest.split_at_mut(QW);
    let (ab, rest) = rest.split_at_mut(QW);
    let (aw, av) = rest.split_at_mut(QW);
    let ar = &mut ar[t.x0..][..len];
    let ag = &mut ag[t.x0..][..len];
    let ab = &mut ab[t.x0..][..len];
    let aw = &mut aw[t.x0..][..len];
    let av = if VAR {
        &mut av[t.x0..][..len]
    } else {
        &mut [][..]
    };
    for i in 0..len {
        let mut e = 0.0f32;
        if CM == CM_FIXED {
            let (dr, dg, db) = (pr[i] - qr[i], pg[i] - qg[i], pb[i] - qb[i]);
            let d2 = mul_add::<FMA>(db, db, mul_add::<FMA>(dg, dg, dr * dr));
            e = d2 * pc[i];
        }
        if CM == CM_VARIANCE {
            e = (pl[i] - ql[i]).abs() * pc[i];
        }
        for k in 0..NF {
            let d = pf[k][i] - qf[k][i];
            e = mul_add::<FMA>(d, d, e);
        }
        let wgt = exp2_cut::<FMA>(t.c0 - e, t.cut) * qv[i];
        ar[i] = mul_add::<FMA>(wgt, qr[i], ar[i]);
        ag[i] = mul_add::<FMA>(wgt, qg[i], ag[i]);
        ab[i] = mul_add::<FMA>(wgt, qb[i], ab[i]);
        aw[i] += wgt;
        if VAR {
            av[i] = mul_add::<FMA>(wgt * wgt, qvar[i], av[i]);
        }
    }
}

/// `len` values of `row` from `start`.
#[inline(always)]
fn sub_row(row: &[f32], start: usize, len: usize) -> &[f32] {
    &row[start..start + len]
}
