//! Stateless low-discrepancy sampling: every number is a function of (pixel, sample index,
//! dimension, seed) only, so images do not depend on thread count or scheduling.

use std::sync::OnceLock;

use glam::Vec2;
use lumo_simd::Isa;
use sobol_burley::parts;

/// Number of leading 4-D dimension sets drawn from the Owen-scrambled Sobol sequence; later
/// numbers come from a per-sample PCG32 stream.
///
/// Eight dimensions cover the camera jitter and the first bounce (light choice, light point,
/// BSDF lobe, BSDF direction), where stratification visibly lowers noise. Deeper dimensions
/// carry little of it (their integrands are already averaged over many earlier choices), and
/// Owen scrambling cost ~13 % of the path tracer's instructions when every dimension was
/// Sobol; a PCG32 step costs a few instructions.
pub const SOBOL_SETS: u32 = 2;

/// Number of Sobol numbers per sample (the first dimensions).
const SOBOL_DIMS: usize = 4 * SOBOL_SETS as usize;

/// Samples whose Sobol numbers [`PixelSampler::run`] computes together (sixteen 32-bit lanes:
/// one AVX-512 register).
pub const RUN: usize = 16;

/// Owen-scrambled Sobol points for one sample of one pixel, continued by independent random
/// numbers past the first `4·SOBOL_SETS` dimensions.
///
/// The Sobol numbers are computed when the sampler is made (four dimensions at a time, as
/// `sobol_burley::sample_4d` does), by the wavefront for sixteen samples at once with
/// [`PixelSampler::run`]: sixteen samples' hashes and scrambles in vector lanes instead of one
/// sample's four dimensions, whose multiply chains (latency ~10 cycles each) cost ~6 % of a
/// Cornell-box render when each sample fetched its own.
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler {
    cache: [f32; SOBOL_DIMS],
    /// Position in `cache` of the next number (`SOBOL_DIMS` = all used).
    used: u8,
    /// PCG32 state for the dimensions past the Sobol ones.
    pcg: u64,
}

/// PCG32's multiplier (O'Neill 2014).
const PCG_MULT: u64 = 6_364_136_223_846_793_005;
/// PCG32's default increment (odd).
const PCG_INC: u64 = 1_442_695_040_888_963_407;

/// 64-bit finaliser (splitmix64) that spreads a seed over the PCG state (and, in `lumo
/// render --temporal`, a sequence's seed and frame over the frame's seed).
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A 32-bit integer hash (lowbias32, Wellons) used to decorrelate pixels.
#[inline]
pub fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// The scrambling seed of pixel (x, y) for samples `block·2¹⁶ ..` under the global `seed`.
#[inline]
fn pixel_seed(x: u32, y: u32, block: u32, seed: u32) -> u32 {
    hash_u32(x ^ hash_u32(y ^ hash_u32(seed ^ hash_u32(block))))
}

impl PixelSampler {
    /// The sampler of sample `index` of pixel (x, y) under the global `seed`.
    #[inline]
    pub fn new(x: u32, y: u32, index: u32, seed: u32) -> Self {
        // sobol_burley supports 2^16 samples per sequence; beyond that, continue with an
        // independently scrambled sequence.
        let pixel_seed = pixel_seed(x, y, index >> 16, seed);
        let mut cache = [0.0; SOBOL_DIMS];
        for (set, dims) in cache.chunks_exact_mut(4).enumerate() {
            dims.copy_from_slice(&sobol_4d(index & 0xffff, set as u32, pixel_seed));
        }
        Self::with_cache(cache, pixel_seed, index)
    }

    /// The samplers of the (pixel x, pixel y, sample index) triples `samples` (at most
    /// [`RUN`]): each equal to [`PixelSampler::new`]'s bit for bit, their Sobol numbers computed
    /// together in vector lanes (a pixel's samples, or at 1 spp sixteen pixels).
    pub fn run(samples: &[(u32, u32, u32)], seed: u32, out: &mut [PixelSampler]) {
        let n = samples.len();
        assert!(
            n <= RUN && out.len() == n,
            "at most {RUN} samples per run, one output each"
        );
        let mut lanes = [(0, 0, 0); RUN];
        lanes[..n].copy_from_slice(samples);
        let mut dims = [[0.0f32; RUN]; SOBOL_DIMS];
        let pixel_seeds = sobol_run(&lanes, seed, &mut dims);
        for (k, s) in out.iter_mut().enumerate() {
            let cache = std::array::from_fn(|d| dims[d][k]);
            *s = Self::with_cache(cache, pixel_seeds[k], lanes[k].2);
        }
    }

