//! Piecewise-linear spectra given as (wavelength, value) samples: Mitsuba's `<spectrum
//! value="λ:v, …">` and the measured conductor presets.

use crate::data::conductors::{CONDUCTORS, IOR_MIN, IOR_SAMPLES, IOR_STEP};

/// A spectrum through (wavelength, value) samples, linear between them.
#[derive(Clone, Debug, PartialEq)]
pub struct Tabulated {
    lambda: Vec<f32>,
    value: Vec<f32>,
    /// Value outside the samples' range: `None` is 0 (Mitsuba's irregular spectra), `Some` holds
    /// the end values (measured data, which end where the measurement did).
    clamp_ends: bool,
}

impl Tabulated {
    /// The spectrum through `pairs` (wavelengths in nm, strictly increasing; at least one
    /// pair), zero outside their range as Mitsuba's irregular spectra are. `None` if the
    /// wavelengths do not increase or a value is not finite.
    pub fn new(pairs: &[(f32, f32)]) -> Option<Self> {
        if pairs.is_empty()
            || pairs.windows(2).any(|w| w[1].0 <= w[0].0)
            || pairs.iter().any(|p| !p.0.is_finite() || !p.1.is_finite())
        {
            return None;
        }
        Some(Self {
            lambda: pairs.iter().map(|p| p.0).collect(),
            value: pairs.iter().map(|p| p.1).collect(),
            clamp_ends: false,
        })
    }

    /// A regularly sampled measurement, held constant beyond its ends.
    fn regular(first: f32, step: f32, values: &[f32]) -> Self {
        Self {
            lambda: (0..values.len()).map(|i| first + step * i as f32).collect(),
            value: values.to_vec(),
            clamp_ends: true,
        }
    }

    /// The value at `lambda` nm.
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        let n = self.lambda.len();
        if lambda <= self.lambda[0] || lambda >= self.lambda[n - 1] {
            let end = if lambda <= self.lambda[0] { 0 } else { n - 1 };
            let inside = lambda == self.lambda[end];
            return if self.clamp_ends || inside {
                self.value[end]
            } else {
                0.0
            };
        }
        let i = self.lambda.partition_point(|&l| l <= lambda) - 1;
        let t = (lambda - self.lambda[i]) / (self.lambda[i + 1] - self.lambda[i]);
        self.value[i] * (1.0 - t) + self.value[i + 1] * t
    }
}

/// The measured (η, k) spectra of Mitsuba's conductor preset `name` (e.g. "Au", "Cu_palik").
pub fn conductor(name: &str) -> Option<(Tabulated, Tabulated)> {
    let (_, eta, k) = CONDUCTORS.iter().find(|(n, _, _)| *n == name)?;
    debug_assert_eq!(eta.len(), IOR_SAMPLES);
    Some((
        Tabulated::regular(IOR_MIN, IOR_STEP, eta),
        Tabulated::regular(IOR_MIN, IOR_STEP, k),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_between_samples_zero_outside() {
        let s = Tabulated::new(&[(400.0, 0.2), (500.0, 0.6), (600.0, 0.4)]).unwrap();
        assert_eq!(s.eval(400.0), 0.2);
        assert!((s.eval(450.0) - 0.4).abs() < 1e-6);
        assert!((s.eval(550.0) - 0.5).abs() < 1e-6);
        assert_eq!(s.eval(600.0), 0.4);
        assert_eq!(s.eval(399.0), 0.0);
        assert_eq!(s.eval(700.0), 0.0);
        assert!(Tabulated::new(&[(500.0, 1.0), (400.0, 1.0)]).is_none());
        assert!(Tabulated::new(&[]).is_none());
    }

    #[test]
    fn gold_is_measured_gold() {
        let (eta, k) = conductor("Au").unwrap();
        // Gold: low η and high k in the red (reflective), η ≈ 1.4 in the blue (absorbing).
        assert!(eta.eval(650.0) < 0.3 && k.eval(650.0) > 3.0);
        assert!(eta.eval(450.0) > 1.2);
        assert!(conductor("unobtainium").is_none());
    }
}
