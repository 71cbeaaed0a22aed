//! The À-Trous kernel's symmetric-pair path, for levels whose taps stay within
//! [`MAX_PAIR_STEP`] pixels. Without a colour weight or with the paper's fixed colour σ a
//! pair's weight is symmetric. SVGF's variance-guided colour weight is not: its σ belongs to
//! the centre pixel. For it the pair's feature distance is still computed once, and two
//! exponentials give the weight seen from p (with g_p) and from q (with g_q; the aux
//! plane holds g for every pixel, see `level_aux`): the same weights as the per-tap path.
//!
//! Why: the edge-stopping weight of a pixel pair, exp(−e(p, q)), is the same seen from p and
//! from q, and so is the B3 weight. Of the 24 non-centre taps of a 5×5 kernel, the 12 "after"
//! the centre in row-major order are mirrors of the 12 before it; computing each pair's
//! weight once and adding it to both pixels halves the exponentials and feature distances,
//! which are most of the kernel's arithmetic.
//!
//! How: bands of rows are swept top to bottom by one thread each. Row y adds its pairs'
//! contributions to its own sum (kept in registers) and stores the pairs' weights in a row
//! buffer; a second pass over the row then adds the mirrored contributions into the
//! accumulator rows of y (dx > 0), y + step and y + 2·step, held in a ring of 2·step + 1
//! rows, each output vector read and written once (see [`scatter`] for why not during the
//! sweep). Row y is complete once it has been swept, and is normalised then. A band first
//! sweeps the 2·step rows above it for their scatter alone, so bands are independent. Every
//! pixel's sum is formed in the same order whatever the band boundaries or the thread count
//! (row y − 2s, then y − s, then y itself), so results are deterministic.
//!
//! The row kernel exists three times: portable (baseline x86-64, other targets) in this file,
//! and with explicit AVX2 and AVX-512 intrinsics in pairs/simd.rs.
//!
//! With the variance carried (SVGF), each pair also adds w²·var of the other pixel to the
//! variance sums (the variance of a weighted mean is Σw²·var / (Σw)²; var is 0 where the
//! validity is).
//!
//! The fixed colour coefficient of a pair is the centre's σ factor times the neighbour's validity:
//! from a valid pixel's side it equals the per-tap path's (an invalid neighbour gets weight 0
//! anyway), and from an invalid pixel's side it is 0, as there (no colour to compare).
//! Results differ from the per-tap path by rounding only (the order of the sums differs).

use std::cell::RefCell;

use rayon::prelude::*;

use crate::atrous::kernel::{
    normalise, AuxBlock, Isa, Level, SrcBlock, CM_FIXED, CM_NONE, CM_VARIANCE, K, KA,
};
use crate::atrous::layout::{flat_rows, Aligned, CW, M, QW};
use crate::atrous::B3;
use crate::common::fastmath::{exp2_cut, mul_add, EXP_CUTOFF};

mod simd;

/// Largest tap spacing of the pair path: a strip sweeps pixels up to 2·step into its
/// neighbours (for their scatter) and reads taps 2·step beyond those, 4·step ≤ M.
pub(in crate::atrous) const MAX_PAIR_STEP: usize = M / 4;

/// Column alignment of the swept range: the widest vector (16 floats).
pub(in crate::atrous) const CHUNK: usize = 16;

/// Accumulator planes per row: r, g, b, weight, variance.
pub(in crate::atrous) const AN: usize = 5;
/// One accumulator row: r, g, b, weight and variance sums, [`QW`] columns each.
pub(in crate::atrous) type Acc = [f32; AN * QW];

/// Source planes: colour from 0, validity, variance.
const V: usize = 3;
const VAR_P: usize = 4;
/// Aux planes: the variance-guided colour factor g, the luminance, features from F.
const G: usize = 0;
const LUM: usize = 1;
const F: usize = 2;

