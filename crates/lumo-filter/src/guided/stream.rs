//! The guided filter's window sums, streamed row by row: per band of output rows, one pass
//! down the image keeps the vertical running sums of the product channels (I, I·Iᵀ, p, I·p)
//! and of the solved coefficients, so no full-image intermediate is ever stored. Cost per
//! pixel does not depend on the radius.
//!
//! Precision: running sums are f64. Every value added to a sum is an f32 that is computed
//! again, identically, when it is subtracted (products) or kept until then (coefficients), so
//! a firefly leaves no residue in the sums once it has left the window.
//!
//! Band heights depend only on the image height and radius (not on the thread count), so
//! results are identical for any number of threads.
//!
//! With `SW` the window's self-weight terms ([`super::self_weight`]) travel with its
//! coefficients: the same factorisation, the same window sums, no second pass over the image.

use rayon::prelude::*;

use super::cholesky::{factor_lanes, solve_factored, L};
use super::self_weight::{terms, window_terms};

/// Largest number of product channels (D = 8: 8 + 36 + 3 + 24), padded to whole chunks.
const MAX_K1: usize = 72;
/// Largest number of coefficients per pixel (D = 8 with the self-weight terms:
/// 3·8 + 3 + 36 + 8 + 1), padded to whole chunks.
const MAX_K2: usize = 72;

/// Channels per chunk: the horizontal running sums keep each pixel's channels in chunks of
/// four f64, which the compiler turns into vector operations (one ymm register per chunk
/// under AVX2). Each channel is still summed in the same order, so padding changes no result.
const CH: usize = 4;
/// Four running sums (one chunk of channels).
type Chunk = [f64; CH];

/// `acc[j] += src[j]` for the first `n` chunks of `src` (a pixel's channels).
#[inline(always)]
fn add_chunks(acc: &mut [Chunk], src: &[f64], n: usize) {
    for (a, c) in acc[..n].iter_mut().zip(src.chunks_exact(CH)) {
        for i in 0..CH {
            a[i] += c[i];
        }
    }
}

/// `acc[j] -= src[j]` for the first `n` chunks of `src`.
#[inline(always)]
fn sub_chunks(acc: &mut [Chunk], src: &[f64], n: usize) {
    for (a, c) in acc[..n].iter_mut().zip(src.chunks_exact(CH)) {
        for i in 0..CH {
            a[i] -= c[i];
        }
    }
}

/// Window sizes along an axis of length `n`: the window [i−r, i+r] clipped to the axis.
fn counts(n: usize, r: usize) -> Vec<f64> {
    (0..n)
        .map(|i| ((i + r).min(n - 1) + 1 - i.saturating_sub(r)) as f64)
        .collect()
}

/// Inputs of one guided-filter solve: `d`-channel guide and 3-channel input, both pixel-major.
pub(super) struct Problem<'a> {
    pub guide: &'a [f32],
    pub p: &'a [f32],
    pub eps: &'a [f32],
    pub w: usize,
    pub h: usize,
    pub r: usize,
}

/// An output plane of [`stream`]: its values and how many of them make one image row (0 for
/// none: an empty plane).
pub(super) type Plane<'a> = (&'a mut [f32], usize);

/// Computes, for every row y, the window-averaged coefficients [a_0 (D), a_1 (D), a_2 (D),
/// b (3)] of each pixel — followed by the averaged self-weight terms
/// ([`super::self_weight::terms`]) when `SW` — and hands them to
/// `emit(y, coefficients, out_row, side_row)`, where `out_row` and `side_row` are row y of
/// the planes `out` and `side` (two planes, so that the self-weighted filter writes its image
/// and its weights where they stay, without an interleaved buffer to copy them out of).
pub(super) fn stream<const D: usize, const SW: bool, F>(
    pb: &Problem,
    out: Plane,
    side: Plane,
    emit: F,
) where
    F: Fn(usize, &[f32], &mut [f32], &mut [f32]) + Sync,
{
    stream_with::<D, SW, F>(pb, out, side, emit, has_avx2())
}

