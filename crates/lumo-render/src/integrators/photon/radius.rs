//! The gather radius of pass `k`: Knaus & Zwicker's probabilistic-PPM schedule (2011),
//! `r_{k+1}² = r_k² · (k + 1 + α) / (k + 2)`, i.e. `r_k² = r_0² · Π_{j=1..k} (j + α)/(j + 1)`,
//! which falls like `k^(α−1)`.
//!
//! Why a global per-pass radius rather than SPPM's per-pixel statistics (Hachisuka & Jensen
//! 2009, whose α it shares): both of lumo's outputs *average samples* — `lumo render` takes
//! the mean of its passes, the viewer `Σ w·c / Σ w` of the stream — and SPPM's estimate lives
//! in per-hit-point state (photon count N, flux τ, radius) that is updated in place and
//! cannot be expressed as independent samples to average. With a radius that depends only on
//! the pass index, every camera sample of pass `k` is a self-contained estimate (given the
//! map), the stream stays a stream, and the average converges: the bias of pass `k` is
//! `O(r_k²) = O(k^(α−1))` → 0, and its variance is `O(1 / (n_k · r_k²))` for `n_k ≥ n_1`
//! photon paths in the map, at most `O(k^(1−α))`, so the variance of the mean of `K` passes is
//! `O(K^(−α))` → 0 (K&Z §4), even where the map is reset to bound memory.

/// The radius schedule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadiusSchedule {
    /// Radius of pass 0 (world units).
    pub initial: f32,
    /// α in (0, 1): how much of the radius reduction a pass keeps (2/3 is the usual choice).
    pub alpha: f32,
}

impl RadiusSchedule {
    /// Squared radius of pass `k` (k = 0, 1, …). Computed from the product in O(k) in f64
    /// (no gamma function in std); callers ask once per pass.
    pub fn radius_sq(&self, k: u32) -> f32 {
        let mut r2 = (self.initial as f64).powi(2);
        let a = self.alpha as f64;
        for j in 1..=k as u64 {
            r2 *= (j as f64 + a) / (j as f64 + 1.0);
        }
        r2 as f32
    }

    /// Radius of pass `k`.
    pub fn radius(&self, k: u32) -> f32 {
        self.radius_sq(k).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radius_falls_like_k_to_alpha_minus_one_and_passes_still_see_more_photons() {
        let s = RadiusSchedule {
            initial: 0.1,
            alpha: 2.0 / 3.0,
        };
        assert_eq!(s.radius(0), 0.1);
        let mut prev = f32::INFINITY;
        for k in 0..2000 {
            let r2 = s.radius_sq(k);
            assert!(r2 < prev, "not decreasing at {k}");
            prev = r2;
        }
        // One step is K&Z's update.
        let (a, b) = (s.radius_sq(9) as f64, s.radius_sq(10) as f64);
        assert!((b / a - (10.0 + 2.0 / 3.0) / 11.0).abs() < 1e-6);
        // r_k² · k^(1−α) tends to a constant: the ratio at k and 4k approaches 1.
        let scaled = |k: u32| s.radius_sq(k) as f64 * (k as f64).powf(1.0 / 3.0);
        let ratio = scaled(4000) / scaled(1000);
        assert!((ratio - 1.0).abs() < 1e-3, "ratio {ratio}");
        // Bias → 0 (r² → 0) while the photons in a disc of one pass's map, ∝ k·r_k², grow.
        assert!(s.radius_sq(100_000) < 0.05 * s.radius_sq(0));
        let seen = |k: u32| (k + 1) as f64 * s.radius_sq(k) as f64;
        assert!(seen(10_000) > 10.0 * seen(10));
        // α = 1 keeps the radius (plain photon mapping).
        let fixed = RadiusSchedule {
            initial: 0.1,
            alpha: 1.0,
        };
        assert_eq!(fixed.radius_sq(50), fixed.radius_sq(0));
    }
}