/// (dx, dy) in steps of the 12 taps after the centre in row-major order; dy picks the row.
pub(in crate::atrous) const PAIRS: [(isize, usize); 12] = [
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

/// Whether a level (its step and feature count) can take the pair path.
pub(in crate::atrous) fn supports(step: usize, nf: usize) -> bool {
    step <= MAX_PAIR_STEP && matches!(nf, 1 | 3 | 4 | 6)
}

thread_local! {
    /// Each worker's accumulator ring, kept between bands and levels (allocating and
    /// page-faulting up to 33 rows per band would cost more than the rows' arithmetic).
    static RING: RefCell<Scratch> = const {
        RefCell::new(Scratch { ring: Vec::new(), weights: Vec::new() })
    };
}

/// A worker's buffers: the accumulator ring and one row of pair weights.
struct Scratch {
    ring: Vec<Aligned<Acc>>,
    /// The 12 pair weights of the row being swept, [`QW`] columns each: the scatter half of
    /// the pairs is added from here in a second pass over the row (see [`scatter`]).
    weights: Vec<Aligned<[f32; QW]>>,
}

/// One level over the whole image into `dst` (K planes per block; margins left 0).
pub(in crate::atrous) fn level(l: &Level, dst: &mut [f32]) {
    let lay = l.lay;
    let block = K * QW;
    // Bands tall enough that the 2·step rows swept twice stay a small part of the work
    // (≤ 8 %), and no more of them than the threads need: with 128-row bands a 512² image's
    // five levels swept ~10 % of their rows twice, with one band per thread ~5 %.
    let band_rows = (16 * l.step)
        .max(128)
        .max(lay.h.div_ceil(rayon::current_num_threads().max(1)));
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

/// Which of a row's pair groups (dy = 0, 1, 2 steps) scatter into the rows below
/// (`scatter[dy]`), and the row's constants.
#[derive(Clone, Copy)]
pub(in crate::atrous) struct RowJob {
    pub scatter: [bool; 3],
    pub j_lo: usize,
    pub j_hi: usize,
    /// The columns whose sums are kept (the mirrored halves are added there): the strip's
    /// own, or wider for the level pipeline's halo.
    pub o_lo: usize,
    pub o_hi: usize,
    pub step: usize,
    pub color_scale: f32,
    pub normal_factor: f32,
    /// The row is less than one step below the image's top, so no row above scatters into
    /// it or into the row one step below: its own sweep and its dy = 1 scatter are the first
    /// writers of those accumulator rows (see [`RowJob::first_writer`]).
    pub top: bool,
}

impl RowJob {
    /// Whether the scatter into the row `dy` steps below is the first write of that
    /// accumulator row since it was last finished, so it stores instead of adding: the
    /// accumulator rings are never cleared. A kept row Y is first written by row Y − 2·step's
    /// scatter (every sweep starts 2·step above its first kept row), or, where Y − 2·step lies
    /// above the image, by row Y − step's, or by its own sweep (`top`). 0 + x = x, so the sums
    /// are the same as when adding into cleared rows (up to the sign of an all-zero sum).
    /// Columns that no scatter writes (beyond the kept ones) keep stale sums: nothing reads them.
    pub fn first_writer(&self, dy: usize) -> bool {
        dy == 2 || (dy == 1 && self.top)
    }
}

/// Rows [a, b) of strip `c` into `out` (their blocks).
fn band(l: &Level, c: usize, a: usize, b: usize, out: &mut [f32], scratch: &mut Scratch) {
    let Scratch { ring, weights } = scratch;
    // Zeroed once; only ever overwritten with weights in [0, 1], so a stale one times the
    // zero colour of a column outside the swept range adds exactly 0 (see [`scatter`]).
    if weights.len() < PAIRS.len() {
        weights.resize(PAIRS.len(), Aligned([0.0; QW]));
    }
    let lay = l.lay;
    let s = l.step;
    let rn = 2 * s + 1;
    // Never cleared: each kept row's first writer stores (see [`RowJob::first_writer`]).
    if ring.len() < rn {
        ring.resize(rn, Aligned([0.0; AN * QW]));
    }
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
            scatter: [false; 3],
            j_lo,
            j_hi,
            o_lo: M,
            o_hi: M + len,
            step: s,
            color_scale: l.color_scale,
            normal_factor: l.normal_factor,
            top: y < s,
        };
        for dy in 0..3 {
            let yq = y + dy * s;
            job.scatter[dy] = in_band(yq);
        }
        // Rows below the image: a zero block (validity 0, so its pairs add nothing).
        let q_src = |dy: usize| {
            let yq = y + dy * s;
            if yq < lay.h {
                src(yq)
            } else {
                &ZERO_SRC.0
            }
        };
        let q_aux = |dy: usize| {
            let yq = y + dy * s;
            if yq < lay.h {
                aux(yq)
            } else {
                &ZERO_AUX.0
            }
        };
        let [a0, a1, a2] = ring
            .get_disjoint_mut([y % rn, (y + s) % rn, (y + 2 * s) % rn])
            .expect("ring rows are distinct");
        let rows = Rows {
            p: src(y),
            pa: aux(y),
            q1: q_src(1),
            qa1: q_aux(1),
            q2: q_src(2),
            qa2: q_aux(2),
        };
        let mut acc = Accs {
            a0: &mut a0.0,
            a1: &mut a1.0,
            a2: &mut a2.0,
            w: flat_rows(weights),
        };
        row(l, &rows, &mut acc, job);
        if own {
            let d = &mut out[(y - a) * K * QW..][..K * QW];
            // Margins (refilled from the neighbours, or 0 beyond the image) and the colour
            // and validity planes' columns beyond the strip: 0; the variance plane's too
            // where it is carried (otherwise nothing reads it).
            for k in 0..if l.var { K } else { 4 } {
                d[k * QW..k * QW + M].fill(0.0);
                d[k * QW + M + len..k * QW + lay.span()].fill(0.0);
            }
            if l.var {
                normalise::<true>(&acc.a0[..], QW, M, d, M, len);
            } else {
                normalise::<false>(&acc.a0[..], QW, M, d, M, len);
            }
        }
        // An own row is finished; the sums of a row swept for its scatter alone are not
        // wanted. Either way the ring row is free again (its next row's first writer stores).
    }
}

