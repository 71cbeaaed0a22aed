//! Relative mean squared error.

use super::{MetricError, Pair};
use crate::Image;

/// ε in relMSE's denominator: keeps black reference pixels from dominating (or dividing by 0).
pub const RELMSE_EPSILON: f64 = 1e-2;

/// Mean over valid pixels and all channels of `(x − r)² / (r² + ε)`, ε = [`RELMSE_EPSILON`],
/// on the linear values (`x` test, `r` reference).
pub fn relmse(reference: &Image, test: &Image) -> Result<f64, MetricError> {
    Ok(relmse_pair(&Pair::new(reference, test)?))
}

pub(crate) fn relmse_pair(pair: &Pair) -> f64 {
    pair.channel_mean(relmse_value)
}

/// relMSE of one reference value `r` and test value `x`.
#[inline]
pub(crate) fn relmse_value(r: f64, x: f64) -> f64 {
    (x - r) * (x - r) / (r * r + RELMSE_EPSILON)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed() {
        let r = Image::from_vec(2, 2, 1, vec![0.0, 1.0, 2.0, 3.0]);
        let t = Image::from_vec(2, 2, 1, vec![1.0, 1.0, 1.0, 1.0]);
        // (1/0.01 + 0 + 1/4.01 + 4/9.01) / 4
        let expected = (100.0 + 0.0 + 1.0 / 4.01 + 4.0 / 9.01) / 4.0;
        assert!((relmse(&r, &t).unwrap() - expected).abs() < 1e-12);
        assert!((expected - 25.173_332).abs() < 1e-5);
        // Not symmetric: the reference is the denominator.
        assert!((relmse(&t, &r).unwrap() - (1.0 + 0.0 + 1.0 + 4.0) / 4.0 / 1.01).abs() < 1e-12);
    }
}
