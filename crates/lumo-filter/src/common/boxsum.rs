//! Box means whose cost does not depend on the radius: running sums, first along rows, then
//! down columns.
//!
//! Sums are carried in f64: a running f32 sum keeps the rounding error of every value it ever
//! added and removed, so one firefly of 1e3 would leave an error of ~1e-4 on the rest of the
//! row, which the guided filter's covariance (a difference of two means) then amplifies.

use rayon::prelude::*;

use crate::common::zeroed::zeroed;

/// Window sizes for every position along an axis of length `n`: the window [i−r, i+r] clipped
/// to the axis (the normalisation of He et al.'s `boxfilter(ones)`).
fn counts(n: usize, r: usize) -> Vec<f64> {
    (0..n)
        .map(|i| (i.saturating_sub(r)..=(i + r).min(n - 1)).count() as f64)
        .collect()
}

/// Mean over the (2r+1)×(2r+1) window clipped to the image, for every pixel and each of the
/// `k` interleaved channels of `data` (`w*h*k` values, pixel-major).
///
/// Panics if `data.len() != w*h*k` (a programming error inside the crate).
pub fn box_mean(data: &[f32], w: usize, h: usize, k: usize, r: usize) -> Vec<f32> {
    assert_eq!(data.len(), w * h * k, "box_mean: data length");
    if w == 0 || h == 0 || k == 0 {
        return Vec::new();
    }
    let cx = counts(w, r);
    let cy = counts(h, r);
    let stride = w * k;
    // Horizontal pass, one row per task.
    let mut tmp = zeroed(data.len());
    tmp.par_chunks_mut(stride)
        .zip(data.par_chunks(stride))
        .for_each_init(
            || vec![0.0f64; k],
            |acc, (o, row)| horizontal(row, o, &cx, r, k, acc),
        );
    let tmp: &[f32] = &tmp;
    let mut out = zeroed(data.len());
    out.par_chunks_mut(band_height(h) * stride)
        .enumerate()
        .for_each(|(b, out_band)| {
            vertical_band(
                |yy| &tmp[yy * stride..(yy + 1) * stride],
                out_band,
                b * band_height(h),
                h,
                r,
                &cy,
            )
        });
    out
}

/// The vertical pass's band height. Each band primes its running sums with the rows above it
/// (O(r) extra rows per band) and then slides down; a band owns its output rows. The height
/// comes from the image alone, never from the thread count: a band restarts its running sums,
/// so where bands start changes the last bits of the means, and through `auto`'s sharp blend
/// whole pixels (it once did: `auto` gave other bits on one thread than on two). Eight bands,
/// the split two threads had before.
fn band_height(h: usize) -> usize {
    h.div_ceil(8).max(16)
}

/// The horizontal pass over one row, with the channel count a constant where it is 1 or 2
/// (`auto`'s errors run it on 1 channel, the light search on 2: the per-channel loops then
/// unroll and vectorise; the same operations per channel, so the same bits).
fn horizontal(row: &[f32], out: &mut [f32], cx: &[f64], r: usize, k: usize, acc: &mut [f64]) {
    match k {
        1 => row_means::<1>(row, out, cx, r),
        2 => row_means::<2>(row, out, cx, r),
        _ => row_means_any(row, out, cx, r, k, acc),
    }
}

/// The vertical pass of one band starting at row `y0` into `out_band` (whole rows of the
/// band's output), reading the horizontal pass's row `yy` as `tmp(yy)`.
fn vertical_band<'a>(
    tmp: impl Fn(usize) -> &'a [f32],
    out_band: &mut [f32],
    y0: usize,
    h: usize,
    r: usize,
    cy: &[f64],
) {
    let stride = tmp(y0).len();
    let rows = out_band.len() / stride;
    let mut acc = vec![0.0f64; stride];
    let first = y0.saturating_sub(r);
    let last = (y0 + r).min(h - 1);
    for yy in first..=last {
        add_row(&mut acc, tmp(yy), 1.0);
    }
    for dy in 0..rows {
        let y = y0 + dy;
        let inv = 1.0 / cy[y];
        let o = &mut out_band[dy * stride..(dy + 1) * stride];
        for (ov, a) in o.iter_mut().zip(&acc) {
            *ov = (*a * inv) as f32;
        }
        if y + r + 1 < h {
            add_row(&mut acc, tmp(y + r + 1), 1.0);
        }
        if y >= r {
            add_row(&mut acc, tmp(y - r), -1.0);
        }
    }
}

