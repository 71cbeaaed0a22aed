//! The À-Trous kernel's symmetric-pair path, for levels whose weights are symmetric (no colour
//! weight, or the paper's fixed colour σ; not SVGF's variance-guided one, whose σ belongs to
//! the centre pixel) and whose taps stay within [`MAX_PAIR_STEP`] pixels.
//!
//! Why: the edge-stopping weight of a pixel pair, exp(−e(p, q)), is the same seen from p and
//! from q, and so is the B3 weight. Of the 24 non-centre taps of a 5×5 kernel, the 12 "after"
//! the centre in row-major order are mirrors of the 12 before it; computing each pair's
//! weight once and adding it to both pixels halves the exponentials and feature distances,
//! which are most of the kernel's arithmetic.
//!
//! How: bands of rows are swept top to bottom by one thread each. Row y adds its pairs'
//! contributions to its own sum (kept in registers) and scatters the mirrored ones into the
//! accumulator rows of y + step and y + 2·step, held in a ring of 2·step + 1 rows; row y is
//! complete once it has been swept, and is normalised then. A band first sweeps the 2·step
//! rows above it for their scatter alone, so bands are independent. Every pixel's sum is
//! formed in the same order whatever the band boundaries or the thread count (row y − 2s,
//! then y − s, then y itself), so results are deterministic.
//!
//! The colour coefficient of a pair is the centre's σ factor times the neighbour's validity:
//! from a valid pixel's side it equals the per-tap path's (an invalid neighbour gets weight 0
//! anyway), and from an invalid pixel's side it is 0, as there (no colour to compare).
//! Results differ from the per-tap path by rounding only (the order of the sums differs).

use std::cell::RefCell;

use rayon::prelude::*;

use crate::atrous::B3;
use crate::atrous_kernel::{
    normalise, AuxBlock, Isa, Level, SrcBlock, CM_FIXED, CM_NONE, CM_VARIANCE, K,
};
use crate::atrous_layout::{CW, M, QW};
use crate::fastmath::{exp2_cut, mul_add, EXP_CUTOFF};

/// Largest tap spacing of the pair path: a strip sweeps pixels up to 2·step into its
/// neighbours (for their scatter) and reads taps 2·step beyond those, 4·step ≤ M.
pub(crate) const MAX_PAIR_STEP: usize = M / 4;

/// Column alignment of the swept range: the widest vector (16 floats).
const CHUNK: usize = 16;

/// Accumulator planes per row: r, g, b, weight.
const AN: usize = 4;
type Acc = [f32; AN * QW];

/// Source planes: colour from 0, validity.
const V: usize = 3;
/// Aux planes: features from F (the colour factor and luminance planes are not read).
const F: usize = 2;

/// (dx, dy) in steps of the 12 taps after the centre in row-major order; dy picks the row.
const PAIRS: [(isize, usize); 12] = [
    (1, 0),
    (2, 0),
    (-2, 1),
    (-1, 1),
    (0, 1),
    (1, 1),
    (2, 1),
    (-2, 2),
    (-1, 2),
    (0, 2),
    (1, 2),
    (2, 2),
];

/// The centre tap's B3 weight (its edge weight is exactly 1).
const CENTRE: f32 = B3[2] * B3[2];

/// Whether a level (its step, variance carrying, colour mode and feature count) can take
/// the pair path.
pub(crate) fn supports(step: usize, var: bool, cm: u8, nf: usize) -> bool {
    step <= MAX_PAIR_STEP && !var && cm != CM_VARIANCE && matches!(nf, 1 | 3 | 4 | 6)
}

thread_local! {
    /// Each worker's accumulator ring, kept between bands and levels (allocating and
    /// page-faulting up to 33 rows per band would cost more than the rows' arithmetic).
    static RING: RefCell<Vec<Acc>> = const { RefCell::new(Vec::new()) };
}

/// One level over the whole image into `dst` (K planes per block; margins left 0).
pub(crate) fn level(l: &Level, dst: &mut [f32]) {
    let lay = l.lay;
    let block = K * QW;
    // Bands tall enough that the 2·step rows swept twice stay a small part of the work
    // (≤ 8 %), and enough of them to share between threads.
    let band_rows = (16 * l.step).max(128);
    dst.par_chunks_mut(block * lay.h)
        .enumerate()
        .for_each(|(c, strip)| {
            strip
                .par_chunks_mut(block * band_rows)
                .enumerate()
                .for_each(|(bi, out)| {
                    let a = bi * band_rows;
                    let b = (a + band_rows).min(lay.h);
                    RING.with(|r| band(l, c, a, b, out, &mut r.borrow_mut()));
                });
        });
}

