//! Pixel reconstruction filters by importance sampling: a sample's offset from the pixel
//! centre is drawn from the filter's own density (inverse CDF per axis, both axes
//! separable as in Mitsuba), so every sample has weight 1 and the Sobol points' stratification
//! carries over to the filtered offsets (the warp is monotonic in each coordinate).

use glam::Vec2;
use lumo_scene::PixelFilter;

/// erf(2√2): the mass of a standard normal within ±4σ, where Mitsuba cuts its Gaussian filter.
const ERF_4_SIGMA: f32 = 0.999_936_66;

/// The offset from the pixel centre (pixels) that `filter` gives the uniform point `u` in
/// [0, 1)², kept within `lo..=hi` on each axis: the film's edges, as Mitsuba's film keeps
/// samples on the image (without `sample_border`), so that a pixel at the edge weighs only the
/// part of its filter on the image.
#[inline]
pub fn filter_offset(filter: &PixelFilter, u: Vec2, lo: Vec2, hi: Vec2) -> Vec2 {
    match *filter {
        PixelFilter::Box => u - Vec2::splat(0.5),
        PixelFilter::Tent { radius } => {
            Vec2::new(
                tent(u.x, lo.x / radius, hi.x / radius),
                tent(u.y, lo.y / radius, hi.y / radius),
            ) * radius
        }
        PixelFilter::Gaussian { stddev } => {
            Vec2::new(
                gaussian(u.x, lo.x / stddev, hi.x / stddev),
                gaussian(u.y, lo.y / stddev, hi.y / stddev),
            ) * stddev
        }
    }
}

/// The unit tent 1 − |x| on [−1, 1] restricted to [lo, hi], by inverting its CDF.
#[inline]
fn tent(u: f32, lo: f32, hi: f32) -> f32 {
    let cdf = |x: f32| {
        let x = x.clamp(-1.0, 1.0);
        if x < 0.0 {
            0.5 * (1.0 + x) * (1.0 + x)
        } else {
            1.0 - 0.5 * (1.0 - x) * (1.0 - x)
        }
    };
    let (c0, c1) = if lo <= -1.0 && hi >= 1.0 {
        (0.0, 1.0)
    } else {
        (cdf(lo), cdf(hi))
    };
    let u = c0 + u * (c1 - c0);
    let x = if u < 0.5 {
        (2.0 * u).sqrt() - 1.0
    } else {
        1.0 - (2.0 - 2.0 * u).max(0.0).sqrt()
    };
    x.clamp(lo.max(-1.0), hi.min(1.0))
}

/// The standard normal cut at ±4 (Mitsuba's radius of 4 stddev) and restricted to [lo, hi]:
/// uniform in erf space over the kept mass, then mapped back. (Mitsuba's filter also
/// subtracts the Gaussian's value at the cut, exp(−8) ≈ 3·10⁻⁴ of the peak: a change far
/// below the noise of any pixel.)
#[inline]
fn gaussian(u: f32, lo: f32, hi: f32) -> f32 {
    let (e0, e1) = if lo <= -4.0 && hi >= 4.0 {
        (-ERF_4_SIGMA, ERF_4_SIGMA)
    } else {
        let e = |x: f32| erf(x * std::f32::consts::FRAC_1_SQRT_2).clamp(-ERF_4_SIGMA, ERF_4_SIGMA);
        (e(lo), e(hi))
    };
    let x = std::f32::consts::SQRT_2 * erf_inv(e0 + u * (e1 - e0));
    x.clamp(lo.max(-4.0), hi.min(4.0))
}

/// The error function (Abramowitz & Stegun 7.1.26, absolute error below 1.5·10⁻⁷).
fn erf(x: f32) -> f32 {
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let poly = t
        * (0.254_829_6
            + t * (-0.284_496_74 + t * (1.421_413_7 + t * (-1.453_152_1 + t * 1.061_405_4))));
    (1.0 - poly * (-x * x).exp()).copysign(x)
}

