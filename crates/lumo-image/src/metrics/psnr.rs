//! Peak signal-to-noise ratio of the tone-mapped images.

use super::{tone_map, MetricError, Pair};
use crate::Image;

/// `10 · log10(1 / MSE)` in dB, the MSE taken over valid pixels and all channels of the
/// tone-mapped values ([`tone_map`](super::tone_map) at `exposure` stops), whose peak is 1.
/// Identical tone-mapped images give `f64::INFINITY`.
pub fn psnr(reference: &Image, test: &Image, exposure: f32) -> Result<f64, MetricError> {
    Ok(psnr_pair(&Pair::new(reference, test)?, exposure))
}

pub(crate) fn psnr_pair(pair: &Pair, exposure: f32) -> f64 {
    let mse = pair.channel_mean(|r, t| {
        let d = tone_map(t as f32, exposure) as f64 - tone_map(r as f32, exposure) as f64;
        d * d
    });
    if mse == 0.0 {
        f64::INFINITY
    } else {
        -10.0 * mse.log10()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linear_to_srgb;

    #[test]
    fn hand_computed() {
        // Tone-mapped values 0 and 1 against 1 and 1: MSE 1/2, PSNR 10·log10(2) (to the f32
        // rounding of the sRGB curve at 1, which gives 1 − 6e-8).
        let r = Image::from_vec(2, 1, 1, vec![0.0, 1.0]);
        let t = Image::from_vec(2, 1, 1, vec![1.0, 7.0]);
        let p = psnr(&r, &t, 0.0).unwrap();
        assert!((p - 3.010_299_956_639_812).abs() < 1e-6, "{p}");
        // One stop down halves the linear values before the sRGB curve.
        let p = psnr(&r, &t, -1.0).unwrap();
        let d = linear_to_srgb(0.5) as f64 - linear_to_srgb(1.0) as f64;
        let expected =
            -10.0 * ((linear_to_srgb(0.5) as f64).powi(2) + d * d).log10() + 10.0 * 2f64.log10();
        assert!((p - expected).abs() < 1e-9, "{p} vs {expected}");
        assert_eq!(psnr(&r, &r, 0.0).unwrap(), f64::INFINITY);
        // Differences above the clamp vanish.
        let hot = Image::from_vec(2, 1, 1, vec![0.0, 3.0]);
        assert_eq!(psnr(&r, &hot, 0.0).unwrap(), f64::INFINITY);
    }

    #[test]
    fn psnr_is_mse_of_tone_mapped_values() {
        let (w, h) = (9, 7);
        let mut s = 7u32;
        let mut rand = move || {
            s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (s >> 8) as f32 / (1u32 << 24) as f32 * 1.5
        };
        let r = Image::from_vec(w, h, 3, (0..w * h * 3).map(|_| rand()).collect());
        let t = Image::from_vec(w, h, 3, (0..w * h * 3).map(|_| rand()).collect());
        let tm = |img: &Image| {
            Image::from_vec(
                w,
                h,
                3,
                img.data.iter().map(|&v| tone_map(v, 0.5)).collect(),
            )
        };
        let mse = super::super::mse(&tm(&r), &tm(&t)).unwrap();
        let p = psnr(&r, &t, 0.5).unwrap();
        assert!((p - 10.0 * (1.0 / mse).log10()).abs() < 1e-9);
    }
}