/// [`stream`], with the AVX2 copy of the band code on or off.
fn stream_with<const D: usize, const SW: bool, F>(
    pb: &Problem,
    (out, row_len): Plane,
    (side, side_len): Plane,
    emit: F,
    avx2: bool,
) where
    F: Fn(usize, &[f32], &mut [f32], &mut [f32]) + Sync,
{
    let (w, h, r) = (pb.w, pb.h, pb.r);
    // Each band recomputes 2r rows of coefficients above and below it: tall bands keep that
    // small; four of them still keep two threads busy. (Never from the thread count.)
    let band = (4 * r).max(h.div_ceil(4)).max(64);
    let cx = counts(w, r);
    let cy = counts(h, r);
    let sides: Vec<&mut [f32]> = if side_len == 0 {
        (0..h.div_ceil(band)).map(|_| Default::default()).collect()
    } else {
        side.chunks_mut(band * side_len).collect()
    };
    out.par_chunks_mut(band * row_len)
        .zip(sides)
        .enumerate()
        .for_each(|(bi, (rows, side_rows))| {
            let y0 = bi * band;
            let y1 = (y0 + band).min(h);
            let mut b = Band::<D, SW>::new(pb, &cx, &cy);
            let k2 = Band::<D, SW>::K2;
            let mut mean = vec![0.0f32; w * k2];
            for y in y0..y1 {
                b.next_row(y, &mut mean, avx2);
                let dy = y - y0;
                emit(
                    y,
                    &mean,
                    &mut rows[dy * row_len..(dy + 1) * row_len],
                    &mut side_rows[dy * side_len..(dy + 1) * side_len],
                );
            }
        });
}

/// Rows of raw coefficients a band keeps: a window's 2r + 1, or the image's height where that
/// is less (a wide strip of an image would otherwise hold 2r + 1 rows of its whole width: 246 MB
/// for 65,536×1). The rows kept are consecutive, so `y % ring_rows` never puts two in one slot.
fn ring_rows(pb: &Problem) -> usize {
    (2 * pb.r + 1).min(pb.h)
}

/// Running state of one band.
struct Band<'a, const D: usize, const SW: bool> {
    pb: &'a Problem<'a>,
    cx: &'a [f64],
    cy: &'a [f64],
    /// Vertical sums of the product channels over rows `v_lo..v_hi` (pixel-major, K1P each).
    v: Vec<f64>,
    v_lo: usize,
    v_hi: usize,
    /// Raw coefficient rows computed so far, by row (ring of [`Self::ring_rows`]), and their
    /// next row.
    ring: Vec<f32>,
    next_ab: usize,
    /// Vertical sums of raw coefficients over rows `a_lo..a_hi`.
    va: Vec<f64>,
    a_lo: usize,
    a_hi: usize,
    started: bool,
    /// Scratch: one product row.
    prod: Vec<f32>,
}

/// Whether the AVX2 copy of the band code can run here (and `LUMO_SIMD` allows it).
fn has_avx2() -> bool {
    lumo_simd::Isa::detect() >= lumo_simd::Isa::Avx2
}

impl<'a, const D: usize, const SW: bool> Band<'a, D, SW> {
    /// [`Self::window_coefficients`], in the AVX2 copy when `avx2` (twice the vector width;
    /// no fused multiply-adds, so the results are bit-identical to the baseline copy).
    fn next_row(&mut self, y: usize, mean: &mut [f32], avx2: bool) {
        #[cfg(target_arch = "x86_64")]
        if avx2 {
            // SAFETY: `avx2` comes from run-time detection.
            unsafe { self.window_avx2(y, mean) };
            return;
        }
        let _ = avx2;
        self.window_base(y, mean)
    }

