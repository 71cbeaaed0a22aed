//! A branch-free `exp` for filter weights.
//!
//! `f32::exp` is a libm call that the compiler cannot vectorise; filter weights are evaluated
//! tens of millions of times per frame, and a relative error of a few 1e-6 in a weight is far
//! below the noise being filtered. This version is plain arithmetic on `f32`/`i32`, so loops that
//! call it auto-vectorise.

/// Below this exponent [`exp_neg`] returns exactly 0 (e^-20 ≈ 2e-9).
pub const EXP_CUTOFF: f32 = -20.0;

/// `exp(x)` for `EXP_CUTOFF <= x <= 0` with relative error below 1e-5; exactly 0 below the
/// cutoff (and for -inf or NaN), exactly 1 at 0.
///
/// Why the cutoff: a weight of 2e-9 changes no filter result, while weights of 1e-38 and their
/// products (w², w·colour) are denormal floats, on which x86 arithmetic is ~100× slower; exact
/// zeros keep every later product in the normal range.
#[inline(always)]
#[allow(clippy::manual_clamp)] // clamp would keep NaN; max/min map it to the cutoff
pub fn exp_neg(x: f32) -> f32 {
    // Clamp keeps the exponent field valid; the select below zeroes what was clamped.
    let keep = (x >= EXP_CUTOFF) as u32 as f32;
    // max/min (not clamp) so NaN becomes the cutoff, then zeroed.
    let x = x.max(EXP_CUTOFF).min(0.0);
    let t = x * std::f32::consts::LOG2_E;
    // Round to nearest with the 1.5·2^23 trick: after the add, the integer sits in the low
    // mantissa bits. Unlike `t as i32` (saturating, scalarised per lane) this is plain float
    // and integer arithmetic that vectorises. f ends up in [-0.5, 0.5].
    const MAGIC: f32 = 12_582_912.0;
    let r = t + MAGIC;
    let f = (t - (r - MAGIC)) * std::f32::consts::LN_2;
    // e^f, |f| <= 0.347: degree-5 Taylor, error ~ f^6/720 < 2.5e-6.
    let p = 1.0 + f * (1.0 + f * (0.5 + f * (1.0 / 6.0 + f * (1.0 / 24.0 + f * (1.0 / 120.0)))));
    // 2^i from the integer in r's low bits: (i + 127) << 23 is the exponent field.
    let i_plus_bias = r.to_bits().wrapping_sub(MAGIC.to_bits()).wrapping_add(127);
    let scale = f32::from_bits(i_plus_bias << 23);
    p * scale * keep
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_std_exp() {
        let mut worst = 0.0f64;
        for k in 0..=200_000 {
            let x = -(k as f32) * 20.0 / 200_000.0;
            let want = (x as f64).exp();
            let got = exp_neg(x) as f64;
            worst = worst.max(((got - want) / want).abs());
        }
        assert!(worst < 1e-5, "worst relative error {worst}");
        assert_eq!(exp_neg(0.0), 1.0);
        assert_eq!(exp_neg(-20.01), 0.0);
        assert_eq!(exp_neg(f32::NEG_INFINITY), 0.0);
        assert_eq!(exp_neg(f32::NAN), 0.0);
        assert_eq!(exp_neg(-1e30), 0.0);
    }
}
