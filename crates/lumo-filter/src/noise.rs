//! A spatial estimate of a noisy image's per-pixel variance, for filters whose input comes with
//! no variance plane, or with one estimated from too few samples to steer a colour weight.

use lumo_image::{luminance, Image};
use rayon::prelude::*;

/// The luminance variance of 3×3 windows, then for each pixel the smallest value among the
/// windows that contain it (one channel).
///
/// This is the stand-in SVGF uses before it has temporal history. The erosion matters: without
/// it a noise-free edge (a hard shadow, a light's rim) looks like noise to its own window and a
/// variance-guided filter blurs it; some window next to an edge pixel lies wholly on its side
/// of the edge and reports 0. Non-finite pixels count as 0.
pub fn spatial_variance(color: &Image) -> Image {
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
            for (x, out) in row.iter_mut().enumerate() {
                let (mut s, mut s2, mut n) = (0.0f32, 0.0f32, 0.0f32);
                for yy in y.saturating_sub(1)..(y + 2).min(h) {
                    for xx in x.saturating_sub(1)..(x + 2).min(w) {
                        let l = lum[yy * w + xx];
                        s += l;
                        s2 += l * l;
                        n += 1.0;
                    }
                }
                let m = s / n;
                *out = (s2 / n - m * m).max(0.0);
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

#[cfg(test)]
mod tests {
    use super::*;

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