    #[inline(always)]
    fn with_cache(cache: [f32; SOBOL_DIMS], pixel_seed: u32, index: u32) -> Self {
        Self {
            cache,
            used: 0,
            pcg: mix64((u64::from(pixel_seed) << 32) | u64::from(index)),
        }
    }

    /// The next number in [0, 1).
    #[inline(always)]
    pub fn next_1d(&mut self) -> f32 {
        if (self.used as usize) < SOBOL_DIMS {
            let v = self.cache[self.used as usize];
            self.used += 1;
            return v;
        }
        self.next_random()
    }

    /// One PCG32 step (XSH-RR output) as a float in [0, 1).
    #[inline(always)]
    fn next_random(&mut self) -> f32 {
        let old = self.pcg;
        self.pcg = old.wrapping_mul(PCG_MULT).wrapping_add(PCG_INC);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let bits = xorshifted.rotate_right((old >> 59) as u32);
        // The top 24 bits fill the float's mantissa exactly: the result is below 1.
        (bits >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// The next 2-D point in [0, 1)².
    #[inline(always)]
    pub fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_1d(), self.next_1d())
    }
}

/// Per Sobol dimension set, the XOR of the direction numbers selected by each value of the
/// high and of the low byte of a 16-bit (bit-reversed) sample index.
struct SobolTables {
    high: [[u32; 4]; 256],
    low: [[u32; 4]; 256],
}

/// The tables of the first [`SOBOL_SETS`] dimension sets, built on first use from
/// `sobol_burley`'s own direction numbers (its `sobol_int4_rev` of single-bit indices).
fn sobol_tables() -> &'static [SobolTables] {
    static TABLES: OnceLock<Vec<SobolTables>> = OnceLock::new();
    TABLES.get_or_init(|| {
        (0..SOBOL_SETS)
            .map(|set| {
                // vecs[k]: the direction numbers of index bit k, counted from the top.
                let vecs: Vec<[u32; 4]> = (0..16)
                    .map(|k| parts::sobol_int4_rev(1u32 << (31 - k), set).into())
                    .collect();
                let xor_of = |byte: usize, first: usize| {
                    let mut v = [0u32; 4];
                    for bit in 0..8 {
                        if byte & (0x80 >> bit) != 0 {
                            for (d, x) in v.iter_mut().enumerate() {
                                *x ^= vecs[first + bit][d];
                            }
                        }
                    }
                    v
                };
                SobolTables {
                    high: std::array::from_fn(|b| xor_of(b, 0)),
                    low: std::array::from_fn(|b| xor_of(b, 8)),
                }
            })
            .collect()
    })
}

/// `sobol_burley::sample_4d(index, set, seed)` bit for bit (tested), for `set < SOBOL_SETS`.
///
/// Why not the crate's function: its direction-number loop runs once per set bit of the
/// shuffled index, and on baseline x86-64 (no SSE4.1) its 4-lane multiplies are emulated with
/// shuffles; together ~10 % of the path tracer's time. Here the loop is two table lookups and,
/// where the CPU has AVX2, the scrambling is compiled with it (native 32-bit lane multiplies).
#[inline]
fn sobol_4d(index: u32, set: u32, seed: u32) -> [f32; 4] {
    let sobol = sobol_bits(index, set, seed);
    // Then the crate's last step: Owen-scramble each dimension with its own hash.
    #[cfg(target_arch = "x86_64")]
    if Isa::detect() >= Isa::Avx2 {
        // SAFETY: AVX2 was detected.
        return unsafe { scramble_avx2(sobol, set, seed) };
    }
    scramble(sobol, set, seed)
}

/// The per-dimension hash inputs of `sobol_burley::sample_4d`'s scramble.
const DIM: [u32; 4] = [0x912f69ba, 0x174f18ab, 0x691e72ca, 0xb40cc1b8];

/// The key that shuffles sample indices under `seed` (as `sobol_burley::sample_4d`).
#[inline(always)]
fn index_key(seed: u32) -> u32 {
    parts::hash(seed ^ 0x79c68e4a)
}

/// The Owen-scramble key of dimension `d` of dimension set `set` under `seed` (as
/// `sobol_burley::sample_4d`).
#[inline(always)]
fn dim_key(seed: u32, set: u32, d: usize) -> u32 {
    parts::hash((seed.wrapping_mul(0x9c8f2d3b) ^ set) ^ DIM[d])
}

