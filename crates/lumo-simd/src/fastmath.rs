//! A branch-free `exp` for filter weights, and a branch-free `ln` for the light search.
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

/// High and low parts of ln 2 for [`ln_normal`]: `e · LN2_HI` is exact for every exponent of an
/// `f32` (the high part has its low 9 mantissa bits clear), the low part carries the rest.
const LN2_HI: f32 = 0.693_145_75;
const LN2_LO: f32 = 1.428_606_8e-6;

/// Natural logarithm of a positive, finite, normal `x` (≥ 2^-126), within 2e-7 absolute or
/// 2 ulp of the exact value; garbage for other inputs, which the caller must exclude.
///
/// Why: the light search takes a logarithm of every pixel, and `f32::ln` is a libm call the
/// compiler cannot vectorise (it was a third of the search's time); this is plain `f32`/`i32`
/// arithmetic, so a loop over pixels that calls it auto-vectorises.
#[inline(always)]
pub fn ln_normal(x: f32) -> f32 {
    // x = 2^e · m with m in [√½, √2): subtracting √½'s bits puts the exponent that makes the
    // mantissa straddle 1 in the bits above the mantissa (an arithmetic shift floors it).
    const SQRT_HALF_BITS: i32 = 0x3f35_04f3;
    let bits = x.to_bits() as i32;
    let e = bits.wrapping_sub(SQRT_HALF_BITS) >> 23;
    let m = f32::from_bits(bits.wrapping_sub(e << 23) as u32);
    // ln m = 2 atanh(s), s = (m − 1)/(m + 1), |s| ≤ 0.1716: the odd series to s⁹ leaves an
    // error below 1e-9.
    let f = m - 1.0;
    let s = f / (2.0 + f);
    let z = s * s;
    let series =
        2.0 * s + 2.0 * s * z * (1.0 / 3.0 + z * (0.2 + z * (1.0 / 7.0 + z * (1.0 / 9.0))));
    let e = e as f32;
    e * LN2_HI + (series + e * LN2_LO)
}

/// The polynomial of [`exp2_cut`] and its vector copies: 2^f ≈ 1 + f·(C1 + f·(C2 + f·(C3 +
/// f·C4))) for |f| ≤ 1/2, fitted for the least maximum relative error with the constant term
/// kept at exactly 1 (so equal pixels weigh exactly their B3 weight): 2.9e-6 evaluated in f32,
/// below the degree-5 Taylor polynomial it replaced (3.2e-6) with one fused multiply-add
/// less per weight (of ≈ 26 in the À-Trous pair kernel).
const C1: f32 = 0.693_124_2;
const C2: f32 = 0.240_240_99;
const C3: f32 = 0.055_906_24;
const C4: f32 = 0.009_582_787;

