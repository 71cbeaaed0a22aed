//! The light search's first test, for every pixel: is it far brighter than the geometric mean
//! of its window? The logarithms and their window sums along rows, then the sums down columns
//! with the test made as each row of sums is formed, in bands of rows that keep only the rows
//! their column sums span.
//!
//! The test is made on sums, not means: `(ln(d + floor) − ln b) · n > Σ ln`, n the count of
//! finite pixels in the window, in f64 — no division and no `exp` per pixel, and the same
//! decision as the plain form `d + floor > b · exp(Σ ln / n)` except where the two sides are
//! within a few 1e-7 of each other. The logarithms come from [`ln_normal`], which vectorises
//! (libm's `ln` was a third of the search's time).

use lumo_simd::fastmath::ln_normal;
use rayon::prelude::*;

use super::EmitterParams;

/// For every pixel, whether `d + floor` exceeds [`EmitterParams::brightness`] × the geometric
/// mean of `d + floor` over the window of [`EmitterParams::radius`] (non-finite pixels take no
/// part and are never bright). `floor` must be a positive normal float.
///
/// Bands of rows, each with its own ring of the rows' logarithms and horizontal sums (the
/// 2r + 1 rows its column sums span and the next), so no image-sized plane but the answer is
/// allocated: fresh planes cost as much in page faults as the arithmetic. A band recomputes
/// the r rows above and below it (a quarter more logarithms at 512², r = 8).
pub(super) fn bright_pixels(
    d: &[f32],
    w: usize,
    h: usize,
    floor: f32,
    params: &EmitterParams,
) -> Vec<bool> {
    let r = params.radius;
    let slots = (2 * r + 2).min(h + 1);
    // Eight bands, from the image's height and the radius alone (a band restarts its running
    // sums, which may change the last bits: the split must not depend on the threads); one
    // band where the ring would be as tall as a band, so that memory stays one ring.
    let band = if 2 * r + 2 <= h.div_ceil(8) {
        h.div_ceil(8)
    } else {
        h
    };
    let ln_b = (params.brightness as f64).ln();
    let mut bright = vec![false; w * h];
    bright
        .par_chunks_mut(band * w)
        .enumerate()
        .for_each(|(b, out)| {
            let y0 = b * band;
            let mut ring = Ring::new(slots, w);
            let mut acc = vec![0.0f64; w];
            let mut count = vec![0u32; w];
            // The rows of ring slot `y`, computed from `d` (one logarithm and one running sum
            // per pixel).
            let fill = |ring: &mut Ring, y: usize| {
                let (logs, sums, counts) = ring.slot_mut(y);
                log_rows(&d[y * w..][..w], floor, logs);
                horizontal(logs, sums, counts, w, r);
            };
            for yy in y0.saturating_sub(r)..=(y0 + r).min(h - 1) {
                fill(&mut ring, yy);
                let (_, s, c) = ring.slot(yy);
                add_row(&mut acc, &mut count, s, c);
            }
            for (dy, out) in out.chunks_mut(w).enumerate() {
                let y = y0 + dy;
                test_row(ring.slot(y).0, &acc, &count, ln_b, out);
                let (next, last) = (y + r + 1, y.checked_sub(r));
                if next < h {
                    fill(&mut ring, next);
                }
                match (next < h, last) {
                    (true, Some(last)) => {
                        let ((_, s, c), (_, so, co)) = (ring.slot(next), ring.slot(last));
                        slide_row(&mut acc, &mut count, s, c, so, co);
                    }
                    (true, None) => {
                        let (_, s, c) = ring.slot(next);
                        add_row(&mut acc, &mut count, s, c);
                    }
                    (false, Some(last)) => {
                        let (_, so, co) = ring.slot(last);
                        sub_row(&mut acc, &mut count, so, co);
                    }
                    (false, None) => {}
                }
            }
        });
    bright
}

/// A band's rows of logarithms, horizontal window sums and counts, row `y` in slot
/// `y % slots`: with 2r + 2 slots the row entering the column sums and the one leaving them
/// are both held.
struct Ring {
    logs: Vec<f32>,
    sums: Vec<f32>,
    counts: Vec<u32>,
    slots: usize,
    w: usize,
}

impl Ring {
    fn new(slots: usize, w: usize) -> Self {
        Ring {
            logs: vec![0.0; slots * w],
            sums: vec![0.0; slots * w],
            counts: vec![0; slots * w],
            slots,
            w,
        }
    }