/// Which of a row's pair groups (dy = 0, 1, 2 steps) add to the row itself (`own`) and
/// which scatter into the row below (`scatter[dy]`).
#[derive(Clone, Copy)]
struct RowJob {
    own: [bool; 3],
    scatter: [bool; 3],
    j_lo: usize,
    j_hi: usize,
    step: usize,
    color_scale: f32,
    normal_factor: f32,
}

/// Rows [a, b) of strip `c` into `out` (their blocks).
fn band(l: &Level, c: usize, a: usize, b: usize, out: &mut [f32], ring: &mut Vec<Acc>) {
    let lay = l.lay;
    let s = l.step;
    let rn = 2 * s + 1;
    // Rows are cleared as they are finished, and a band finishes every row it adds to, so
    // the ring is all zeros between bands (new rows are zeroed by `resize`).
    if ring.len() < rn {
        ring.resize(rn, [0.0; AN * QW]);
    }
    debug_assert!(ring.iter().all(|r| r.iter().all(|&v| v == 0.0)));
    let (_, len) = lay.strip(c);
    // Swept columns: the strip, plus 2·step into a neighbouring strip (whose pixels scatter
    // into this one), rounded out to whole chunks of [`CHUNK`] columns.
    let j_lo = if c > 0 { (M - 2 * s) & !(CHUNK - 1) } else { M };
    let j_hi = if c + 1 < lay.nch {
        (M + len + 2 * s).next_multiple_of(CHUNK)
    } else {
        (M + len).next_multiple_of(CHUNK)
    };
    debug_assert!(j_hi + 2 * s <= QW && len <= CW);
    let src = |y: usize| l.src_block(c, y);
    let aux = |y: usize| l.aux_block(c, y);
    let in_band = |y: usize| y >= a && y < b;
    for y in a.saturating_sub(2 * s)..b {
        let own = in_band(y);
        let mut job = RowJob {
            own: [false; 3],
            scatter: [false; 3],
            j_lo,
            j_hi,
            step: s,
            color_scale: l.color_scale,
            normal_factor: l.normal_factor,
        };
        for dy in 0..3 {
            let yq = y + dy * s;
            job.own[dy] = own && yq < lay.h;
            job.scatter[dy] = in_band(yq);
        }
        let yq = |dy: usize| (y + dy * s).min(lay.h - 1);
        let (q1, q2) = (yq(1), yq(2));
        let [a0, a1, a2] = ring
            .get_disjoint_mut([y % rn, (y + s) % rn, (y + 2 * s) % rn])
            .expect("ring rows are distinct");
        let rows = Rows {
            p: src(y),
            pa: aux(y),
            q1: src(q1),
            qa1: aux(q1),
            q2: src(q2),
            qa2: aux(q2),
        };
        row(l, &rows, a0, a1, a2, job);
        if own {
            let d = &mut out[(y - a) * K * QW..][..K * QW];
            // Margins (refilled from the neighbours, or 0 beyond the image) and the colour,
            // validity and variance planes' columns beyond the strip: 0.
            for k in 0..4 {
                d[k * QW..k * QW + M].fill(0.0);
                d[k * QW + M + len..(k + 1) * QW].fill(0.0);
            }
            d[4 * QW..5 * QW].fill(0.0);
            normalise::<false>(&a0[..], QW, M, d, len);
            a0.fill(0.0);
        }
    }
}

/// The source and aux blocks of a row and of the rows one and two steps below it.
struct Rows<'a> {
    p: &'a SrcBlock,
    pa: &'a AuxBlock,
    q1: &'a SrcBlock,
    qa1: &'a AuxBlock,
    q2: &'a SrcBlock,
    qa2: &'a AuxBlock,
}

/// Dispatch of one row on the level's feature count, colour mode and instruction set.
fn row(l: &Level, r: &Rows, a0: &mut Acc, a1: &mut Acc, a2: &mut Acc, job: RowJob) {
    macro_rules! go {
        ($nf:literal, $cm:expr) => {
            match l.isa {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: `Isa::Avx512` is only chosen after run-time detection of AVX-512F/VL
                // and FMA.
                Isa::Avx512 => unsafe { row_avx512::<$nf, $cm>(r, a0, a1, a2, job) },
                #[cfg(target_arch = "x86_64")]
                // SAFETY: `Isa::Avx2` is only chosen after run-time detection of AVX2 and FMA.
                Isa::Avx2 => unsafe { row_avx2::<$nf, $cm>(r, a0, a1, a2, job) },
                _ => row_base::<$nf, $cm>(r, a0, a1, a2, job),
            }
        };
    }
    match (l.nf, l.cm) {
        (1, CM_NONE) => go!(1, CM_NONE),
        (1, _) => go!(1, CM_FIXED),
        (3, CM_NONE) => go!(3, CM_NONE),
        (3, _) => go!(3, CM_FIXED),
        (4, CM_NONE) => go!(4, CM_NONE),
        (4, _) => go!(4, CM_FIXED),
        (_, CM_NONE) => go!(6, CM_NONE),
        (_, _) => go!(6, CM_FIXED),
    }
}