    #[inline(never)]
    fn window_base(&mut self, y: usize, mean: &mut [f32]) {
        self.window_coefficients(y, mean)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    unsafe fn window_avx2(&mut self, y: usize, mean: &mut [f32]) {
        self.window_coefficients(y, mean)
    }

    const K1: usize = D + D * (D + 1) / 2 + 3 + 3 * D;
    const K2: usize = 3 * D + 3 + if SW { terms(D) } else { 0 };
    /// K1 and K2 padded to whole chunks (the padding channels stay 0), and their chunk counts.
    const K1P: usize = Self::K1.next_multiple_of(CH);
    const K2P: usize = Self::K2.next_multiple_of(CH);
    const N1: usize = Self::K1P / CH;
    const N2: usize = Self::K2P / CH;

    fn new(pb: &'a Problem<'a>, cx: &'a [f64], cy: &'a [f64]) -> Self {
        let w = pb.w;
        Band {
            pb,
            cx,
            cy,
            v: vec![0.0; w * Self::K1P],
            v_lo: 0,
            v_hi: 0,
            ring: vec![0.0; ring_rows(pb) * w * Self::K2P],
            next_ab: usize::MAX,
            va: vec![0.0; w * Self::K2P],
            a_lo: 0,
            a_hi: 0,
            started: false,
            prod: vec![0.0; w * Self::K1P],
        }
    }

    /// Product channels of row `y`, pixel-major: I, I_a·I_b (a ≤ b), p, I_a·p_c.
    #[inline(always)]
    fn products(&mut self, y: usize) {
        let (w, k1) = (self.pb.w, Self::K1P);
        let g = &self.pb.guide[y * w * D..(y + 1) * w * D];
        let p = &self.pb.p[y * w * 3..(y + 1) * w * 3];
        for x in 0..w {
            let gi: &[f32; D] = g[x * D..(x + 1) * D].try_into().expect("D values");
            let pc = &p[x * 3..x * 3 + 3];
            let o = &mut self.prod[x * k1..(x + 1) * k1];
            o[..D].copy_from_slice(gi);
            let mut t = D;
            for a in 0..D {
                for b in a..D {
                    o[t] = gi[a] * gi[b];
                    t += 1;
                }
            }
            o[t..t + 3].copy_from_slice(pc);
            t += 3;
            for c in 0..3 {
                for a in 0..D {
                    o[t + c * D + a] = gi[a] * pc[c];
                }
            }
        }
    }

    /// Adds (`sign` = 1) or removes (−1) the products of row `y` to / from the sums.
    #[inline(always)]
    fn slide_v(&mut self, y: usize, sign: f64) {
        self.products(y);
        for (s, v) in self.v.iter_mut().zip(&self.prod) {
            *s += sign * *v as f64;
        }
    }

    /// Raw (not yet averaged) coefficients of row `y` into the ring; rows must come in order.
    #[inline(always)]
    fn raw_coefficients(&mut self, y: usize) {
        let (w, h, r) = (self.pb.w, self.pb.h, self.pb.r);
        let (lo, hi) = (y.saturating_sub(r), (y + r).min(h - 1) + 1);
        if self.next_ab != y {
            // First row of the band: sum the window from scratch.
            self.v.fill(0.0);
            for yy in lo..hi {
                self.slide_v(yy, 1.0);
            }
        } else {
            while self.v_hi < hi {
                self.slide_v(self.v_hi, 1.0);
                self.v_hi += 1;
            }
            while self.v_lo < lo {
                self.slide_v(self.v_lo, -1.0);
                self.v_lo += 1;
            }
        }
        (self.v_lo, self.v_hi) = (lo, hi);
        self.next_ab = y + 1;
        let (k1, k2, n1) = (Self::K1P, Self::K2P, Self::N1);
        let slot = (y % ring_rows(self.pb)) * w * k2;
        let out = &mut self.ring[slot..slot + w * k2];
        let inv_y = 1.0 / self.cy[y];
        let mut acc = [[0.0f64; CH]; MAX_K1 / CH];
        for x in 0..=r.min(w - 1) {
            add_chunks(&mut acc, &self.v[x * k1..(x + 1) * k1], n1);
        }
        // Pixels go in blocks of L lanes: the means are formed pixel by pixel (the running sum
        // is sequential), the solves lane-wise, which vectorises.
        let mut sys = Lanes::<D>::default();
        for x0 in (0..w).step_by(L) {
            let n = (w - x0).min(L);
            for l in 0..n {
                let x = x0 + l;
                let inv = inv_y / self.cx[x];
                let mut m = [[0.0f64; CH]; MAX_K1 / CH];
                for (mj, aj) in m[..n1].iter_mut().zip(&acc) {
                    for i in 0..CH {
                        mj[i] = aj[i] * inv;
                    }
                }
                sys.set(l, m.as_flattened(), self.pb.eps);
                if x + r + 1 < w {
                    add_chunks(&mut acc, &self.v[(x + r + 1) * k1..(x + r + 2) * k1], n1);
                }
                if x >= r {
                    sub_chunks(&mut acc, &self.v[(x - r) * k1..(x - r + 1) * k1], n1);
                }
            }
            let (lo, inv_diag) = factor_lanes::<D>(&sys.sigma);
            let a = solve_factored::<D>(&lo, &inv_diag, &sys.cov);
            if SW {
                let k0 = 3 * D + 3;
                window_terms::<D>(&lo, &inv_diag, &sys.mi, |l, t| {
                    if l < n {
                        let inv_size = (inv_y / self.cx[x0 + l]) as f32;
                        let o = &mut out[(x0 + l) * k2 + k0..(x0 + l) * k2 + k0 + terms(D)];
                        for (o, v) in o.iter_mut().zip(t) {
                            *o = v * inv_size;
                        }
                    }
                });
            }
            for l in 0..n {
                let o = &mut out[(x0 + l) * k2..(x0 + l + 1) * k2];
                for c in 0..3 {
                    let mut b = sys.mp[c][l];
                    for i in 0..D {
                        o[c * D + i] = a[c][i][l];
                        b -= a[c][i][l] * sys.mi[i][l];
                    }
                    o[3 * D + c] = b;
                }
            }
        }
    }

    /// Adds (`sign` = 1) or removes (−1) raw coefficient row `y` (in the ring) to / from `va`.
    #[inline(always)]
    fn slide_a(&mut self, y: usize, sign: f64) {
        let (w, k2) = (self.pb.w, Self::K2P);
        let slot = (y % ring_rows(self.pb)) * w * k2;
        for (s, v) in self.va.iter_mut().zip(&self.ring[slot..slot + w * k2]) {
            *s += sign * *v as f64;
        }
    }

    /// Window means of the coefficients of every pixel of row `y` (rows in order).
    #[inline(always)]
    fn window_coefficients(&mut self, y: usize, mean: &mut [f32]) {
        let (w, h, r) = (self.pb.w, self.pb.h, self.pb.r);
        let (lo, hi) = (y.saturating_sub(r), (y + r).min(h - 1) + 1);
        if !self.started {
            (self.a_lo, self.a_hi, self.started) = (lo, lo, true);
        }
        // Remove first: the ring slot a new row takes is that of the row 2r+1 above it.
        while self.a_lo < lo {
            self.slide_a(self.a_lo, -1.0);
            self.a_lo += 1;
        }
        while self.a_hi < hi {
            let yy = self.a_hi;
            self.raw_coefficients(yy);
            self.slide_a(yy, 1.0);
            self.a_hi += 1;
        }
        let (k2, k2p, n2) = (Self::K2, Self::K2P, Self::N2);
        let inv_y = 1.0 / self.cy[y];
        let mut acc = [[0.0f64; CH]; MAX_K2 / CH];
        for x in 0..=r.min(w - 1) {
            add_chunks(&mut acc, &self.va[x * k2p..(x + 1) * k2p], n2);
        }
        for x in 0..w {
            let inv = inv_y / self.cx[x];
            let mut m = [0.0f32; MAX_K2];
            for (mj, aj) in m.chunks_exact_mut(CH).zip(&acc[..n2]) {
                for i in 0..CH {
                    mj[i] = (aj[i] * inv) as f32;
                }
            }
            mean[x * k2..(x + 1) * k2].copy_from_slice(&m[..k2]);
            if x + r + 1 < w {
                add_chunks(&mut acc, &self.va[(x + r + 1) * k2p..(x + r + 2) * k2p], n2);
            }
            if x >= r {
                sub_chunks(&mut acc, &self.va[(x - r) * k2p..(x - r + 1) * k2p], n2);
            }
        }
    }
}

/// The window systems of L pixels, lane-last: Σ + diag ε, cov(I, p), mean I, mean p.
struct Lanes<const D: usize> {
    sigma: [[[f32; L]; D]; D],
    cov: [[[f32; L]; D]; 3],
    mi: [[f32; L]; D],
    mp: [[f32; L]; 3],
}

impl<const D: usize> Default for Lanes<D> {
    fn default() -> Self {
        Lanes {
            sigma: [[[0.0; L]; D]; D],
            cov: [[[0.0; L]; D]; 3],
            mi: [[0.0; L]; D],
            mp: [[0.0; L]; 3],
        }
    }
}

impl<const D: usize> Lanes<D> {
    /// Lane `l` from the window means `m` (layout of the product channels). Covariances are
    /// formed in f64: each is a difference of two means that may be close.
    #[inline(always)]
    fn set(&mut self, l: usize, m: &[f64], eps: &[f32]) {
        let mut t = D;
        for a in 0..D {
            self.mi[a][l] = m[a] as f32;
            for b in a..D {
                let v = (m[t] - m[a] * m[b]) as f32;
                self.sigma[a][b][l] = v;
                self.sigma[b][a][l] = v;
                t += 1;
            }
            self.sigma[a][a][l] += eps[a];
        }
        let mp = [m[t], m[t + 1], m[t + 2]];
        t += 3;
        for c in 0..3 {
            self.mp[c][l] = mp[c] as f32;
            for a in 0..D {
                self.cov[c][a][l] = (m[t + c * D + a] - m[a] * mp[c]) as f32;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn avx2_copy_is_bit_identical_to_baseline() {
        if !has_avx2() {
            return;
        }
        let (w, h, d) = (45usize, 70usize, 3usize);
        let val = |i: usize, k: u64| ((i as u64 * 2654435761 + k * 97) % 1000) as f32 / 1000.0;
        let guide: Vec<f32> = (0..w * h * d).map(|i| val(i, 1)).collect();
        let p: Vec<f32> = (0..w * h * 3).map(|i| val(i, 2) * 4.0).collect();
        let eps = [0.01f32; 3];
        let pb = Problem {
            guide: &guide,
            p: &p,
            eps: &eps,
            w,
            h,
            r: 6,
        };
        let k2 = 3 * d + 3;
        let run = |avx2| {
            let mut out = vec![0.0f32; w * h * k2];
            let emit = |_: usize, m: &[f32], o: &mut [f32], _: &mut [f32]| o.copy_from_slice(m);
            stream_with::<3, false, _>(&pb, (&mut out, w * k2), (&mut [], 0), emit, avx2);
            out
        };
        let (a, b) = (run(true), run(false));
        assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
    }
}