/// The block read for rows below the image.
pub(in crate::atrous) static ZERO_SRC: Aligned<SrcBlock> = Aligned([0.0; K * QW]);
/// The aux block read for rows below the image.
pub(in crate::atrous) static ZERO_AUX: Aligned<AuxBlock> = Aligned([0.0; KA * QW]);

/// The source and aux blocks of a row and of the rows one and two steps below it.
pub(in crate::atrous) struct Rows<'a> {
    pub p: &'a SrcBlock,
    pub pa: &'a AuxBlock,
    pub q1: &'a SrcBlock,
    pub qa1: &'a AuxBlock,
    pub q2: &'a SrcBlock,
    pub qa2: &'a AuxBlock,
}

/// The accumulator rows of a row and of the rows one and two steps below it, and the
/// row's pair weights.
pub(in crate::atrous) struct Accs<'a> {
    pub a0: &'a mut Acc,
    pub a1: &'a mut Acc,
    pub a2: &'a mut Acc,
    pub w: &'a mut [f32],
}

/// Dispatch of one row on the level's feature count, colour mode, variance carrying and
/// instruction set.
pub(in crate::atrous) fn row(l: &Level, r: &Rows, acc: &mut Accs, job: RowJob) {
    macro_rules! go {
        ($nf:literal, $cm:expr, $var:literal) => {
            match l.isa {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: `Isa::Avx512` is only chosen after run-time detection of AVX-512F/VL
                // and FMA.
                Isa::Avx512 => unsafe { simd::row_avx512::<$nf, $cm, $var>(r, acc, job) },
                #[cfg(target_arch = "x86_64")]
                // SAFETY: `Isa::Avx2` is only chosen after run-time detection of AVX2 and FMA.
                Isa::Avx2 => unsafe { simd::row_avx2::<$nf, $cm, $var>(r, acc, job) },
                _ => row_base::<$nf, $cm, $var>(r, acc, job),
            }
        };
    }
    macro_rules! by_colour {
        ($nf:literal) => {
            match (l.cm, l.var) {
                (CM_NONE, false) => go!($nf, CM_NONE, false),
                (CM_NONE, true) => go!($nf, CM_NONE, true),
                (CM_VARIANCE, _) => go!($nf, CM_VARIANCE, true),
                (_, false) => go!($nf, CM_FIXED, false),
                (_, true) => go!($nf, CM_FIXED, true),
            }
        };
    }
    match l.nf {
        1 => by_colour!(1),
        3 => by_colour!(3),
        4 => by_colour!(4),
        _ => by_colour!(6),
    }
}