/// The inverse error function on (−1, 1), single-precision rational approximation of Giles
/// (2012), "Approximating the erfinv function" (relative error below 4·10⁻⁷ where it matters).
fn erf_inv(x: f32) -> f32 {
    let mut w = -((1.0 - x) * (1.0 + x)).max(f32::MIN_POSITIVE).ln();
    let p = if w < 5.0 {
        w -= 2.5;
        [
            3.432_739_4e-7,
            -3.523_387_7e-6,
            -4.391_506_5e-6,
            2.185_808_7e-4,
            -1.253_725e-3,
            -4.177_681_6e-3,
            2.466_407_3e-1,
            1.501_409_4,
        ]
        .iter()
        .fold(2.810_226_4e-8, |p, &c| c + p * w)
    } else {
        w = w.sqrt() - 3.0;
        [
            1.009_505_6e-4,
            1.349_343_2e-3,
            -3.673_428_4e-3,
            5.739_507_7e-3,
            -7.622_461e-3,
            9.438_870_5e-3,
            1.001_674,
            2.832_976_8,
        ]
        .iter()
        .fold(-2.002_142_6e-4, |p, &c| c + p * w)
    };
    p * x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Stratified points through the warp: their histogram matches the filter's normalised
    /// density (χ²-style: every bin within 1 % of its expected share, with 2^20 points) and
    /// their variance the filter's (tent r²/6; Gaussian σ² less the cut tails' 0.107 %).
    #[test]
    fn offsets_follow_the_filter_density() {
        let n = 1 << 20;
        let cases = [
            (PixelFilter::Tent { radius: 1.5 }, 1.5f32),
            (PixelFilter::Gaussian { stddev: 0.5 }, 2.0),
        ];
        let density = |filter: &PixelFilter, x: f32| match filter {
            PixelFilter::Tent { radius } => (1.0 - x.abs() / radius).max(0.0),
            _ => (-x * x / (2.0 * 0.25)).exp(),
        };
        for (filter, radius) in cases {
            let bins = 32;
            let mut hist = vec![0u32; bins];
            let mut var = 0.0f64;
            for i in 0..n {
                let u = (i as f32 + 0.5) / n as f32;
                let x = filter_offset(
                    &filter,
                    Vec2::new(u, 0.5),
                    Vec2::splat(-9.0),
                    Vec2::splat(9.0),
                )
                .x;
                assert!(x.abs() <= radius + 1e-4, "{filter:?}: {x}");
                let b = (((x + radius) / (2.0 * radius)) * bins as f32) as usize;
                hist[b.min(bins - 1)] += 1;
                var += (x as f64).powi(2);
            }
            // Expected shares by midpoint integration of the density over each bin.
            let fine = 64;
            let share: Vec<f64> = (0..bins)
                .map(|b| {
                    (0..fine)
                        .map(|k| {
                            let x = -radius
                                + 2.0 * radius * (b as f32 + (k as f32 + 0.5) / fine as f32)
                                    / bins as f32;
                            density(&filter, x) as f64
                        })
                        .sum::<f64>()
                })
                .collect();
            let total: f64 = share.iter().sum();
            for (b, (&h, s)) in hist.iter().zip(&share).enumerate() {
                let expected = s / total * n as f64;
                if expected > 1000.0 {
                    let rel = (h as f64 / expected - 1.0).abs();
                    assert!(rel < 0.01, "{filter:?} bin {b}: {h} vs {expected:.0}");
                }
            }
            let var = var / n as f64;
            let want = match filter {
                PixelFilter::Tent { radius } => (radius * radius / 6.0) as f64,
                _ => 0.25 * (1.0 - 0.001_07),
            };
            assert!(
                (var / want - 1.0).abs() < 2e-3,
                "{filter:?}: {var} vs {want}"
            );
        }
    }

    #[test]
    fn box_is_the_pixel() {
        let o = filter_offset(
            &PixelFilter::Box,
            Vec2::new(0.25, 0.75),
            Vec2::splat(-0.5),
            Vec2::splat(0.5),
        );
        assert_eq!(o, Vec2::new(-0.25, 0.25));
    }

    /// At the film's edge the offsets stay on the image and follow the filter's density
    /// there, renormalised: mass beyond the edge is not folded back onto the edge pixel.
    #[test]
    fn offsets_stop_at_the_film_edge() {
        let n = 1 << 18;
        for filter in [
            PixelFilter::Tent { radius: 1.0 },
            PixelFilter::Gaussian { stddev: 0.7 },
        ] {
            let (lo, hi) = (-0.5f32, 2.5f32);
            let mut below_zero = 0u32;
            for i in 0..n {
                let u = (i as f32 + 0.5) / n as f32;
                let x = filter_offset(&filter, Vec2::splat(u), Vec2::splat(lo), Vec2::splat(hi)).x;
                assert!((lo..=hi).contains(&x), "{filter:?}: {x}");
                below_zero += (x < 0.0) as u32;
            }
            // The share of the kept mass on [lo, 0): integrate the density numerically.
            let density = |x: f32| match filter {
                PixelFilter::Tent { .. } => (1.0 - x.abs()).max(0.0),
                _ => (-x * x / (2.0 * 0.49)).exp(),
            };
            let m = 100_000;
            let mass = |a: f32, b: f32| {
                (0..m)
                    .map(|k| density(a + (b - a) * (k as f32 + 0.5) / m as f32) as f64)
                    .sum::<f64>()
                    * (b - a) as f64
                    / m as f64
            };
            let want = mass(lo, 0.0) / mass(lo, hi.min(2.8));
            let got = below_zero as f64 / n as f64;
            assert!((got - want).abs() < 2e-3, "{filter:?}: {got} vs {want}");
        }
    }
}