/// `2^t` for `cut <= t <= 0` with relative error below 1e-5, exactly 0 for `t < cut` or NaN.
/// `cut` must be ≥ -126 (so the result and the clamp stay normal floats).
///
/// The À-Trous kernel's variant of [`exp_neg`]: its exponents are built in log2 units, which
/// saves a multiply per weight, and the caller picks the cutoff per tap.
///
/// `FMA`: evaluate the polynomial with fused multiply-adds (only where the CPU has them: on
/// other targets `mul_add` is a slow library call); results then differ in the last bits.
#[inline(always)]
pub fn exp2_cut<const FMA: bool>(t: f32, cut: f32) -> f32 {
    // `t > cut` (not `max`) so that NaN also lands on the cutoff: one `maxps`, no NaN fix-up.
    let tc = if t > cut { t } else { cut };
    const MAGIC: f32 = 12_582_912.0;
    let r = tc + MAGIC;
    let f = tc - (r - MAGIC);
    let p = mul_add::<FMA>(f, C4, C3);
    let p = mul_add::<FMA>(f, p, C2);
    let p = mul_add::<FMA>(f, p, C1);
    let p = mul_add::<FMA>(f, p, 1.0);
    let bias = 127u32.wrapping_sub(MAGIC.to_bits());
    let scale = f32::from_bits(r.to_bits().wrapping_add(bias) << 23);
    if t >= cut {
        p * scale
    } else {
        0.0
    }
}

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// [`exp2_cut`]`::<true>` of `N` 8-lane vectors with AVX2 + FMA intrinsics, bit for bit the
/// same. Why intrinsics: the compiler scalarised the portable version mapped over an 8-float
/// array (measured 83 % of the À-Trous time on an AVX2-only CPU). Why several: each step is
/// done for all `N` before the next, so `N` independent dependency chains interleave
/// (the polynomial alone is four dependent fused multiply-adds).
///
/// # Safety
/// Callable only where AVX2 and FMA exist (from code compiled with them, or after detecting
/// them, e.g. [`crate::Isa::detect`] `>= Isa::Avx2`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub fn exp2_cut_avx2_xn<const N: usize>(t: [__m256; N], cut: [__m256; N]) -> [__m256; N] {
    let tc: [__m256; N] = std::array::from_fn(|i| _mm256_max_ps(t[i], cut[i]));
    // Round to nearest even, as the scalar version's magic-number addition does, in one
    // instruction instead of two dependent ones.
    let r = tc.map(|x| _mm256_round_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(x));
    let f: [__m256; N] = std::array::from_fn(|i| _mm256_sub_ps(tc[i], r[i]));
    let mut p = f.map(|f| _mm256_fmadd_ps(f, _mm256_set1_ps(C4), _mm256_set1_ps(C3)));
    for c in [C2, C1, 1.0] {
        let c = _mm256_set1_ps(c);
        p = std::array::from_fn(|i| _mm256_fmadd_ps(f[i], p[i], c));
    }
    let bias = _mm256_set1_epi32(127);
    std::array::from_fn(|i| {
        let e = _mm256_slli_epi32::<23>(_mm256_add_epi32(_mm256_cvtps_epi32(r[i]), bias));
        let w = _mm256_mul_ps(p[i], _mm256_castsi256_ps(e));
        _mm256_and_ps(w, _mm256_cmp_ps::<_CMP_GE_OQ>(t[i], cut[i]))
    })
}

/// [`exp2_cut`] of `N` 16-lane vectors with AVX-512's round-to-integer and scale
/// instructions: the same polynomial on the same reduced argument, 6 instructions fewer than
/// the portable bit manipulation; exactly 0 below `cut` and for NaN, equal to the scalar one
/// within 1e-6. Interleaved as [`exp2_cut_avx2_xn`].
///
/// # Safety
/// Callable only where AVX-512 F exists (from code compiled with it, or after detecting it).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub fn exp2_cut_avx512_xn<const N: usize>(t: [__m512; N], cut: [__m512; N]) -> [__m512; N] {
    let keep: [__mmask16; N] =
        std::array::from_fn(|i| _mm512_cmp_ps_mask::<_CMP_GE_OQ>(t[i], cut[i]));
    let r = t.map(|x| _mm512_roundscale_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(x));
    let f: [__m512; N] = std::array::from_fn(|i| _mm512_sub_ps(t[i], r[i]));
    let mut p = f.map(|f| _mm512_fmadd_ps(f, _mm512_set1_ps(C4), _mm512_set1_ps(C3)));
    for c in [C2, C1, 1.0] {
        let c = _mm512_set1_ps(c);
        p = std::array::from_fn(|i| _mm512_fmadd_ps(f[i], p[i], c));
    }
    std::array::from_fn(|i| _mm512_maskz_scalef_ps(keep[i], p[i], r[i]))
}

