//! Stateless low-discrepancy sampling: every number is a function of (pixel, sample index,
//! dimension, seed) only, so images do not depend on thread count or scheduling.

use glam::Vec2;

/// Owen-scrambled Sobol points for one sample of one pixel.
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler {
    seed: u32,
    index: u32,
    dimension: u32,
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
        let pixel_seed = hash_u32(x ^ hash_u32(y ^ hash_u32(seed)));
        Self {
            seed: pixel_seed,
            index,
            dimension: 0,
        }
    }

    /// The next number in [0, 1).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        let dim = self.dimension;
        self.dimension += 1;
        // sobol_burley has 256 dimensions; deeper paths continue with a re-seeded set.
        let set = dim / sobol_burley::NUM_DIMENSIONS;
        let seed = if set == 0 {
            self.seed
        } else {
            hash_u32(self.seed ^ set)
        };
        sobol_burley::sample(self.index, dim % sobol_burley::NUM_DIMENSIONS, seed)
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
