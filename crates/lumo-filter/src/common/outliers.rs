//! Outlier removal for low-resolution buffers (papers/README §3 step 3).

use lumo_image::{luminance, Image};

use crate::common::gbuffer::check_color;
use crate::FilterError;

/// Scales pixels whose luminance is more than `k_sigma` standard deviations from the mean of
/// their 3×3 neighbourhood (itself included, clipped at the border, missing pixels skipped) to
/// that mean luminance, keeping their chromaticity. The paper uses `k_sigma = 2`.
///
/// Returns the cleaned image and how many pixels were scaled. Non-finite pixels are left as
/// they are (callers treat them as missing).
pub fn remove_outliers(img: &Image, k_sigma: f32) -> Result<(Image, usize), FilterError> {
    check_color("low-res buffer", img)?;
    if !(k_sigma > 0.0) {
        return Err(crate::common::error::param(
            "outlier k_sigma",
            format!("{k_sigma} (must be > 0)"),
        ));
    }
    let (w, h) = (img.width, img.height);
    let lum: Vec<f32> = img
        .data
        .chunks_exact(3)
        .map(|p| {
            let l = luminance([p[0], p[1], p[2]]);
            if l.is_finite() {
                l
            } else {
                f32::NAN
            }
        })
        .collect();
    let mut out = img.clone();
    let mut changed = 0;
    for y in 0..h {
        for x in 0..w {
            let l = lum[y * w + x];
            if !l.is_finite() {
                continue;
            }
            // Two-pass mean and variance in f64 (the neighbourhood is at most 9 values).
            let (mut n, mut sum) = (0.0f64, 0.0f64);
            let ys = y.saturating_sub(1)..=(y + 1).min(h - 1);
            let xs = x.saturating_sub(1)..=(x + 1).min(w - 1);
            for yy in ys.clone() {
                for xx in xs.clone() {
                    let v = lum[yy * w + xx];
                    if v.is_finite() {
                        n += 1.0;
                        sum += v as f64;
                    }
                }
            }
            let mean = sum / n;
            let mut var = 0.0f64;
            for yy in ys.clone() {
                for xx in xs.clone() {
                    let v = lum[yy * w + xx];
                    if v.is_finite() {
                        var += (v as f64 - mean).powi(2);
                    }
                }
            }
            let std = (var / n).sqrt();
            if std > 0.0 && ((l as f64) - mean).abs() > k_sigma as f64 * std {
                let scale = if l > 0.0 {
                    (mean / l as f64) as f32
                } else {
                    0.0
                };
                let p = &mut out.data[(y * w + x) * 3..(y * w + x) * 3 + 3];
                if l > 0.0 {
                    p.iter_mut().for_each(|v| *v *= scale);
                } else {
                    p.fill(mean as f32);
                }
                changed += 1;
            }
        }
    }
    Ok((out, changed))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scales_a_firefly_to_the_local_mean() {
        let mut img = Image::new(5, 5, 3, 1.0);
        img.pixel_mut(2, 2).copy_from_slice(&[100.0, 100.0, 100.0]);
        let (out, n) = remove_outliers(&img, 2.0).unwrap();
        assert_eq!(n, 1);
        let l = luminance(out.rgb(2, 2));
        assert!((l - (8.0 + 100.0) / 9.0).abs() < 1e-3, "{l}");
        assert_eq!(out.rgb(0, 0), [1.0; 3]);
        let (same, n) = remove_outliers(&Image::new(4, 4, 3, 0.5), 2.0).unwrap();
        assert_eq!(n, 0);
        assert_eq!(same, Image::new(4, 4, 3, 0.5));
    }
}
