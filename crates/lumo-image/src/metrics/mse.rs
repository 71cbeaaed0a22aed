//! Mean squared error of the linear values.

use super::{MetricError, Pair};
use crate::Image;

/// Mean over valid pixels and all channels of `(test − reference)²`, on the linear values.
pub fn mse(reference: &Image, test: &Image) -> Result<f64, MetricError> {
    Ok(mse_pair(&Pair::new(reference, test)?))
}

pub(crate) fn mse_pair(pair: &Pair) -> f64 {
    pair.channel_mean(|r, t| (t - r) * (t - r))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed() {
        let r = Image::from_vec(2, 2, 1, vec![0.0, 1.0, 2.0, 3.0]);
        let t = Image::from_vec(2, 2, 1, vec![1.0, 1.0, 1.0, 1.0]);
        // Squared differences 1, 0, 1, 4.
        assert_eq!(mse(&r, &t).unwrap(), 1.5);
        // Symmetric, and every channel counts.
        assert_eq!(mse(&t, &r).unwrap(), 1.5);
        let r3 = Image::from_vec(1, 1, 3, vec![0.0, 0.0, 0.0]);
        let t3 = Image::from_vec(1, 1, 3, vec![3.0, 0.0, 0.0]);
        assert_eq!(mse(&r3, &t3).unwrap(), 3.0);
    }

    #[test]
    fn excluded_pixels_leave_the_mean() {
        let r = Image::from_vec(3, 1, 1, vec![0.0, 0.0, 0.0]);
        let t = Image::from_vec(3, 1, 1, vec![2.0, f32::NAN, 4.0]);
        assert_eq!(mse(&r, &t).unwrap(), 10.0);
    }
}