#[inline(never)]
fn row_base<const NF: usize, const CM: u8, const VAR: bool>(r: &Rows, acc: &mut Accs, job: RowJob) {
    row_impl::<NF, CM, VAR, 4, false>(r, acc, job)
}

/// `L` floats of `s` from `at`.
#[inline(always)]
fn ld<const L: usize>(s: &[f32], at: usize) -> [f32; L] {
    s[at..at + L].try_into().expect("L floats")
}

/// `L` floats from `p + at`, unchecked.
///
/// # Safety
/// `p + at .. p + at + L` must lie inside one allocation.
#[inline(always)]
unsafe fn ldp<const L: usize>(p: *const f32, at: usize) -> [f32; L] {
    // SAFETY: guaranteed by the caller.
    unsafe { p.add(at).cast::<[f32; L]>().read_unaligned() }
}

/// What every pair of a row's `L` columns starting at `j0` shares: the centre pixel p's
/// colour, validity and features, its own sums, and where the neighbour rows lie.
struct Centre<const NF: usize, const L: usize> {
    pr: [f32; L],
    pg: [f32; L],
    pb: [f32; L],
    pv: [f32; L],
    /// The colour coefficient of p: the fixed σ factor × validity, or g_p (variance-guided:
    /// p's own σ factor × validity).
    pc: [f32; L],
    /// The luminance of p (variance-guided colour weight).
    pl: [f32; L],
    pf: [[f32; L]; NF],
    ar: [f32; L],
    ag: [f32; L],
    ab: [f32; L],
    aw: [f32; L],
    av: [f32; L],
}

/// The source and aux rows at dy = 0, 1, 2 steps, as raw pointers (bounds checked once
/// per row in [`row_impl`]), the weights buffer, and the per-row constants.
struct RowPtrs {
    q: [*const f32; 3],
    qa: [*const f32; 3],
    w: *mut f32,
    step: usize,
    normal_factor: f32,
    /// log2 of each pair's B3 weight, and the exponent below which its weight is 0.
    c0: [f32; 12],
    cut: [f32; 12],
}

/// Pair `KP` of [`PAIRS`] for `L` columns from `j0`: its weight is added to p's sums with
/// q's colour, and stored for [`scatter`].
///
/// # Safety
/// The row pointers must be valid for every column read (checked in [`row_impl`]), and the
/// CPU must support what `FMA`/`X512`/`L` select (see [`row_impl`]).
#[inline(always)]
unsafe fn pair<
    const KP: usize,
    const NF: usize,
    const CM: u8,
    const VAR: bool,
    const L: usize,
    const FMA: bool,