#[inline(never)]
fn row_base<const NF: usize, const CM: u8>(
    r: &Rows,
    a0: &mut Acc,
    a1: &mut Acc,
    a2: &mut Acc,
    job: RowJob,
) {
    row_impl::<NF, CM, 4, false, false>(r, a0, a1, a2, job)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
unsafe fn row_avx2<const NF: usize, const CM: u8>(
    r: &Rows,
    a0: &mut Acc,
    a1: &mut Acc,
    a2: &mut Acc,
    job: RowJob,
) {
    row_impl::<NF, CM, 8, true, false>(r, a0, a1, a2, job)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
#[inline(never)]
unsafe fn row_avx512<const NF: usize, const CM: u8>(
    r: &Rows,
    a0: &mut Acc,
    a1: &mut Acc,
    a2: &mut Acc,
    job: RowJob,
) {
    row_impl::<NF, CM, 16, true, true>(r, a0, a1, a2, job)
}

/// [`exp2_cut`] of 16 exponents with AVX-512's round-to-integer and scale instructions: the
/// same polynomial on the same reduced argument, 6 instructions fewer than the portable
/// bit manipulation (which the other builds use). Exactly 0 below `cut` and for NaN.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn exp2_cut_x16(t: &[f32], cut: f32) -> [f32; 16] {
    use std::arch::x86_64::*;
    const C1: f32 = std::f32::consts::LN_2;
    const C2: f32 = C1 * C1 / 2.0;
    const C3: f32 = C2 * C1 / 3.0;
    const C4: f32 = C3 * C1 / 4.0;
    const C5: f32 = C4 * C1 / 5.0;
    let mut out = [0.0f32; 16];
    assert!(t.len() >= 16);
    // SAFETY: 16 floats are read from `t` and written to `out` (checked above).
    unsafe {
        let t = _mm512_loadu_ps(t.as_ptr());
        let keep = _mm512_cmp_ps_mask::<_CMP_GE_OQ>(t, _mm512_set1_ps(cut));
        let i = _mm512_roundscale_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(t);
        let f = _mm512_sub_ps(t, i);
        let mut p = _mm512_fmadd_ps(f, _mm512_set1_ps(C5), _mm512_set1_ps(C4));
        p = _mm512_fmadd_ps(f, p, _mm512_set1_ps(C3));
        p = _mm512_fmadd_ps(f, p, _mm512_set1_ps(C2));
        p = _mm512_fmadd_ps(f, p, _mm512_set1_ps(C1));
        p = _mm512_fmadd_ps(f, p, _mm512_set1_ps(1.0));
        _mm512_storeu_ps(out.as_mut_ptr(), _mm512_maskz_scalef_ps(keep, p, i));
    }
    out
}

/// `L` floats of `s` from `at`.
#[inline(always)]
fn ld<const L: usize>(s: &[f32], at: usize) -> [f32; L] {
    s[at..at + L].try_into().expect("L floats")
}

/// One row's pairs, `L` columns at a time (the arrays are the vector registers).
#[inline(always)]
fn row_impl<const NF: usize, const CM: u8, const L: usize, const FMA: bool, const X512: bool>(
    r: &Rows,
    a0: &mut Acc,
    a1: &mut Acc,
    a2: &mut Acc,
    job: RowJob,
) {
    let step = job.step.min(MAX_PAIR_STEP) as isize;
    let mut c0 = [0.0f32; 12];
    for (k, &(dx, dy)) in PAIRS.iter().enumerate() {
        c0[k] = (B3[(dx + 2) as usize] * B3[dy + 2]).log2();
    }
    // The exponent e above which a weight is 0 (the per-tap path's cutoff, e^-20).
    let e_max = -EXP_CUTOFF * std::f32::consts::LOG2_E;
    let mut j0 = job.j_lo;
    while j0 < job.j_hi {
        let pr: [f32; L] = ld(r.p, j0);
        let pg: [f32; L] = ld(r.p, QW + j0);
        let pb: [f32; L] = ld(r.p, 2 * QW + j0);
        let pv: [f32; L] = ld(r.p, V * QW + j0);
        // The colour factor from the validity, not the aux plane: swept columns in a
        // neighbouring strip have none there.
        let pc: [f32; L] = std::array::from_fn(|l| job.color_scale * pv[l]);
        let pf: [[f32; L]; NF] = std::array::from_fn(|f| ld(r.pa, (F + f) * QW + j0));
        let mut ar = [0.0f32; L];
        let mut ag = [0.0f32; L];
        let mut ab = [0.0f32; L];
        let mut aw = [0.0f32; L];
        for l in 0..L {
            let w = CENTRE * pv[l];
            ar[l] = w * pr[l];
            ag[l] = w * pg[l];
            ab[l] = w * pb[l];
            aw[l] = w;
        }
        for (k, &(dx, dy)) in PAIRS.iter().enumerate() {
            let (own, scatter) = (job.own[dy], job.scatter[dy]);
            if !own && !scatter {
                continue;
            }
            let (q, qa, acc): (&SrcBlock, &AuxBlock, &mut Acc) = match dy {
                0 => (r.p, r.pa, &mut *a0),
                1 => (r.q1, r.qa1, &mut *a1),
                _ => (r.q2, r.qa2, &mut *a2),
            };
            let qj = (j0 as isize + dx * step) as usize;
            let qr: [f32; L] = ld(q, qj);
            let qg: [f32; L] = ld(q, QW + qj);
            let qb: [f32; L] = ld(q, 2 * QW + qj);
            let qv: [f32; L] = ld(q, V * QW + qj);
            let qf: [[f32; L]; NF] = std::array::from_fn(|f| ld(qa, (F + f) * QW + qj));
            let mut wgt = [0.0f32; L];
            for l in 0..L {
                let mut e = 0.0f32;
                if CM == CM_FIXED {
                    let (dr, dg, db) = (pr[l] - qr[l], pg[l] - qg[l], pb[l] - qb[l]);
                    let d2 = mul_add::<FMA>(db, db, mul_add::<FMA>(dg, dg, dr * dr));
                    e = d2 * (pc[l] * qv[l]);
                }
                // With 4 or 6 coordinates the first three are normals, whose squared
                // distance takes the level's factor.
                let normals = if NF >= 4 { 3 } else { 0 };
                let mut en = 0.0f32;
                for (f, (pf, qf)) in pf.iter().zip(&qf).enumerate() {
                    let d = pf[l] - qf[l];
                    if f < normals {
                        en = mul_add::<FMA>(d, d, en);
                    } else {
                        e = mul_add::<FMA>(d, d, e);
                    }
                }
                if NF >= 4 {
                    e = mul_add::<FMA>(en, job.normal_factor, e);
                }
                wgt[l] = c0[k] - e;
            }
            let cut = c0[k] - e_max;
            #[cfg(target_arch = "x86_64")]
            if X512 && L == 16 {
                // SAFETY: `X512` is only set in the AVX-512 build (row_avx512).
                let w16 = unsafe { exp2_cut_x16(&wgt[..16], cut) };
                wgt[..16].copy_from_slice(&w16);
            } else {
                wgt = wgt.map(|t| exp2_cut::<FMA>(t, cut));
            }
            #[cfg(not(target_arch = "x86_64"))]
            {
                wgt = wgt.map(|t| exp2_cut::<FMA>(t, cut));
            }
            // Colour is 0 where the validity is (see `fill`), so w·colour needs no validity
            // factor: the same sums as w·valid·colour, bit for bit, one multiply less.
            if own {
                for l in 0..L {
                    let w = wgt[l];
                    ar[l] = mul_add::<FMA>(w, qr[l], ar[l]);
                    ag[l] = mul_add::<FMA>(w, qg[l], ag[l]);
                    ab[l] = mul_add::<FMA>(w, qb[l], ab[l]);
                    aw[l] = mul_add::<FMA>(w, qv[l], aw[l]);
                }
            }
            if scatter {
                let (sr, rest) = acc.split_at_mut(QW);
                let (sg, rest) = rest.split_at_mut(QW);
                let (sb, sw) = rest.split_at_mut(QW);
                let sr = &mut sr[qj..qj + L];
                let sg = &mut sg[qj..qj + L];
                let sb = &mut sb[qj..qj + L];
                let sw = &mut sw[qj..qj + L];
                for l in 0..L {
                    let w = wgt[l];
                    sr[l] = mul_add::<FMA>(w, pr[l], sr[l]);
                    sg[l] = mul_add::<FMA>(w, pg[l], sg[l]);
                    sb[l] = mul_add::<FMA>(w, pb[l], sb[l]);
                    sw[l] = mul_add::<FMA>(w, pv[l], sw[l]);
                }
            }
        }
        if job.own[0] {
            let (sr, rest) = a0.split_at_mut(QW);
            let (sg, rest) = rest.split_at_mut(QW);
            let (sb, sw) = rest.split_at_mut(QW);
            for l in 0..L {
                sr[j0 + l] += ar[l];
                sg[j0 + l] += ag[l];
                sb[j0 + l] += ab[l];
                sw[j0 + l] += aw[l];
            }
        }
        j0 += L;
    }
}