/// [`box_mean`] on the rows `y` where `wanted[y]`, with its bits, as `(y, means of row y)` in
/// row order; `row(y, buf)` writes row `y` of the data (`w*k` values) into `buf`. Only the
/// vertical bands that hold a wanted row are summed, and only the rows those bands read are
/// made and passed horizontally.
///
/// Why: the guided filter fills its few missing pixels (lights hidden by the light search)
/// from their window's mean; a whole-frame mean of four channels per run cost `auto` nine
/// passes and 15 image-sized buffers per candidate for a few hundred pixels.
pub(crate) fn box_mean_rows(
    row: impl Fn(usize, &mut [f32]) + Sync,
    (w, h, k, r): (usize, usize, usize, usize),
    wanted: &[bool],
) -> Vec<(usize, Vec<f32>)> {
    assert_eq!(wanted.len(), h, "box_mean_rows: one flag per row");
    if w == 0 || h == 0 || k == 0 {
        return Vec::new();
    }
    let (cx, cy, stride, band) = (counts(w, r), counts(h, r), w * k, band_height(h));
    let bands: Vec<usize> = (0..h.div_ceil(band))
        .filter(|b| wanted[b * band..((b + 1) * band).min(h)].contains(&true))
        .collect();
    // The rows of the horizontal pass those bands read.
    let mut needed = vec![false; h];
    for &b in &bands {
        let (y0, y1) = (b * band, ((b + 1) * band).min(h));
        needed[y0.saturating_sub(r)..=(y1 + r).min(h - 1)].fill(true);
    }
    let tmp: Vec<Option<Vec<f32>>> = needed
        .par_iter()
        .enumerate()
        .map_init(
            || (vec![0.0f32; stride], vec![0.0f64; k]),
            |(buf, acc), (y, &need)| {
                need.then(|| {
                    row(y, buf);
                    let mut o = vec![0.0f32; stride];
                    horizontal(buf, &mut o, &cx, r, k, acc);
                    o
                })
            },
        )
        .collect();
    let tmp_row = |yy: usize| tmp[yy].as_deref().expect("a row the band reads");
    bands
        .par_iter()
        .flat_map_iter(|&b| {
            let (y0, y1) = (b * band, ((b + 1) * band).min(h));
            let mut out = vec![0.0f32; (y1 - y0) * stride];
            vertical_band(tmp_row, &mut out, y0, h, r, &cy);
            let rows: Vec<(usize, Vec<f32>)> = (y0..y1)
                .filter(|&y| wanted[y])
                .map(|y| (y, out[(y - y0) * stride..(y - y0 + 1) * stride].to_vec()))
                .collect();
            rows
        })
        .collect()
}

/// Mean of the finite values of the one-channel plane `values` over the (2r+1)×(2r+1) window
/// around every pixel (clipped to the image); NaN where the window holds none. Non-finite
/// values are missing pixels: they take no part, rather than poisoning the sums.
pub(crate) fn box_mean_finite(values: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let mut pairs = vec![0.0f32; values.len() * 2];
    pairs
        .par_chunks_exact_mut(2)
        .zip(values.par_iter())
        .for_each(|(p, &v)| {
            if v.is_finite() {
                p[0] = v;
                p[1] = 1.0;
            }
        });
    box_mean(&pairs, w, h, 2, r)
        .par_chunks_exact(2)
        .map(|m| if m[1] > 0.0 { m[0] / m[1] } else { f32::NAN })
        .collect()
}

/// The horizontal pass over one row of `k` interleaved channels: `out` gets the mean of each
/// channel over the window of radius `r` (`cx`: the window sizes along the row; `acc`: k
/// sums). Inlined into [`row_means`] with `k` a constant.
#[inline(always)]
fn row_means_any(row: &[f32], out: &mut [f32], cx: &[f64], r: usize, k: usize, acc: &mut [f64]) {
    let w = cx.len();
    acc.fill(0.0);
    for x in 0..=r.min(w - 1) {
        for c in 0..k {
            acc[c] += row[x * k + c] as f64;
        }
    }
    for x in 0..w {
        let inv = 1.0 / cx[x];
        for c in 0..k {
            out[x * k + c] = (acc[c] * inv) as f32;
        }
        if x + r + 1 < w {
            let a = &row[(x + r + 1) * k..(x + r + 2) * k];
            for c in 0..k {
                acc[c] += a[c] as f64;
            }
        }
        if x >= r {
            let s = &row[(x - r) * k..(x - r + 1) * k];
            for c in 0..k {
                acc[c] -= s[c] as f64;
            }
        }
    }
}

