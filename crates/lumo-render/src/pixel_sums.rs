//! A pixel's samples summed exactly: the canonical reduction of every render.
//!
//! Floating-point addition is not associative, so a render split into chunks of samples (a
//! Ray cluster's tasks, `Scene.render(passes=…)` in Python) and added back would differ in the
//! last bits from the same render done in one go, and differently for every split. Instead each
//! sample's contribution is rounded once to a 128-bit fixed-point number with 64 fractional bits
//! (a resolution of 5.4e-20, far below anything an f32 image can show) and sums are integer
//! sums, which are associative and commutative: any split of a pixel's samples into chunks,
//! added in any order, gives the same sums, and the single-process renderer is the case of one
//! chunk. Only [`PixelSums::estimate`] turns sums into floating-point means.
//!
//! Bounds: a sample's value is clamped to ±2^40 (1.1e12; the path tracer drops non-finite
//! values already), so 2^20 samples (`lumo render --spp`'s maximum) sum to under 2^124 and
//! never overflow. Squared luminances (for the variance) use 40 fractional bits and add with
//! saturation, which is still associative because they are never negative.

use glam::Vec3;
use lumo_image::luminance;

use crate::integrators::path::{FirstHit, PathRadiance};
use crate::settings::PixelEstimate;

/// Fractional bits of a value's fixed-point form.
const FRAC: i32 = 64;
/// Fractional bits of a squared luminance's fixed-point form: fewer, so that the square of the
/// largest value (2^80) still fits.
const FRAC_SQ: i32 = 40;
/// Largest magnitude of one sample's value.
const MAX_VALUE: f64 = (1u64 << 40) as f64;

/// `x · 2^frac` as an integer, truncated towards zero; magnitudes beyond 2^126 saturate and NaN
/// is 0. Written with the bits of `x` rather than `as i128`, which is a library call.
#[inline]
fn fixed(x: f64, frac: i32) -> i128 {
    let bits = x.to_bits();
    let biased = ((bits >> 52) & 0x7ff) as i32;
    if biased == 0 {
        return 0; // zero or subnormal: below 2^-1022, nothing at this resolution
    }
    if biased == 0x7ff && bits & ((1 << 52) - 1) != 0 {
        return 0; // NaN
    }
    let mantissa = ((bits & ((1 << 52) - 1)) | (1 << 52)) as i128;
    let shift = biased - 1075 + frac;
    let magnitude = if shift >= 74 {
        i128::MAX // would pass 2^126 (and infinity)
    } else if shift >= 0 {
        mantissa << shift
    } else if shift > -53 {
        mantissa >> -shift
    } else {
        0
    };
    if bits >> 63 == 1 {
        -magnitude
    } else {
        magnitude
    }
}

/// A fixed-point sum as f64: rounded once, then scaled by a power of two (exact).
#[inline]
fn unfixed(sum: i128, frac: i32) -> f64 {
    sum as f64 * (-frac as f64).exp2()
}

#[inline]
fn fixed3(v: Vec3) -> [i128; 3] {
    // Written out rather than `array::map`, whose inlining (its `try_map`) came and went with
    // how the crate was cut into codegen units: 3 % of a path-traced render's instructions.
    let f = |c: f32| fixed((c as f64).clamp(-MAX_VALUE, MAX_VALUE), FRAC);
    [f(v.x), f(v.y), f(v.z)]
}

#[inline]
fn add3(a: &mut [i128; 3], b: [i128; 3]) {
    for (a, b) in a.iter_mut().zip(b) {
        *a += b;
    }
}

#[inline]
fn mean3(sum: &[i128; 3], n: f64) -> Vec3 {
    Vec3::from_array(sum.map(|s| (unfixed(s, FRAC) / n) as f32))
}

/// The exact sums of some of a pixel's samples (see the module's doc): what a chunk of a
/// render returns and what chunks add up to.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelSums {
    /// Samples summed.
    pub count: u32,
    /// Rays traced by them.
    pub rays: u64,
    /// The pixel-centre sample's first hit, where sample 0 is among the samples summed.
    pub first_hit: Option<FirstHit>,
    direct: [i128; 3],
    indirect: [i128; 3],
    albedo: [i128; 3],
    emitted: [i128; 3],
    luminance: i128,
    luminance_sq: i128,
}