/// The unscrambled Sobol integers of `sobol_burley::sample_4d`: the index shuffled (its
/// reversed bits Owen-scrambled) as the crate does, then the top 16 bits (what
/// `sobol_int4_rev` reads) looked up in the set's two tables.
#[inline(always)]
fn sobol_bits(index: u32, set: u32, seed: u32) -> [u32; 4] {
    let shuffled = parts::owen_scramble_rev(index.reverse_bits(), index_key(seed));
    let t = &sobol_tables()[set as usize];
    let (hi, lo) = (
        t.high[(shuffled >> 24) as usize],
        t.low[((shuffled >> 16) & 0xff) as usize],
    );
    [hi[0] ^ lo[0], hi[1] ^ lo[1], hi[2] ^ lo[2], hi[3] ^ lo[3]]
}

/// The per-dimension Owen scramble of `sobol_burley::sample_4d` on four Sobol integers, and
/// their conversion to floats in [0, 1).
#[inline(always)]
fn scramble(sobol: [u32; 4], set: u32, seed: u32) -> [f32; 4] {
    let mut out = [0.0f32; 4];
    for d in 0..4 {
        let scrambled = parts::owen_scramble_rev(sobol[d], dim_key(seed, set, d));
        out[d] = parts::u32_to_f32_norm(scrambled.reverse_bits());
    }
    out
}

/// [`scramble`] compiled with AVX2: the four lanes' multiplies vectorise. Written by hand, not
/// with `multiversion!`: it runs once per four dimensions of every sample, where the macro's
/// dispatcher would add a second `Isa::detect` and a call.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn scramble_avx2(sobol: [u32; 4], set: u32, seed: u32) -> [f32; 4] {
    scramble(sobol, set, seed)
}

lumo_simd::multiversion! {
    /// Lane `k`: `sobol_4d(index & 0xffff, set, pixel_seed(x, y, index >> 16, seed))` of every
    /// set for `samples[k] = (x, y, index)`, dimension by dimension (`out[4·set + d][k]`);
    /// returns the pixel seeds.
    fn sobol_run(
        samples: &[(u32, u32, u32); RUN],
        seed: u32,
        out: &mut [[f32; RUN]; SOBOL_DIMS],
    ) -> [u32; RUN] as sobol_run_isa, at sobol_run_at {
        sobol_run_lanes(samples, seed, out)
    }
}