>(
    c: &mut Centre<NF, L>,
    rp: &RowPtrs,
    j0: usize,
) {
    let (dx, dy) = PAIRS[KP];
    let qj = (j0 as isize + dx * rp.step as isize) as usize;
    let (q, qa) = (rp.q[dy], rp.qa[dy]);
    // SAFETY: in bounds by the caller's contract.
    let (qr, qg, qb, qv): ([f32; L], [f32; L], [f32; L], [f32; L]) = unsafe {
        (
            ldp(q, qj),
            ldp(q, QW + qj),
            ldp(q, 2 * QW + qj),
            ldp(q, V * QW + qj),
        )
    };
    // SAFETY: in bounds by the caller's contract.
    let qf: [[f32; L]; NF] = std::array::from_fn(|f| unsafe { ldp(qa, (F + f) * QW + qj) });
    // SAFETY: in bounds by the caller's contract.
    let (ql, qgf, qvar): ([f32; L], [f32; L], [f32; L]) = unsafe {
        (
            if CM == CM_VARIANCE {
                ldp(qa, LUM * QW + qj)
            } else {
                [0.0; L]
            },
            if CM == CM_VARIANCE {
                ldp(qa, G * QW + qj)
            } else {
                [0.0; L]
            },
            if VAR {
                ldp(q, VAR_P * QW + qj)
            } else {
                [0.0; L]
            },
        )
    };
    let mut wgt = [0.0f32; L];
    // The exponent seen from q (variance-guided colour weight only).
    let mut wq = [0.0f32; L];
    for l in 0..L {
        let mut e = 0.0f32;
        if CM == CM_FIXED {
            let (dr, dg, db) = (c.pr[l] - qr[l], c.pg[l] - qg[l], c.pb[l] - qb[l]);
            let d2 = mul_add::<FMA>(db, db, mul_add::<FMA>(dg, dg, dr * dr));
            e = d2 * (c.pc[l] * qv[l]);
        }
        // With 4 or 6 coordinates the first three are normals, whose squared distance
        // takes the level's factor.
        let normals = if NF >= 4 { 3 } else { 0 };
        let mut en = 0.0f32;
        for f in 0..NF {
            let d = c.pf[f][l] - qf[f][l];
            if f < normals {
                en = mul_add::<FMA>(d, d, en);
            } else {
                e = mul_add::<FMA>(d, d, e);
            }
        }
        if NF >= 4 {
            e = mul_add::<FMA>(en, rp.normal_factor, e);
        }
        if CM == CM_VARIANCE {
            let dl = (c.pl[l] - ql[l]).abs();
            wq[l] = rp.c0[KP] - mul_add::<FMA>(dl, qgf[l], e);
            e = mul_add::<FMA>(dl, c.pc[l], e);
        }
        wgt[l] = rp.c0[KP] - e;
    }
    let cut = rp.cut[KP];
    wgt = wgt.map(|t| exp2_cut::<FMA>(t, cut));
    // The weight the scatter gives q (p's colour with q's σ): the pair's own weight
    // where it is symmetric.
    let scatter_w = if CM == CM_VARIANCE {
        wq.map(|t| exp2_cut::<FMA>(t, cut))
    } else {
        wgt
    };
    // Colour is 0 where the validity is (see `fill`), so w·colour needs no validity
    // factor: the same sums as w·valid·colour, bit for bit, one multiply less.
    for l in 0..L {
        let w = wgt[l];
        c.ar[l] = mul_add::<FMA>(w, qr[l], c.ar[l]);
        c.ag[l] = mul_add::<FMA>(w, qg[l], c.ag[l]);
        c.ab[l] = mul_add::<FMA>(w, qb[l], c.ab[l]);
        c.aw[l] = mul_add::<FMA>(w, qv[l], c.aw[l]);
        if VAR {
            c.av[l] = mul_add::<FMA>(w * w, qvar[l], c.av[l]);
        }
    }
    // SAFETY: the weights buffer holds 12 rows of QW floats and j0 + L <= QW.
    unsafe {
        rp.w.add(KP * QW + j0)
            .cast::<[f32; L]>()
            .write_unaligned(scatter_w)
    };
}

