//! Symmetric mean absolute percentage error.

use super::{MetricError, Pair};
use crate::Image;

/// ε in SMAPE's denominator, so that two black values score 0 rather than 0/0.
pub const SMAPE_EPSILON: f64 = 1e-2;

/// Mean over valid pixels and all channels of `|x − r| / (|x| + |r| + ε)`,
/// ε = [`SMAPE_EPSILON`], on the linear values. In [0, 1); no factor 2, no percent.
pub fn smape(reference: &Image, test: &Image) -> Result<f64, MetricError> {
    Ok(smape_pair(&Pair::new(reference, test)?))
}

pub(crate) fn smape_pair(pair: &Pair) -> f64 {
    pair.channel_mean(|r, x| (x - r).abs() / (x.abs() + r.abs() + SMAPE_EPSILON))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed() {
        let r = Image::from_vec(2, 2, 1, vec![0.0, 1.0, 2.0, 3.0]);
        let t = Image::from_vec(2, 2, 1, vec![1.0, 1.0, 1.0, 1.0]);
        let expected = (1.0 / 1.01 + 0.0 + 1.0 / 3.01 + 2.0 / 4.01) / 4.0;
        let got = smape(&r, &t).unwrap();
        assert!((got - expected).abs() < 1e-12, "{got}");
        // Symmetric in its arguments, and bounded by 1 even for a sign flip.
        assert!((smape(&t, &r).unwrap() - expected).abs() < 1e-12);
        let a = Image::from_vec(1, 1, 1, vec![-100.0]);
        let b = Image::from_vec(1, 1, 1, vec![100.0]);
        let s = smape(&a, &b).unwrap();
        assert!(s < 1.0 && s > 0.9999, "{s}");
    }
}
