//! The light search's first test, for every pixel: is it far brighter than the geometric mean
//! of its window? One fused pass per axis: the logarithms and their running sums along rows,
//! then the running sums down columns with the test made as each row of means is formed, so
//! no plane of means is ever stored.
//!
//! The sums are [`crate::box_mean`]'s, operation for operation (f64 running sums, its window
//! counts, its eight bands of rows down the columns), so the means have its bits and the mask
//! is the one the plain search found with it.

use rayon::prelude::*;

use super::EmitterParams;

/// Half-width, in natural-log units, of the band around the brightness threshold inside which
/// the test is made as the plain search made it (`d + floor > brightness · exp(mean)` in f32).
/// Outside it the log-domain comparison cannot disagree: the f32 roundings of the logarithms,
/// the mean and the product add up to less than 1e-4 there even at |ln| ≈ 88.
const EXACT_BAND: f32 = 1e-3;

/// Rows whose running sums the horizontal pass carries at once: independent chains of f64
/// additions, so that their latencies overlap (each row's sums are formed as one row's are).
const ROWS: usize = 4;

/// For every pixel, whether `d + floor` exceeds [`EmitterParams::brightness`] × the geometric
/// mean of `d + floor` over the window of [`EmitterParams::radius`] (non-finite pixels take no
/// part and are never bright).
pub(super) fn bright_pixels(
    d: &[f32],
    w: usize,
    h: usize,
    floor: f32,
    params: &EmitterParams,
) -> Vec<bool> {
    let r = params.radius;
    let logs: Vec<f32> = d.par_iter().map(|&v| (v + floor).ln()).collect();
    // Without missing pixels every window's count is its size and the mean of the finite
    // values is the plain mean (the count channel's mean is exactly 1): the counts are skipped.
    let missing = logs.par_iter().any(|v| !v.is_finite());
    let values: Vec<f32>;
    let finite = if missing {
        values = logs
            .par_iter()
            .map(|&v| if v.is_finite() { v } else { 0.0 })
            .collect();
        &values
    } else {
        &logs
    };
    let cx = counts(w, r);
    let cy = counts(h, r);
    let sums = row_means(w, h, r, &cx, |i| finite[i]);
    let count_sums =
        missing.then(|| row_means(w, h, r, &cx, |i| f32::from(u8::from(logs[i].is_finite()))));
    let ln_brightness = params.brightness.ln();
    let test = |i: usize, m: f32| {
        if !(d[i].is_finite() && m.is_finite()) {
            return false;
        }
        let t = logs[i] - ln_brightness - m;
        if t.abs() > EXACT_BAND {
            t > 0.0
        } else {
            d[i] + floor > params.brightness * m.exp()
        }
    };
    let mut bright = vec![false; w * h];
    // The bands of `box_mean`'s vertical pass: where a band starts changes the last bits.
    let band = h.div_ceil(8).max(16);
    bright
        .par_chunks_mut(band * w)
        .enumerate()
        .for_each(|(b, out)| {
            let y0 = b * band;
            let mut acc = Column::new(&sums, w, h, r, y0);
            let mut count_acc = count_sums.as_ref().map(|c| Column::new(c, w, h, r, y0));
            for (dy, row) in out.chunks_mut(w).enumerate() {
                let y = y0 + dy;
                let inv = 1.0 / cy[y];
                match &mut count_acc {
                    None => {
                        for (x, o) in row.iter_mut().enumerate() {
                            *o = test(y * w + x, (acc.acc[x] * inv) as f32);
                        }
                    }
                    Some(c) => {
                        for (x, o) in row.iter_mut().enumerate() {
                            let (m, n) = ((acc.acc[x] * inv) as f32, (c.acc[x] * inv) as f32);
                            *o = test(y * w + x, if n > 0.0 { m / n } else { f32::NAN });
                        }
                        c.slide(y);
                    }
                }
                acc.slide(y);
            }
        });
    bright
}

/// Window sizes for every position along an axis of length `n` (as `box_mean` counts them).
fn counts(n: usize, r: usize) -> Vec<f64> {
    (0..n)
        .map(|i| (i.saturating_sub(r)..=(i + r).min(n - 1)).count() as f64)
        .collect()
}

/// Horizontal window means of every row, the values read through `src` (a pixel index).
fn row_means(
    w: usize,
    h: usize,
    r: usize,
    cx: &[f64],
    src: impl Fn(usize) -> f32 + Sync,
) -> Vec<f32> {
    let mut out = vec![0.0f32; w * h];
    out.par_chunks_mut(w * ROWS)
        .enumerate()
        .for_each(|(b, block)| horizontal(block, b * ROWS, w, r, cx, &src));
    out
}

/// Horizontal window means of up to [`ROWS`] rows from `y0` into `block`, the values read
/// through `src` (a pixel index): `box_mean`'s row pass, its running sums carried side by side.
#[inline(always)]
fn horizontal(
    block: &mut [f32],
    y0: usize,
    w: usize,
    r: usize,
    cx: &[f64],
    src: &impl Fn(usize) -> f32,
) {
    let rows = block.len() / w;
    let mut acc = [0.0f64; ROWS];
    let at = |k: usize, x: usize| src((y0 + k) * w + x) as f64;
    for x in 0..=r.min(w - 1) {
        for (k, a) in acc.iter_mut().enumerate().take(rows) {
            *a += at(k, x);
        }
    }
    for x in 0..w {
        let inv = 1.0 / cx[x];
        for (k, a) in acc.iter_mut().enumerate().take(rows) {
            block[k * w + x] = (*a * inv) as f32;
            if x + r + 1 < w {
                *a += at(k, x + r + 1);
            }
            if x >= r {
                *a -= at(k, x - r);
            }
        }
    }
}

/// The running column sums of `box_mean`'s vertical pass over a plane of row means.
struct Column<'a> {
    acc: Vec<f64>,
    rows: &'a [f32],
    w: usize,
    h: usize,
    r: usize,
}

impl<'a> Column<'a> {
    /// The sums for output row `y0`: rows `y0 − r ..= y0 + r`, clipped.
    fn new(rows: &'a [f32], w: usize, h: usize, r: usize, y0: usize) -> Self {
        let mut c = Column {
            acc: vec![0.0; w],
            rows,
            w,
            h,
            r,
        };
        for yy in y0.saturating_sub(r)..=(y0 + r).min(h - 1) {
            c.add(yy, 1.0);
        }
        c
    }

    fn add(&mut self, y: usize, sign: f64) {
        let row = &self.rows[y * self.w..(y + 1) * self.w];
        for (a, v) in self.acc.iter_mut().zip(row) {
            *a += sign * *v as f64;
        }
    }

    /// From output row `y` to `y + 1`.
    fn slide(&mut self, y: usize) {
        if y + self.r + 1 < self.h {
            self.add(y + self.r + 1, 1.0);
        }
        if y >= self.r {
            self.add(y - self.r, -1.0);
        }
    }
}