/// One row's pairs, `L` columns at a time (the arrays are the vector registers): every
/// pair's weight is added to the row's own sums and stored, then [`scatter`] adds the
/// mirrored halves to the rows below.
///
/// Branch-free over the pairs: own sums are formed for every swept row (`band` discards
/// those of rows it does not own) and rows below the image read a zero block (validity 0,
/// so they add nothing).
#[inline(always)]
fn row_impl<const NF: usize, const CM: u8, const VAR: bool, const L: usize, const FMA: bool>(
    r: &Rows,
    acc: &mut Accs,
    job: RowJob,
) {
    let step = job.step.min(MAX_PAIR_STEP);
    // The exponent e above which a weight is 0 (the per-tap path's cutoff, e^-20).
    let e_max = -EXP_CUTOFF * std::f32::consts::LOG2_E;
    let mut rp = RowPtrs {
        q: [r.p.as_ptr(), r.q1.as_ptr(), r.q2.as_ptr()],
        qa: [r.pa.as_ptr(), r.qa1.as_ptr(), r.qa2.as_ptr()],
        w: acc.w.as_mut_ptr(),
        step,
        normal_factor: job.normal_factor,
        c0: [0.0; 12],
        cut: [0.0; 12],
    };
    for (k, &(dx, dy)) in PAIRS.iter().enumerate() {
        rp.c0[k] = (B3[(dx + 2) as usize] * B3[dy + 2]).log2();
        rp.cut[k] = rp.c0[k] - e_max;
    }
    // Every column read: p's at [j_lo, j_hi), q's up to 2·step either side; the weights
    // buffer's at [j_lo, j_hi). One check here instead of one per load.
    assert!(job.j_lo >= 2 * step && job.j_hi + 2 * step <= QW && job.j_lo.is_multiple_of(L));
    assert!(acc.w.len() >= PAIRS.len() * QW && job.j_hi.is_multiple_of(L));
    let mut j0 = job.j_lo;
    while j0 < job.j_hi {
        let p = r.p.as_ptr();
        let pa = r.pa.as_ptr();
        // SAFETY: j0 + L <= j_hi <= QW (checked above); the planes are inside the blocks.
        let mut c = unsafe {
            let pv: [f32; L] = ldp(p, V * QW + j0);
            Centre::<NF, L> {
                pr: ldp(p, j0),
                pg: ldp(p, QW + j0),
                pb: ldp(p, 2 * QW + j0),
                pv,
                // The fixed colour factor from the validity, not the aux plane: swept
                // columns in a neighbouring strip have none there (g has, in the margins).
                pc: if CM == CM_VARIANCE {
                    ldp(pa, G * QW + j0)
                } else {
                    pv.map(|v| job.color_scale * v)
                },
                pl: if CM == CM_VARIANCE {
                    ldp(pa, LUM * QW + j0)
                } else {
                    [0.0; L]
                },
                pf: std::array::from_fn(|f| ldp(pa, (F + f) * QW + j0)),
                ar: [0.0; L],
                ag: [0.0; L],
                ab: [0.0; L],
                aw: [0.0; L],
                av: [0.0; L],
            }
        };
        let pvar: [f32; L] = if VAR {
            // SAFETY: as above (the variance plane is inside the block).
            unsafe { ldp(p, VAR_P * QW + j0) }
        } else {
            [0.0; L]
        };
        for l in 0..L {
            let w = CENTRE * c.pv[l];
            c.ar[l] = w * c.pr[l];
            c.ag[l] = w * c.pg[l];
            c.ab[l] = w * c.pb[l];
            c.aw[l] = w;
            // The centre's own w² term (no pair's scatter adds it).
            c.av[l] = w * w * pvar[l];
        }
        macro_rules! pairs {
            ($($k:literal)*) => {
                // SAFETY: q columns j0 + dx·step are within [j_lo − 2·step, j_hi + 2·step)
                // ⊂ [0, QW) (checked above); the CPU features match the caller's copy.
                $(unsafe { pair::<$k, NF, CM, VAR, L, FMA>(&mut c, &rp, j0) };)*
            };
        }
        pairs!(0 1 2 3 4 5 6 7 8 9 10 11);
        let (sr, rest) = acc.a0.split_at_mut(QW);
        let (sg, rest) = rest.split_at_mut(QW);
        let (sb, rest) = rest.split_at_mut(QW);
        let (sw, sv) = rest.split_at_mut(QW);
        for l in 0..L {
            if job.top {
                (sr[j0 + l], sg[j0 + l]) = (c.ar[l], c.ag[l]);
                (sb[j0 + l], sw[j0 + l]) = (c.ab[l], c.aw[l]);
                if VAR {
                    sv[j0 + l] = c.av[l];
                }
            } else {
                sr[j0 + l] += c.ar[l];
                sg[j0 + l] += c.ag[l];
                sb[j0 + l] += c.ab[l];
                sw[j0 + l] += c.aw[l];
                if VAR {
                    sv[j0 + l] += c.av[l];
                }
            }
        }
        j0 += L;
    }
    for dy in 0..3 {
        if job.scatter[dy] {
            let a = match dy {
                0 => &mut *acc.a0,
                1 => &mut *acc.a1,
                _ => &mut *acc.a2,
            };
            let first = job.first_writer(dy);
            scatter::<VAR, L, FMA>(r.p, acc.w, a, dy, step, job.o_lo..job.o_hi, first);
        }
    }
}