/// `a·b + c`, fused (one rounding) when `FMA`, else two roundings.
#[inline(always)]
pub fn mul_add<const FMA: bool>(a: f32, b: f32, c: f32) -> f32 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ln_normal_matches_std_ln() {
        // Every 97th positive normal float (every exponent, mantissas spread), and the ends.
        let check = |x: f32| {
            let (want, got) = ((x as f64).ln(), ln_normal(x) as f64);
            let ulp = (want as f32).abs() as f64 * f32::EPSILON as f64;
            let err = (got - want).abs();
            assert!(
                err <= 2e-7 || err <= 2.0 * ulp,
                "ln({x:e}) = {got}, not {want}"
            );
        };
        let mut bits = f32::MIN_POSITIVE.to_bits();
        while bits < f32::MAX.to_bits() {
            check(f32::from_bits(bits));
            bits += 97;
        }
        for x in [
            f32::MIN_POSITIVE,
            0.5,
            1.0,
            2.0,
            std::f32::consts::E,
            1e-8,
            f32::MAX,
        ] {
            check(x);
        }
        assert_eq!(ln_normal(1.0), 0.0);
    }

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

    #[test]
    fn exp2_cut_matches_std_exp2() {
        let cut = -40.0;
        let mut worst = 0.0f64;
        for k in 0..=400_000 {
            let t = -(k as f32) * 40.0 / 400_000.0;
            let want = (t as f64).exp2();
            for got in [exp2_cut::<false>(t, cut), exp2_cut::<true>(t, cut)] {
                worst = worst.max(((got as f64 - want) / want).abs());
            }
        }
        assert!(worst < 1e-5, "worst relative error {worst}");
        assert_eq!(exp2_cut::<false>(0.0, cut), 1.0);
        assert_eq!(exp2_cut::<false>(-40.001, cut), 0.0);
        assert_eq!(exp2_cut::<false>(f32::NEG_INFINITY, cut), 0.0);
        assert_eq!(exp2_cut::<false>(f32::NAN, cut), 0.0);
    }

    /// The SIMD copies give what the scalar one gives (the AVX2 one bit for bit), including
    /// at the cutoff and for NaN and infinities.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn simd_exp2_cut_matches_scalar() {
        let cut = -37.5;
        let mut ts: Vec<f32> = (0..=80_000)
            .map(|k| -(k as f32) * 40.0 / 80_000.0)
            .collect();
        ts.extend([cut, cut - 1e-5, f32::NAN, f32::NEG_INFINITY, 0.0, -0.0]);
        ts.resize(ts.len().next_multiple_of(64), 0.0);
        let avx2 = is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma");
        let avx512 = avx2 && is_x86_feature_detected!("avx512f");
        for c in ts.chunks(64) {
            let want: Vec<f32> = c.iter().map(|&t| exp2_cut::<true>(t, cut)).collect();
            let mut got = [0.0f32; 64];
            if avx2 {
                // SAFETY: AVX2 and FMA were detected above; 4·8 floats read and written
                // per half of the 64-float chunk.
                unsafe {
                    for h in 0..2 {
                        let t =
                            std::array::from_fn(|i| _mm256_loadu_ps(c[32 * h + 8 * i..].as_ptr()));
                        let v = exp2_cut_avx2_xn(t, [_mm256_set1_ps(cut); 4]);
                        for (i, v) in v.into_iter().enumerate() {
                            _mm256_storeu_ps(got[32 * h + 8 * i..].as_mut_ptr(), v);
                        }
                    }
                }
                for (g, w) in got.iter().zip(&want) {
                    assert_eq!(g.to_bits(), w.to_bits());
                }
            }
            if avx512 {
                // SAFETY: AVX-512F was detected above; 4·16 floats read and written.
                unsafe {
                    let t = std::array::from_fn(|i| _mm512_loadu_ps(c[16 * i..].as_ptr()));
                    let v = exp2_cut_avx512_xn(t, [_mm512_set1_ps(cut); 4]);
                    for (i, v) in v.into_iter().enumerate() {
                        _mm512_storeu_ps(got[16 * i..].as_mut_ptr(), v);
                    }
                }
                for (g, w) in got.iter().zip(&want) {
                    assert!((g - w).abs() <= 1e-6 * w, "{g} vs {w}");
                }
            }
        }
    }
}
