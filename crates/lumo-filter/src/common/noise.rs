//! A spatial estimate of a noisy image's per-pixel variance, for filters whose input comes with
//! no variance plane, or with one estimated from too few samples to steer a colour weight.

use lumo_image::{luminance, rgb_of, Image};
use rayon::prelude::*;

/// The luminance variance of 3×3 windows, then for each pixel the smallest value among the
/// windows that contain it (one channel).
///
/// This is the stand-in SVGF uses before it has temporal history. The erosion matters: without
/// it a noise-free edge (a hard shadow, a light's rim) looks like noise to its own window and a
/// variance-guided filter blurs it; some window next to an edge pixel lies wholly on its side
/// of the edge and reports 0. Non-finite pixels count as 0.
///
/// Each pass runs row by row over whole rows so that its loops vectorise (in AVX-512 / AVX2
/// copies chosen at run time); a pixel's sums add the same terms in the same order as a
/// per-pixel loop over its clipped window (kept in the tests as the reference), so the result
/// is the same bit for bit.
pub fn spatial_variance(color: &Image) -> Image {
    let (w, h) = (color.width, color.height);
    let mut lum = vec![0.0f32; w * h];
    lum.par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(y, row)| luminance_row(color, y, row));
    let mut windows = vec![0.0f32; w * h];
    windows
        .par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(y, row)| window_variance_row(&lum, w, h, y, row));
    let mut out = Image::new(w, h, 1, 0.0);
    out.data
        .par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(y, row)| erode_row(&windows, w, h, y, row));
    out
}

/// Columns per stack buffer of the row passes.
const CHUNK: usize = 64;

multiversion! {
    /// Luminance of row `y` of `color` (as `Image::rgb` reads a pixel); 0 where not finite.
    fn luminance_row(color: &Image, y: usize, out: &mut [f32]) as luminance_row_impl {
        let c = color.channels;
        let data = &color.data[y * out.len() * c..(y + 1) * out.len() * c];
        let finite = |v: f32| if v.is_finite() { v } else { 0.0 };
        // Three channels (the common case) with a constant count, so the loop vectorises.
        if c == 3 {
            for (l, p) in out.iter_mut().zip(data.chunks_exact(3)) {
                *l = finite(luminance(rgb_of(p)));
            }
        } else {
            for (l, p) in out.iter_mut().zip(data.chunks_exact(c)) {
                *l = finite(luminance(rgb_of(p)));
            }
        }
    }
}

/// The rows of the 3×3 window around row `y`, clipped to the image.
fn window_rows(h: usize, y: usize) -> std::ops::Range<usize> {
    y.saturating_sub(1)..(y + 2).min(h)
}

/// Variance of the clipped 3×3 window of pixel (x, y): the per-pixel rule, for the border
/// columns.
fn window_variance(lum: &[f32], w: usize, h: usize, x: usize, y: usize) -> f32 {
    let (mut s, mut s2, mut n) = (0.0f32, 0.0f32, 0.0f32);
    for yy in window_rows(h, y) {
        for xx in x.saturating_sub(1)..(x + 2).min(w) {
            let l = lum[yy * w + xx];
            s += l;
            s2 += l * l;
            n += 1.0;
        }
    }
    let m = s / n;
    (s2 / n - m * m).max(0.0)
}

multiversion! {
    /// Row `y` of the 3×3 window variances of the `w`×`h` luminance image `lum`.
    fn window_variance_row(lum: &[f32], w: usize, h: usize, y: usize, out: &mut [f32])
        as window_variance_row_impl
    {
        let rows = window_rows(h, y);
        // Interior columns: three columns per window row, added left to right; the count
        // is a small integer, exact however it is formed.
        let n = (3 * rows.len()) as f32;
        let mut x0 = 1;
        while x0 + 1 < w {
            let len = CHUNK.min(w - 1 - x0);
            let (mut s, mut s2) = ([0.0f32; CHUNK], [0.0f32; CHUNK]);
            for yy in rows.clone() {
                let r = &lum[yy * w + x0 - 1..yy * w + x0 + len + 1];
                for t in 0..len {
                    for d in 0..3 {
                        let l = r[t + d];
                        s[t] += l;
                        s2[t] += l * l;
                    }
                }
            }
            for t in 0..len {
                let m = s[t] / n;
                out[x0 + t] = (s2[t] / n - m * m).max(0.0);
            }
            x0 += len;
        }
        for x in [0, w.saturating_sub(1)] {
            if x < w {
                out[x] = window_variance(lum, w, h, x, y);
            }
        }
    }
}