/// The mirrored half of row p's pairs with dy = `dy`: each pixel q of the row `dy` steps
/// below gets w(p, q)·p from the pixels p = q − (dx, dy)·step of the row just swept.
///
/// Why a second pass: adding into the lower rows during the sweep made every vector a
/// read-modify-write at an offset of dx·step, overlapping the one before it; on CPUs whose
/// store-to-load forwarding cannot merge two stores (AMD Zen 3 measured) each such load
/// stalls. Here each vector of the lower row is read and written once, aligned, and the
/// pairs' weights are read back from the row buffer the sweep stored them in.
///
/// Only the kept columns `out` are summed: their sources lie within 2·step of them, inside
/// the swept range or in margins whose colour and validity are 0 (so a stale weight there
/// adds exactly 0); the level pipeline's rounded-out halo columns may get such stale sums, but
/// no kept pixel reads them.
#[inline(always)]
fn scatter<const VAR: bool, const L: usize, const FMA: bool>(
    p: &SrcBlock,
    w: &[f32],
    a: &mut Acc,
    dy: usize,
    step: usize,
    out: std::ops::Range<usize>,
    first: bool,
) {
    let ks = match dy {
        0 => 0..2,
        1 => 2..7,
        _ => 7..12,
    };
    let mut jq = out.start;
    while jq < out.end {
        let mut sr = [0.0f32; L];
        let mut sg = [0.0f32; L];
        let mut sb = [0.0f32; L];
        let mut sw = [0.0f32; L];
        let mut sv = [0.0f32; L];
        for k in ks.clone() {
            let i = (jq as isize - PAIRS[k].0 * step as isize) as usize;
            let wk: [f32; L] = ld(w, k * QW + i);
            let pr: [f32; L] = ld(p, i);
            let pg: [f32; L] = ld(p, QW + i);
            let pb: [f32; L] = ld(p, 2 * QW + i);
            let pv: [f32; L] = ld(p, V * QW + i);
            let pvar: [f32; L] = if VAR { ld(p, VAR_P * QW + i) } else { [0.0; L] };
            for l in 0..L {
                sr[l] = mul_add::<FMA>(wk[l], pr[l], sr[l]);
                sg[l] = mul_add::<FMA>(wk[l], pg[l], sg[l]);
                sb[l] = mul_add::<FMA>(wk[l], pb[l], sb[l]);
                sw[l] = mul_add::<FMA>(wk[l], pv[l], sw[l]);
                if VAR {
                    sv[l] = mul_add::<FMA>(wk[l] * wk[l], pvar[l], sv[l]);
                }
            }
        }
        let (ar, rest) = a.split_at_mut(QW);
        let (ag, rest) = rest.split_at_mut(QW);
        let (ab, rest) = rest.split_at_mut(QW);
        let (aw, av) = rest.split_at_mut(QW);
        for l in 0..L {
            if first {
                (ar[jq + l], ag[jq + l], ab[jq + l], aw[jq + l]) = (sr[l], sg[l], sb[l], sw[l]);
                if VAR {
                    av[jq + l] = sv[l];
                }
            } else {
                ar[jq + l] += sr[l];
                ag[jq + l] += sg[l];
                ab[jq + l] += sb[l];
                aw[jq + l] += sw[l];
                if VAR {
                    av[jq + l] += sv[l];
                }
            }
        }
        jq += L;
    }
}
