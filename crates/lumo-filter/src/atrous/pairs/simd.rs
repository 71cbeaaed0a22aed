//! The pair path's row kernel written with explicit AVX2 and AVX-512 intrinsics (one body,
//! instantiated twice by a macro).
//!
//! Why not the portable arrays-as-registers code of the parent module: on an AVX2-only CPU
//! (AMD EPYC, Zen 3) the compiler vectorised that code only in part — the `[f32; 8]` exp
//! map stayed scalar, the 12-pair loop kept its per-pair branches, bounds checks and
//! re-broadcast constants — at ~95 instructions per pair and 8 pixels where this kernel
//! needs ~45. Measured on that machine: 512², 5 levels, 3 weights, 2 threads: 52–60 ms
//! with the portable copy, see docs/filter-benchmarks.md for this one.
//!
//! The arithmetic is the portable kernel's, operation for operation except that the colour
//! and feature distances are summed in a fixed order of fused multiply-adds, so results
//! agree with it to rounding (tests compare them).

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

#[cfg(target_arch = "x86_64")]
use super::{Accs, RowJob, Rows, CENTRE, F, G, LUM, MAX_PAIR_STEP, PAIRS, V, VAR_P};
#[cfg(target_arch = "x86_64")]
use crate::atrous::kernel::{CM_FIXED, CM_VARIANCE};
#[cfg(target_arch = "x86_64")]
use crate::atrous::layout::QW;
#[cfg(target_arch = "x86_64")]
use crate::atrous::B3;
#[cfg(target_arch = "x86_64")]
use crate::common::fastmath::{exp2_cut_avx2_xn, exp2_cut_avx512_xn, EXP_CUTOFF};

