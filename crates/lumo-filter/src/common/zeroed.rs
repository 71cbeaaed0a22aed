//! Zero-filled buffers, filled by every thread.
//!
//! Why: `auto` allocates a dozen image-sized buffers per candidate. Once the allocator has
//! freed the first ones it serves the next from memory it must clear, and `vec![0.0; n]`
//! clears it on the calling thread while the other workers wait: on a 512² frame that was
//! about a tenth of `auto`'s wall time on the 2-vCPU VM (perf, 5 December 2026). Filling in
//! parallel also spreads the page faults of fresh memory over the threads.

use lumo_image::Image;
use rayon::prelude::*;

/// Below this many values a serial fill is cheaper than waking the pool.
const PARALLEL_FROM: usize = 1 << 16;

/// `vec![0.0f32; n]`, filled in parallel when large.
pub(crate) fn zeroed(n: usize) -> Vec<f32> {
    if n < PARALLEL_FROM {
        return vec![0.0; n];
    }
    let mut v = Vec::with_capacity(n);
    v.par_extend(rayon::iter::repeat_n(0.0f32, n));
    v
}

/// `Image::new(w, h, channels, 0.0)`, filled in parallel when large.
pub(crate) fn zeroed_image(w: usize, h: usize, channels: usize) -> Image {
    Image::from_vec(w, h, channels, zeroed(w * h * channels))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zeroed_has_the_length_and_only_zeros() {
        for n in [
            0,
            1,
            PARALLEL_FROM - 1,
            PARALLEL_FROM,
            3 * PARALLEL_FROM + 7,
        ] {
            let v = zeroed(n);
            assert_eq!(v.len(), n);
            assert!(v.iter().all(|x| x.to_bits() == 0));
        }
        let img = zeroed_image(300, 301, 3);
        assert_eq!((img.width, img.height, img.channels), (300, 301, 3));
        assert_eq!(img.data.len(), 300 * 301 * 3);
    }
}
