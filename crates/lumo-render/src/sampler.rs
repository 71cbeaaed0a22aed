//! Stateless low-discrepancy sampling: every number is a function of (pixel, sample index,
//! dimension, seed) only, so images do not depend on thread count or scheduling.

use glam::Vec2;

/// Owen-scrambled Sobol points for one sample of one pixel.
///
/// Numbers are drawn four dimensions at a time with `sobol_burley::sample_4d` (SIMD), which
/// measured about 3× cheaper per number than one-dimension calls in the path tracer's profile.
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler {
    seed: u32,
    index: u32,
    /// Next 4-D dimension set to fetch.
    set: u32,
    cache: [f32; 4],
    /// Position in `cache` of the next number (4 = empty).
    used: u8,
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

impl PixelSampler {
    /// The sampler of sample `index` of pixel (x, y) under the global `seed`.
    #[inline]
    pub fn new(x: u32, y: u32, index: u32, seed: u32) -> Self {
        // sobol_burley supports 2^16 samples per sequence; beyond that, continue with an
        // independently scrambled sequence.
        let block = index >> 16;
        let pixel_seed = hash_u32(x ^ hash_u32(y ^ hash_u32(seed ^ hash_u32(block))));
        Self {
            seed: pixel_seed,
            index: index & 0xffff,
            set: 0,
            cache: [0.0; 4],
            used: 4,
        }
    }

    /// The next number in [0, 1).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        if self.used == 4 {
            let sets = sobol_burley::NUM_DIMENSION_SETS_4D;
            // Deep paths run past the table's dimensions: continue with a re-seeded set.
            let round = self.set / sets;
            let seed = if round == 0 {
                self.seed
            } else {
                hash_u32(self.seed ^ round)
            };
            self.cache = sobol_burley::sample_4d(self.index, self.set % sets, seed);
            self.set += 1;
            self.used = 0;
        }
        let v = self.cache[self.used as usize];
        self.used += 1;
        v
    }

    /// The next 2-D point in [0, 1)².
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_1d(), self.next_1d())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