multiversion! {
    /// Row `y` of the smallest window variance among the 3×3 windows containing each pixel.
    fn erode_row(windows: &[f32], w: usize, h: usize, y: usize, out: &mut [f32])
        as erode_row_impl
    {
        // `min` is exact and ignores NaN, so the order of the window's values does not matter.
        out.fill(f32::INFINITY);
        for yy in window_rows(h, y) {
            let r = &windows[yy * w..(yy + 1) * w];
            for x in 1..w.saturating_sub(1) {
                out[x] = out[x].min(r[x - 1]).min(r[x]).min(r[x + 1]);
            }
            // The border columns' windows have two columns (one in a one-column image).
            out[0] = r[..w.min(2)].iter().fold(out[0], |v, &x| v.min(x));
            if w >= 2 {
                out[w - 1] = out[w - 1].min(r[w - 2]).min(r[w - 1]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The per-pixel version the row passes replaced, as it was: the bit-exact reference.
    fn spatial_variance_reference(color: &Image) -> Image {
        let (w, h) = (color.width, color.height);
        let mut lum = vec![0.0f32; w * h];
        lum.par_chunks_mut(w.max(1))
            .enumerate()
            .for_each(|(y, row)| {
                for (x, l) in row.iter_mut().enumerate() {
                    let v = luminance(color.rgb(x, y));
                    *l = if v.is_finite() { v } else { 0.0 };
                }
            });
        let mut windows = vec![0.0f32; w * h];
        windows
            .par_chunks_mut(w.max(1))
            .enumerate()
            .for_each(|(y, row)| {
                // `window_variance` is the per-pixel rule as it was (the row pass uses it
                // only for the border columns).
                for (x, out) in row.iter_mut().enumerate() {
                    *out = window_variance(&lum, w, h, x, y);
                }
            });
        let mut out = Image::new(w, h, 1, 0.0);
        out.data
            .par_chunks_mut(w.max(1))
            .enumerate()
            .for_each(|(y, row)| {
                for (x, o) in row.iter_mut().enumerate() {
                    let mut v = f32::INFINITY;
                    for yy in y.saturating_sub(1)..(y + 2).min(h) {
                        for xx in x.saturating_sub(1)..(x + 2).min(w) {
                            v = v.min(windows[yy * w + xx]);
                        }
                    }
                    *o = v;
                }
            });
        out
    }

    #[test]
    fn row_passes_match_the_per_pixel_reference_bit_for_bit() {
        let mut seed = 3u64;
        let mut rnd = || crate::bench::synthetic::splitmix(&mut seed);
        for (w, h, c) in [
            (1, 1, 3),
            (2, 5, 3),
            (3, 2, 1),
            (70, 9, 3),
            (131, 4, 4),
            (9, 7, 2),
            (200, 1, 3),
        ] {
            let mut img = Image::new(w, h, c, 0.0);
            for v in &mut img.data {
                *v = rnd() * 4.0 - 0.5;
            }
            if img.data.len() > 7 {
                img.data[5] = f32::NAN;
                img.data[7] = f32::INFINITY;
            }
            let got = spatial_variance(&img);
            let want = spatial_variance_reference(&img);
            let bits = |i: &Image| i.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&got), bits(&want), "{w}×{h}, {c} channels");
        }
    }

    #[test]
    fn constant_image_has_zero_variance_and_an_edge_stays_zero() {
        let mut img = Image::new(8, 6, 3, 0.5);
        assert!(spatial_variance(&img).data.iter().all(|&v| v == 0.0));
        // A noise-free vertical step: every pixel has a window wholly on its own side.
        for y in 0..6 {
            for x in 4..8 {
                img.pixel_mut(x, y).copy_from_slice(&[2.0, 2.0, 2.0]);
            }
        }
        assert!(spatial_variance(&img).data.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn checkerboard_noise_is_seen_everywhere() {
        let mut img = Image::new(6, 6, 3, 0.0);
        for i in 0..36 {
            let v = if (i % 6 + i / 6) % 2 == 0 { 1.0 } else { 0.0 };
            img.data[i * 3..i * 3 + 3].fill(v);
        }
        let var = spatial_variance(&img);
        // Every 3×3 (or border 2×2, 2×3) window of a checkerboard mixes both values.
        assert!(var.data.iter().all(|&v| v > 0.15), "{:?}", var.data);
    }
}