/// [`sobol_run`]'s arithmetic: [`pixel_seed`], [`sobol_bits`] and [`scramble`] with samples as
/// lanes (loops the compiler vectorises).
#[inline(always)]
#[allow(clippy::needless_range_loop)]
fn sobol_run_lanes(
    samples: &[(u32, u32, u32); RUN],
    seed: u32,
    out: &mut [[f32; RUN]; SOBOL_DIMS],
) -> [u32; RUN] {
    let (mut xs, mut ys, mut indices) = ([0u32; RUN], [0u32; RUN], [0u32; RUN]);
    for k in 0..RUN {
        (xs[k], ys[k], indices[k]) = samples[k];
    }
    let mut seeds = [0u32; RUN];
    let mut shuffled = [0u32; RUN];
    for k in 0..RUN {
        seeds[k] = pixel_seed(xs[k], ys[k], indices[k] >> 16, seed);
        let key = index_key(seeds[k]);
        shuffled[k] = parts::owen_scramble_rev((indices[k] & 0xffff).reverse_bits(), key);
    }
    // The shuffled index is the same for every set; the direction numbers and scrambles differ.
    for (set, t) in sobol_tables().iter().enumerate() {
        let mut sobol = [[0u32; RUN]; 4];
        for k in 0..RUN {
            let hi = t.high[(shuffled[k] >> 24) as usize];
            let lo = t.low[((shuffled[k] >> 16) & 0xff) as usize];
            for d in 0..4 {
                sobol[d][k] = hi[d] ^ lo[d];
            }
        }
        for d in 0..4 {
            for k in 0..RUN {
                let key = dim_key(seeds[k], set as u32, d);
                let scrambled = parts::owen_scramble_rev(sobol[d][k], key);
                out[4 * set + d][k] = parts::u32_to_f32_norm(scrambled.reverse_bits());
            }
        }
    }
    seeds
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sobol_4d_equals_sobol_burley() {
        for set in 0..SOBOL_SETS {
            for seed in [0u32, 1, 0xdead_beef, 123_456_789] {
                for index in (0..65_536u32).step_by(7).chain([0xffff]) {
                    let want = sobol_burley::sample_4d(index, set, seed);
                    let got = sobol_4d(index, set, seed);
                    assert_eq!(
                        want.map(f32::to_bits),
                        got.map(f32::to_bits),
                        "{index} {set} {seed}"
                    );
                    assert_eq!(want.map(f32::to_bits), scramble_portable(index, set, seed));
                }
            }
        }
    }

    /// Runs over a pixel's samples and over many pixels, across a 2^16-sample block
    /// boundary and near the top of the index range, equal one-at-a-time samplers.
    #[test]
    fn runs_equal_single_samplers() {
        let mut cases: Vec<Vec<(u32, u32, u32)>> = Vec::new();
        for first in [0u32, 5, 65_530, u32::MAX - 20] {
            for n in [1u32, 7, 16] {
                cases.push((0..n).map(|k| (17, 3, first.wrapping_add(k))).collect());
            }
        }
        cases.push((0..16).map(|k| (k * 37 % 512, 200 + k / 5, 0)).collect());
        cases.push((0..11).map(|k| (k, k, k * 9_000)).collect());
        for seed in [0u32, 9, 0xdead_beef] {
            for samples in &cases {
                let mut run = vec![PixelSampler::new(0, 0, 0, 0); samples.len()];
                PixelSampler::run(samples, seed, &mut run);
                for (r, &(x, y, index)) in run.iter().zip(samples) {
                    let (mut a, mut b) = (*r, PixelSampler::new(x, y, index, seed));
                    for _ in 0..SOBOL_DIMS + 3 {
                        assert_eq!(a.next_1d().to_bits(), b.next_1d().to_bits());
                    }
                }
            }
        }
    }

    /// Every compiled form of the run equals `sobol_4d` sample by sample.
    #[test]
    #[allow(clippy::needless_range_loop)]
    fn sobol_runs_equal_sobol_4d_in_every_form() {
        for level in Isa::detect().up_to() {
            let name = format!("{level:?}");
            for seed in [0u32, 0xdead_beef] {
                for first in [0u32, 9, 65_530] {
                    let samples = std::array::from_fn(|k| {
                        (k as u32 % 3, 7, first.wrapping_add(k as u32 * 4_000))
                    });
                    let mut out = [[0.0; RUN]; SOBOL_DIMS];
                    let seeds = sobol_run_at(level, &samples, seed, &mut out);
                    for k in 0..RUN {
                        let (x, y, index) = samples[k];
                        let ps = pixel_seed(x, y, index >> 16, seed);
                        assert_eq!(seeds[k], ps, "{name}");
                        for set in 0..SOBOL_SETS as usize {
                            let want = sobol_4d(index & 0xffff, set as u32, ps);
                            let got: [f32; 4] = std::array::from_fn(|d| out[4 * set + d][k]);
                            assert_eq!(want.map(f32::to_bits), got.map(f32::to_bits), "{name}");
                        }
                    }
                }
            }
        }
    }

    /// The portable scramble path, whatever this CPU has.
    fn scramble_portable(index: u32, set: u32, seed: u32) -> [u32; 4] {
        scramble(sobol_bits(index, set, seed), set, seed).map(f32::to_bits)
    }

    #[test]
    fn deterministic_and_well_distributed() {
        let mut a = PixelSampler::new(3, 4, 7, 1);
        let mut b = PixelSampler::new(3, 4, 7, 1);
        for _ in 0..300 {
            assert_eq!(a.next_1d().to_bits(), b.next_1d().to_bits());
        }
        // 256 samples of dimension 0 stratify [0,1) into 256 cells of one point each.
        let mut cells = [0u32; 256];
        for i in 0..256 {
            let v = PixelSampler::new(9, 9, i, 5).next_1d();
            cells[(v * 256.0) as usize] += 1;
        }
        assert!(cells.iter().all(|&c| c == 1));
    }

    #[test]
    fn random_dimensions_are_uniform_and_differ_between_samples() {
        // Past the Sobol dimensions: mean ≈ 1/2, variance ≈ 1/12, and two samples of one
        // pixel do not repeat each other's numbers.
        let skip = 4 * SOBOL_SETS as usize;
        let (mut sum, mut sum2, n) = (0.0f64, 0.0f64, 4096);
        let mut equal = 0;
        for i in 0..n {
            let mut a = PixelSampler::new(1, 2, i, 0);
            let mut b = PixelSampler::new(1, 2, i + 1, 0);
            for _ in 0..skip {
                a.next_1d();
                b.next_1d();
            }
            for _ in 0..8 {
                let (x, y) = (a.next_1d(), b.next_1d());
                assert!((0.0..1.0).contains(&x));
                equal += usize::from(x == y);
                sum += x as f64;
                sum2 += (x as f64) * (x as f64);
            }
        }
        let m = sum / (8 * n) as f64;
        let var = sum2 / (8 * n) as f64 - m * m;
        assert!((m - 0.5).abs() < 0.01, "mean {m}");
        assert!((var - 1.0 / 12.0).abs() < 0.003, "variance {var}");
        assert!(equal < 8, "{equal} repeats");
    }
}