/// One row of the pair path (the sweep, then the scatter of the mirrored halves), for one
/// instruction set.
macro_rules! row_kernel {
    ($d:tt $name:ident, $feat:literal, $t:ty, $l:literal, $load:ident, $store:ident, $set1:ident,
     $zero:ident, $add:ident, $sub:ident, $mul:ident, $fma:ident, $max:ident, $exp:ident,
     $([$($g:literal)+])+) => {
        /// One row's pairs (see the parent module's `row_impl`, which this mirrors).
        ///
        /// # Safety
        /// The CPU must support the instruction set named in the `target_feature`.
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $feat)]
        #[allow(clippy::too_many_lines)]
        pub(super) unsafe fn $name<const NF: usize, const CM: u8, const VAR: bool>(
            r: &Rows,
            acc: &mut Accs,
            job: RowJob,
        ) {
            const L: usize = $l;
            let step = job.step.min(MAX_PAIR_STEP);
            // Every column read: p's at [j_lo, j_hi), q's up to 2·step either side, the
            // weights buffer's at [j_lo, j_hi); the scatter reads p and weights within
            // 2·step of [o_lo, o_hi) and writes [o_lo, o_hi) rounded up to L. Checked here
            // once instead of at every load.
            assert!(job.j_lo >= 2 * step && job.j_hi + 2 * step <= QW);
            assert!(job.j_lo.is_multiple_of(L) && job.j_hi.is_multiple_of(L));
            assert!(job.o_lo >= 2 * step && job.o_lo <= job.o_hi);
            assert!(job.o_lo + (job.o_hi - job.o_lo).next_multiple_of(L) + 2 * step <= QW);
            assert!(acc.w.len() >= PAIRS.len() * QW);
            let e_max = -EXP_CUTOFF * std::f32::consts::LOG2_E;
            let mut c0 = [0.0f32; 12];
            let mut cut = [0.0f32; 12];
            // Per pair: its q row (dy) displaced by dx·step, as an offset from row starts.
            let mut qoff = [0isize; 12];
            for (k, &(dx, dy)) in PAIRS.iter().enumerate() {
                c0[k] = (B3[(dx + 2) as usize] * B3[dy + 2]).log2();
                cut[k] = c0[k] - e_max;
                qoff[k] = dx * step as isize;
            }
            let p = r.p.as_ptr();
            let pa = r.pa.as_ptr();
            let q = [r.p.as_ptr(), r.q1.as_ptr(), r.q2.as_ptr()];
            let qa = [r.pa.as_ptr(), r.qa1.as_ptr(), r.qa2.as_ptr()];
            let w = acc.w.as_mut_ptr();
            let a0 = acc.a0.as_mut_ptr();
            let cs = $set1(job.color_scale);
            let nfac = $set1(job.normal_factor);
            let centre = $set1(CENTRE);
            let normals = if NF >= 4 { 3 } else { 0 };
            let mut j0 = job.j_lo;
            // SAFETY: (all loads and stores below) within the ranges checked above; the
            // blocks hold their planes at multiples of QW, the weights buffer 12 rows.
            unsafe {
                while j0 < job.j_hi {
                    let pr = $load(p.add(j0));
                    let pg = $load(p.add(QW + j0));
                    let pb = $load(p.add(2 * QW + j0));
                    let pv = $load(p.add(V * QW + j0));
                    // The colour coefficient: fixed σ factor × validity, or g_p.
                    let pc = if CM == CM_VARIANCE {
                        $load(pa.add(G * QW + j0))
                    } else {
                        $mul(cs, pv)
                    };
                    let pl = if CM == CM_VARIANCE {
                        $load(pa.add(LUM * QW + j0))
                    } else {
                        $zero()
                    };
                    let wc = $mul(centre, pv);
                    let mut ar = $mul(wc, pr);
                    let mut ag = $mul(wc, pg);
                    let mut ab = $mul(wc, pb);
                    let mut aw = wc;
                    // The centre's own term, w² = CENTRE² on its variance, is added by
                    // the scatter of no pair: add it here.
                    let mut av = if VAR {
                        $mul($mul(wc, wc), $load(p.add(VAR_P * QW + j0)))
                    } else {
                        $zero()
                    };
                    // A group of pairs at a time (the instantiation's list, four each),
                    // stage by stage: each stage's operations are independent, so the
                    // ~80-cycle dependency chain of one pair (loads, distances, exp
                    // polynomial) overlaps with the others' instead of stalling the
                    // out-of-order window (measured: one pair after the other ran at ~1.2
                    // instructions per cycle; groups of 2, 3 and 6 ran 3–15 % slower than 4
                    // on AVX2, Zen 3).
                    macro_rules! group {
                        ($d($d k:literal)+) => {{
                            let ks = [$d($d k),+];
                            let qp = ks.map(|k| q[PAIRS[k].1].add((j0 as isize + qoff[k]) as usize));
                            let qap =
                                ks.map(|k| qa[PAIRS[k].1].add((j0 as isize + qoff[k]) as usize));
                            // The colour, normal and position terms are summed separately
                            // and joined at the end: three short dependency chains instead of
                            // one long one (the same operations; measured on Zen 3, whose
                            // 256-entry window holds about one group, the chain's length was
                            // the group's time).
                            let mut d2c = ks.map(|_| $zero());
                            let mut cc = ks.map(|_| $zero());
                            if CM == CM_FIXED {
                                for i in 0..ks.len() {
                                    let dr = $sub(pr, $load(qp[i]));
                                    let dg = $sub(pg, $load(qp[i].add(QW)));
                                    let db = $sub(pb, $load(qp[i].add(2 * QW)));
                                    d2c[i] = $fma(db, db, $fma(dg, dg, $mul(dr, dr)));
                                    cc[i] = $mul(pc, $load(qp[i].add(V * QW)));
                                }
                            }
                            if CM == CM_VARIANCE {
                                for i in 0..ks.len() {
                                    let dl = $sub(pl, $load(qap[i].add(LUM * QW)));
                                    d2c[i] = $max(dl, $sub($zero(), dl));
                                    // g_q: q's σ factor, for the weight seen from q.
                                    cc[i] = $load(qap[i].add(G * QW));
                                }
                            }
                            let mut en = ks.map(|_| $zero());
                            let mut ex = ks.map(|_| $zero());
                            for f in 0..NF {
                                let pf = $load(pa.add((F + f) * QW + j0));
                                for i in 0..ks.len() {
                                    let d = $sub(pf, $load(qap[i].add((F + f) * QW)));
                                    if f < normals {
                                        en[i] = if f == 0 { $mul(d, d) } else { $fma(d, d, en[i]) };
                                    } else if f == normals {
                                        ex[i] = $mul(d, d);
                                    } else {
                                        ex[i] = $fma(d, d, ex[i]);
                                    }
                                }
                            }
                            let mut t = ks.map(|_| $zero());
                            let mut tq = ks.map(|_| $zero());
                            for i in 0..ks.len() {
                                let mut e = ex[i];
                                if normals > 0 {
                                    e = if NF > normals {
                                        $fma(en[i], nfac, e)
                                    } else {
                                        $mul(en[i], nfac)
                                    };
                                }
                                if CM == CM_FIXED {
                                    e = $fma(d2c[i], cc[i], e);
                                }
                                if CM == CM_VARIANCE {
                                    // SVGF's σ is the centre's: p's for p's sums, q's for
                                    // the weight the scatter gives q.
                                    tq[i] = $sub($set1(c0[ks[i]]), $fma(d2c[i], cc[i], e));
                                    e = $fma(d2c[i], pc, e);
                                }
                                t[i] = $sub($set1(c0[ks[i]]), e);
                            }
                            let cuts = ks.map(|k| $set1(cut[k]));
                            let wgt = $exp(t, cuts);
                            let wq = if CM == CM_VARIANCE { $exp(tq, cuts) } else { wgt };
                            for i in 0..ks.len() {
                                // Colour is 0 where the validity is, so w·colour needs no
                                // validity factor (as in the portable kernel).
                                ar = $fma(wgt[i], $load(qp[i]), ar);
                                ag = $fma(wgt[i], $load(qp[i].add(QW)), ag);
                                ab = $fma(wgt[i], $load(qp[i].add(2 * QW)), ab);
                                aw = $fma(wgt[i], $load(qp[i].add(V * QW)), aw);
                                if VAR {
                                    let w2 = $mul(wgt[i], wgt[i]);
                                    av = $fma(w2, $load(qp[i].add(VAR_P * QW)), av);
                                }
                                $store(w.add(ks[i] * QW + j0), wq[i]);
                            }
                        }};
                    }
                    $(group!($($g)+);)+
                    let planes = if VAR { 5 } else { 4 };
                    for (k, v) in [ar, ag, ab, aw, av].into_iter().take(planes).enumerate() {
                        let at = a0.add(k * QW + j0);
                        $store(at, if job.top { v } else { $add($load(at), v) });
                    }
                    j0 += L;
                }
                // The mirrored halves (see the parent module's `scatter`).
                for dy in 0..3 {
                    if !job.scatter[dy] {
                        continue;
                    }
                    let a = match dy {
                        0 => acc.a0.as_mut_ptr(),
                        1 => acc.a1.as_mut_ptr(),
                        _ => acc.a2.as_mut_ptr(),
                    };
                    let ks = match dy {
                        0 => 0..2,
                        1 => 2..7,
                        _ => 7..12,
                    };
                    let first = job.first_writer(dy);
                    let mut jq = job.o_lo;
                    while jq < job.o_hi {
                        let mut s = [$zero(); 5];
                        for k in ks.clone() {
                            let i = (jq as isize - qoff[k]) as usize;
                            let wk = $load(w.add(k * QW + i));
                            for (c, sc) in s.iter_mut().take(4).enumerate() {
                                *sc = $fma(wk, $load(p.add(c * QW + i)), *sc);
                            }
                            if VAR {
                                let w2 = $mul(wk, wk);
                                s[4] = $fma(w2, $load(p.add(VAR_P * QW + i)), s[4]);
                            }
                        }
                        let planes = if VAR { 5 } else { 4 };
                        for (c, sc) in s.into_iter().take(planes).enumerate() {
                            let at = a.add(c * QW + jq);
                            $store(at, if first { sc } else { $add($load(at), sc) });
                        }
                        jq += L;
                    }
                }
            }
        }
    };
}

row_kernel!(
    $ row_avx2,
    "avx2,fma",
    __m256,
    8,
    _mm256_loadu_ps,
    _mm256_storeu_ps,
    _mm256_set1_ps,
    _mm256_setzero_ps,
    _mm256_add_ps,
    _mm256_sub_ps,
    _mm256_mul_ps,
    _mm256_fmadd_ps,
    _mm256_max_ps,
    exp2_cut_avx2_xn,
    [0 1 2 3] [4 5 6 7] [8 9 10 11]
);

row_kernel!(
    $ row_avx512,
    "avx512f,avx512vl,avx2,fma",
    __m512,
    16,
    _mm512_loadu_ps,
    _mm512_storeu_ps,
    _mm512_set1_ps,
    _mm512_setzero_ps,
    _mm512_add_ps,
    _mm512_sub_ps,
    _mm512_mul_ps,
    _mm512_fmadd_ps,
    _mm512_max_ps,
    exp2_cut_avx512_xn,
    [0 1 2 3] [4 5 6 7] [8 9 10 11]
);
