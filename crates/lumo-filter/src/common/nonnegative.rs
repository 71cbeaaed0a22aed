//! Radiance cannot be negative, but a filter whose per-window model is linear (the guided
//! filter, and `auto`'s blend of guided candidates) overshoots below zero beside bright edges.
//! Such values are artefacts with no light to them: the filters that can make them clamp
//! their output at 0, which can only move a pixel closer to any non-negative reference.

use lumo_image::Image;
use rayon::prelude::*;

/// Sets the negative values of `img` to 0; NaN (missing pixels) is left as it is.
pub(crate) fn clamp_negative(img: &mut Image) {
    img.data.par_chunks_mut(1 << 14).for_each(|chunk| {
        for v in chunk {
            if *v < 0.0 {
                *v = 0.0;
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negatives_become_zero_and_the_rest_stays() {
        let mut img = Image::from_vec(2, 2, 1, vec![-1.0, 0.5, f32::NAN, -0.0]);
        clamp_negative(&mut img);
        assert_eq!(img.data[0], 0.0);
        assert_eq!(img.data[1], 0.5);
        assert!(img.data[2].is_nan());
        assert_eq!(img.data[3], 0.0);
    }
}