    fn slot(&self, y: usize) -> (&[f32], &[f32], &[u32]) {
        let at = (y % self.slots) * self.w..(y % self.slots + 1) * self.w;
        (
            &self.logs[at.clone()],
            &self.sums[at.clone()],
            &self.counts[at],
        )
    }

    fn slot_mut(&mut self, y: usize) -> (&mut [f32], &mut [f32], &mut [u32]) {
        let at = (y % self.slots) * self.w..(y % self.slots + 1) * self.w;
        (
            &mut self.logs[at.clone()],
            &mut self.sums[at.clone()],
            &mut self.counts[at],
        )
    }
}

multiversion! {
    /// `ln(d + floor)` of a run of pixels, NaN where `d` is not finite.
    fn log_rows(d: &[f32], floor: f32, out: &mut [f32]) as log_rows_impl {
        let d = &d[..out.len()];
        for (o, &v) in out.iter_mut().zip(d) {
            let x = v + floor;
            // d ≥ 0 and floor a normal float: a finite x is in ln_normal's domain.
            *o = if x.is_finite() { ln_normal(x) } else { f32::NAN };
        }
    }
}

/// Window sums along a row of the finite logarithms of `logs`, and how many there are in
/// each window: a running sum in f64.
fn horizontal(logs: &[f32], sums: &mut [f32], counts: &mut [u32], w: usize, r: usize) {
    let at = |x: usize| {
        let l = logs[x];
        if l.is_finite() {
            (l as f64, 1u32)
        } else {
            (0.0, 0)
        }
    };
    let (mut acc, mut count) = (0.0f64, 0u32);
    for x in 0..=r.min(w - 1) {
        let (v, c) = at(x);
        acc += v;
        count += c;
    }
    for x in 0..w {
        sums[x] = acc as f32;
        counts[x] = count;
        let (add, cadd) = if x + r + 1 < w {
            at(x + r + 1)
        } else {
            (0.0, 0)
        };
        let (sub, csub) = if x >= r { at(x - r) } else { (0.0, 0) };
        acc += add - sub;
        count = count + cadd - csub;
    }
}

multiversion! {
    /// Whether each pixel of a row is bright: `(ln(d + floor) − ln b) · n > Σ`, with the
    /// window's sum Σ and count n from the running column sums.
    fn test_row(logs: &[f32], acc: &[f64], count: &[u32], ln_b: f64, out: &mut [bool])
        as test_row_impl {
        let len = out.len();
        let (logs, acc, count) = (&logs[..len], &acc[..len], &count[..len]);
        for x in 0..len {
            let l = logs[x];
            // A finite logarithm counts itself, so n ≥ 1 wherever the test can pass.
            out[x] = l.is_finite() & ((l as f64 - ln_b) * count[x] as f64 > acc[x]);
        }
    }
}

multiversion! {
    /// Column sums: row `s`/`c` in.
    fn add_row(acc: &mut [f64], count: &mut [u32], s: &[f32], c: &[u32]) as add_row_impl {
        let len = acc.len();
        let (count, s, c) = (&mut count[..len], &s[..len], &c[..len]);
        for x in 0..len {
            acc[x] += s[x] as f64;
            count[x] += c[x];
        }
    }
}

multiversion! {
    /// Column sums: row `s`/`c` out.
    fn sub_row(acc: &mut [f64], count: &mut [u32], s: &[f32], c: &[u32]) as sub_row_impl {
        let len = acc.len();
        let (count, s, c) = (&mut count[..len], &s[..len], &c[..len]);
        for x in 0..len {
            acc[x] -= s[x] as f64;
            count[x] -= c[x];
        }
    }
}

multiversion! {
    /// Column sums: row `s`/`c` in and row `so`/`co` out, in one pass.
    fn slide_row(
        acc: &mut [f64],
        count: &mut [u32],
        s: &[f32],
        c: &[u32],
        so: &[f32],
        co: &[u32],
    ) as slide_row_impl {
        let len = acc.len();
        let (count, s, c, so, co) = (&mut count[..len], &s[..len], &c[..len], &so[..len], &co[..len]);
        for x in 0..len {
            acc[x] += s[x] as f64 - so[x] as f64;
            count[x] = count[x] + c[x] - co[x];
        }
    }
}