impl PixelSums {
    /// No samples yet, with the pixel-centre sample's first hit where it will be among them.
    pub fn new(first_hit: Option<FirstHit>) -> PixelSums {
        PixelSums {
            first_hit,
            ..PixelSums::default()
        }
    }

    /// Adds one sample's radiance.
    #[inline]
    pub fn add_sample(&mut self, r: &PathRadiance) {
        self.count += 1;
        self.rays += r.rays as u64;
        add3(&mut self.direct, fixed3(r.direct));
        add3(&mut self.indirect, fixed3(r.indirect));
        add3(&mut self.albedo, fixed3(r.albedo));
        add3(&mut self.emitted, fixed3(r.emitted));
        let l = (luminance((r.direct + r.indirect).into()) as f64).clamp(-MAX_VALUE, MAX_VALUE);
        self.luminance += fixed(l, FRAC);
        // The square of an f32 is exact in f64 (48 significant bits) and never negative.
        self.luminance_sq = self.luminance_sq.saturating_add(fixed(l * l, FRAC_SQ));
    }

    /// Adds another chunk's sums: the result does not depend on the order of additions.
    pub fn merge(&mut self, other: &PixelSums) {
        self.count += other.count;
        self.rays += other.rays;
        if self.first_hit.is_none() {
            self.first_hit = other.first_hit;
        }
        add3(&mut self.direct, other.direct);
        add3(&mut self.indirect, other.indirect);
        add3(&mut self.albedo, other.albedo);
        add3(&mut self.emitted, other.emitted);
        self.luminance += other.luminance;
        self.luminance_sq = self.luminance_sq.saturating_add(other.luminance_sq);
    }

    /// The pixel's estimate from its sums: means, and the sample variance of the luminance
    /// (0 with one sample). The first hit's albedo is the mean of the samples' albedo.
    pub fn estimate(&self) -> PixelEstimate {
        let n = self.count.max(1) as f64;
        let mut first_hit = self.first_hit.unwrap_or_default();
        first_hit.albedo = mean3(&self.albedo, n);
        let variance = if self.count > 1 {
            let sum = unfixed(self.luminance, FRAC);
            let m2 = unfixed(self.luminance_sq, FRAC_SQ) - sum * sum / n;
            (m2.max(0.0) / (n - 1.0)) as f32
        } else {
            0.0
        };
        PixelEstimate {
            direct: mean3(&self.direct, n),
            indirect: mean3(&self.indirect, n),
            luminance_variance: variance,
            first_hit,
            emitted: mean3(&self.emitted, n),
            rays: self.rays,
        }
    }

    /// Bytes of [`PixelSums::to_bytes`]'s record.
    pub const RECORD_BYTES: usize = 4 + 8 + 1 + 13 * 4 + 14 * 16;

    /// Appends the sums as a fixed-size little-endian record (for shipping chunks between
    /// processes; [`PixelSums::from_bytes`] reads it back bit for bit).
    pub fn to_bytes(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.count.to_le_bytes());
        out.extend_from_slice(&self.rays.to_le_bytes());
        out.push(self.first_hit.is_some() as u8);
        let f = self.first_hit.unwrap_or_default();
        let floats = [f.normal, f.position, f.albedo, f.emitted]
            .into_iter()
            .flat_map(|v| v.to_array())
            .chain([f.depth]);
        for x in floats {
            out.extend_from_slice(&x.to_le_bytes());
        }
        let ints = [self.direct, self.indirect, self.albedo, self.emitted]
            .into_iter()
            .flatten()
            .chain([self.luminance, self.luminance_sq]);
        for x in ints {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }

    /// Reads one record written by [`PixelSums::to_bytes`]; `None` if `b` is not
    /// [`PixelSums::RECORD_BYTES`] long or its flag byte is not 0 or 1.
    pub fn from_bytes(b: &[u8]) -> Option<PixelSums> {
        if b.len() != Self::RECORD_BYTES || b[12] > 1 {
            return None;
        }
        let u32_at = |i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
        let f32_at = |k: usize| f32::from_bits(u32_at(13 + 4 * k));
        let i128_at = |k: usize| {
            let at = 13 + 13 * 4 + 16 * k;
            let mut x = [0u8; 16];
            x.copy_from_slice(&b[at..at + 16]);
            i128::from_le_bytes(x)
        };
        let v3 = |k: usize| Vec3::new(f32_at(k), f32_at(k + 1), f32_at(k + 2));
        let i3 = |k: usize| [i128_at(k), i128_at(k + 1), i128_at(k + 2)];
        let mut rays = [0u8; 8];
        rays.copy_from_slice(&b[4..12]);
        Some(PixelSums {
            count: u32_at(0),
            rays: u64::from_le_bytes(rays),
            first_hit: (b[12] == 1).then(|| FirstHit {
                normal: v3(0),
                position: v3(3),
                albedo: v3(6),
                emitted: v3(9),
                depth: f32_at(12),
            }),
            direct: i3(0),
            indirect: i3(3),
            albedo: i3(6),
            emitted: i3(9),
            luminance: i128_at(12),
            luminance_sq: i128_at(13),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(k: u32) -> PathRadiance {
        // Values spread over many orders of magnitude, where float sums depend on order.
        let s = (k as f32 * 0.618_034).fract();
        PathRadiance {
            direct: Vec3::new(s * 1e4, s * 1e-6, 0.3),
            indirect: Vec3::new(1.0 - s, (k % 7) as f32 * 1e3, s * s),
            rays: k % 5,
            albedo: Vec3::splat(s),
            emitted: Vec3::new(0.0, s, 1e-3),
        }
    }

    fn sums(range: std::ops::Range<u32>) -> PixelSums {
        let mut p = PixelSums::default();
        for k in range {
            p.add_sample(&sample(k));
        }
        p
    }

    #[test]
    fn any_split_in_any_order_gives_the_same_bits() {
        let whole = sums(0..1000);
        for cuts in [[0, 1, 999, 1000], [0, 250, 500, 1000], [0, 333, 334, 1000]] {
            let parts: Vec<PixelSums> = cuts.windows(2).map(|w| sums(w[0]..w[1])).collect();
            for order in [[0, 1, 2], [2, 1, 0], [1, 2, 0]] {
                let mut total = PixelSums::default();
                for i in order {
                    total.merge(&parts[i]);
                }
                total.first_hit = whole.first_hit;
                assert_eq!(total, whole, "cuts {cuts:?} order {order:?}");
            }
        }
    }

    #[test]
    fn means_and_variance_match_a_double_precision_reference() {
        let p = sums(0..1000);
        let e = p.estimate();
        let r: Vec<PathRadiance> = (0..1000).map(sample).collect();
        let mean_d: f64 = r.iter().map(|r| r.direct.x as f64).sum::<f64>() / 1000.0;
        assert!((e.direct.x as f64 - mean_d).abs() <= mean_d * 1e-6);
        let l: Vec<f64> = r
            .iter()
            .map(|r| luminance((r.direct + r.indirect).into()) as f64)
            .collect();
        let m = l.iter().sum::<f64>() / 1000.0;
        let var = l.iter().map(|x| (x - m).powi(2)).sum::<f64>() / 999.0;
        assert!((e.luminance_variance as f64 - var).abs() <= var * 1e-5);
        assert_eq!(e.rays, r.iter().map(|r| r.rays as u64).sum::<u64>());
    }

    #[test]
    fn fixed_point_conversion_is_exact_where_representable() {
        // f32 values (what samples are) down to 2^-40 have no bits below 2^-64.
        for x in [
            1.0,
            -2.5,
            1e-9f32 as f64,
            3.0e11,
            0.1f32 as f64,
            (-40f64).exp2(),
        ] {
            let f = fixed(x, FRAC);
            assert_eq!(unfixed(f, FRAC), x, "{x}");
        }
        assert_eq!(fixed(f64::NAN, FRAC), 0);
        assert_eq!(fixed(f64::INFINITY, FRAC), i128::MAX);
        assert_eq!(fixed(1e-30, FRAC), 0);
    }

    #[test]
    fn records_round_trip_bit_for_bit() {
        let mut p = sums(0..10);
        p.first_hit = Some(FirstHit {
            normal: Vec3::Z,
            position: Vec3::new(1.0, 2.0, 3.0),
            depth: f32::INFINITY,
            albedo: Vec3::splat(0.5),
            emitted: Vec3::ZERO,
        });
        let mut b = Vec::new();
        p.to_bytes(&mut b);
        assert_eq!(b.len(), PixelSums::RECORD_BYTES);
        let q = PixelSums::from_bytes(&b).expect("a record");
        assert_eq!(q, p);
        b[12] = 7;
        assert!(PixelSums::from_bytes(&b).is_none());
    }
}