/// [`row_means_any`] for `K` channels, a constant.
fn row_means<const K: usize>(row: &[f32], out: &mut [f32], cx: &[f64], r: usize) {
    row_means_any(row, out, cx, r, K, &mut [0.0f64; K]);
}

#[inline]
fn add_row(acc: &mut [f64], row: &[f32], sign: f64) {
    for (a, v) in acc.iter_mut().zip(row) {
        *a += sign * *v as f64;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same bits on any number of threads (the vertical pass's bands once came from the
    /// thread count, and a band's running sums round differently from a longer run's).
    #[test]
    fn same_bits_on_any_thread_count() {
        let (w, h, k, r) = (37usize, 300usize, 3usize, 7usize);
        let mut s = 7u64;
        let data: Vec<f32> = (0..w * h * k)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let u = (s >> 40) as f32 / (1u64 << 24) as f32;
                // Heavy-tailed, as squared 1-spp errors: mostly tiny, now and then huge (wider
                // than an f64 sum of f32 values holds exactly).
                if u > 0.98 {
                    1e9 * u
                } else {
                    1e-6 * u
                }
            })
            .collect();
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| box_mean(&data, w, h, k, r))
        };
        let one = run(1);
        for threads in [2, 3, 4] {
            assert!(one == run(threads), "{threads} threads differ from one");
        }
    }

    /// The means on the wanted rows only are the bits of the whole frame's: rows in one band,
    /// in several, at the frame's top and bottom, none, all; 1, 2 and 4 channels; radii smaller
    /// than a band, larger than one, larger than the frame.
    #[test]
    fn rows_give_the_bits_of_the_whole_mean() {
        let (w, h) = (29usize, 300usize);
        for (k, r) in [(4, 3), (4, 45), (1, 7), (2, 400)] {
            let data: Vec<f32> = (0..w * h * k)
                .map(|i| ((i * 7919) % 1013) as f32 * 0.37 + if i % 97 == 0 { 1e6 } else { 0.0 })
                .collect();
            let whole = box_mean(&data, w, h, k, r);
            let patterns: [&dyn Fn(usize) -> bool; 5] = [
                &|y| y == 120,
                &|y| (40..44).contains(&y) || y == 250,
                &|y| y == 0 || y == h - 1,
                &|_| false,
                &|_| true,
            ];
            for (n, wanted) in patterns.iter().enumerate() {
                let wanted: Vec<bool> = (0..h).map(wanted).collect();
                let rows = box_mean_rows(
                    |y, buf| buf.copy_from_slice(&data[y * w * k..(y + 1) * w * k]),
                    (w, h, k, r),
                    &wanted,
                );
                let ys: Vec<usize> = rows.iter().map(|(y, _)| *y).collect();
                let want: Vec<usize> = (0..h).filter(|&y| wanted[y]).collect();
                assert_eq!(ys, want, "k {k} r {r} pattern {n}: rows");
                for (y, m) in rows {
                    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    let row = &whole[y * w * k..(y + 1) * w * k];
                    assert_eq!(bits(&m), bits(row), "k {k} r {r} pattern {n} row {y}");
                }
            }
        }
    }

    #[test]
    fn matches_brute_force() {
        // Every channel count with a copy of its own (2, 14, 15) and two without; radii
        // smaller and larger than the image.
        for (k, r) in [(2, 3), (14, 2), (15, 4), (3, 1), (1, 20)] {
            matches_brute_force_with(k, r);
        }
    }

    fn matches_brute_force_with(k: usize, r: usize) {
        let (w, h) = (13usize, 9usize);
        let data: Vec<f32> = (0..w * h * k)
            .map(|i| ((i * 7919) % 101) as f32 / 10.0)
            .collect();
        let got = box_mean(&data, w, h, k, r);
        for y in 0..h {
            for x in 0..w {
                for c in 0..k {
                    let (mut s, mut n) = (0.0f64, 0.0f64);
                    for yy in y.saturating_sub(r)..=(y + r).min(h - 1) {
                        for xx in x.saturating_sub(r)..=(x + r).min(w - 1) {
                            s += data[(yy * w + xx) * k + c] as f64;
                            n += 1.0;
                        }
                    }
                    let want = (s / n) as f32;
                    let g = got[(y * w + x) * k + c];
                    assert!(
                        (g - want).abs() < 1e-5,
                        "k {k} r {r} ({x},{y},{c}): {g} vs {want}"
                    );
                }
            }
        }
    }
}
