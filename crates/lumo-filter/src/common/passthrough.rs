//! Pixels a filter must leave exactly as they are: lights and sky seen directly (noise-free and
//! far brighter than their surroundings) and, in demodulation, pixels without an albedo.

use lumo_image::Image;
use rayon::prelude::*;

use crate::common::gbuffer::{missing_pixels, Filtered};

/// The colour of a pass-through channel value: itself, or 0 where it is not finite.
pub(crate) fn passed(v: f32) -> f32 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

/// Runs `filter` with the pixels where `pass` is true left out — missing, so they neither
/// receive nor give weight — then puts their colour from `color` back. The reported missing
/// count is that of `color`. Errors are the filter's own (any type).
pub fn with_passthrough<F, E>(color: &Image, pass: &[bool], filter: F) -> Result<Filtered, E>
where
    F: FnOnce(&Image) -> Result<Filtered, E>,
{
    with_hidden(color, pass, &[], filter)
}

/// As [`with_passthrough`], and the pixels where `hidden` is true (it may be shorter, even
/// empty) are also kept out of the filter but keep what the filter fills in there: the rim
/// of a light found in the frame ([`crate::EmitterMask`]), whose own values would spread the
/// light and whose noise a pass-through would keep.
pub fn with_hidden<F, E>(
    color: &Image,
    pass: &[bool],
    hidden: &[bool],
    filter: F,
) -> Result<Filtered, E>
where
    F: FnOnce(&Image) -> Result<Filtered, E>,
{
    let mut input = color.clone();
    // The masks in parallel (serial, they and the restore below were ≈ 1 % of a 512²
    // À-Trous call's CPU time, twice that of its wall time on two threads).
    for mask in [pass, hidden] {
        input
            .data
            .par_chunks_mut(3)
            .zip(mask.par_iter())
            .filter(|(_, &p)| p)
            .for_each(|(px, _)| px.fill(f32::NAN));
    }
    let mut out = filter(&input)?;
    out.image
        .data
        .par_chunks_mut(3)
        .zip(color.data.par_chunks(3))
        .zip(pass.par_iter())
        .filter(|(_, &p)| p)
        .for_each(|((o, c), _)| {
            for (o, &c) in o.iter_mut().zip(c) {
                *o = passed(c);
            }
        });
    out.missing = missing_pixels(color);
    Ok(out)
}

/// As [`with_passthrough`], and the radiance `emitted` (3 channels, the mean over each
/// pixel's samples of what their first hits emit towards the camera) is kept out of the filter
/// everywhere else: the filter sees `color − emitted` (at least 0) and `emitted` is added back
/// to its output. Why: with several samples a pixel on a light's rim mixes the light with its
/// surroundings; its centre ray may see the surroundings, so `pass` keeps it, and its bright
/// share of the light, in the filter, which spread it over the ceiling as a halo. An `emitted`
/// plane of another size, or a non-finite value, leaves those pixels' colour as it is.
pub fn with_emitted<F, E>(
    color: &Image,
    pass: &[bool],
    emitted: &Image,
    filter: F,
) -> Result<Filtered, E>
where
    F: FnOnce(&Image) -> Result<Filtered, E>,
{
    let usable = emitted.width == color.width
        && emitted.height == color.height
        && emitted.channels == 3
        && color.channels == 3;
    if !usable {
        return with_passthrough(color, pass, filter);
    }
    let share = |i: usize| -> Option<[f32; 3]> {
        if pass.get(i).copied().unwrap_or(false) {
            return None;
        }
        let e = &emitted.data[i * 3..i * 3 + 3];
        (e.iter().all(|v| v.is_finite()) && e.iter().any(|&v| v > 0.0)).then(|| [e[0], e[1], e[2]])
    };
    let mut reflected = color.clone();
    for i in 0..color.pixel_count() {
        if let Some(e) = share(i) {
            // A non-finite value stays as it is: it marks the pixel missing for the filter
            // (`max` would turn a NaN into 0).
            for (c, e) in reflected.data[i * 3..i * 3 + 3].iter_mut().zip(e) {
                if c.is_finite() {
                    *c = (*c - e).max(0.0);
                }
            }
        }
    }
    let mut out = with_passthrough(&reflected, pass, filter)?;
    for i in 0..color.pixel_count() {
        if let Some(e) = share(i) {
            for (c, e) in out.image.data[i * 3..i * 3 + 3].iter_mut().zip(e) {
                *c += e;
            }
        }
    }
    out.missing = missing_pixels(color);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::FilterError;

    /// A stand-in filter: every pixel becomes the mean of the valid (finite) values.
    fn mean_filter(c: &Image) -> Filtered {
        let valid: Vec<f32> = c.data.iter().copied().filter(|v| v.is_finite()).collect();
        let mean = valid.iter().sum::<f32>() / valid.len() as f32;
        Filtered {
            image: Image::new(c.width, c.height, 3, mean),
            missing: 0,
        }
    }

    #[test]
    fn passed_pixels_are_hidden_from_the_filter_and_put_back() {
        let mut color = Image::new(4, 1, 3, 0.5);
        color.data[3..6].fill(50.0); // pixel 1 is a light
        color.data[9] = f32::NAN; // pixel 3 is broken and passed through too
        let pass = [false, true, false, true];
        let out = with_passthrough::<_, FilterError>(&color, &pass, |c| {
            // The filter sees NaN where pixels are passed through; it averages the rest.
            assert!(c.data[3].is_nan() && c.data[9].is_nan());
            Ok(mean_filter(c))
        })
        .unwrap();
        assert_eq!(&out.image.data[0..3], &[0.5; 3]);
        assert_eq!(&out.image.data[3..6], &[50.0; 3]);
        assert_eq!(out.image.data[9], 0.0);
        assert_eq!(out.missing, 1);
    }

    #[test]
    fn hidden_pixels_are_hidden_from_the_filter_and_keep_its_fill() {
        let mut color = Image::new(3, 1, 3, 0.5);
        color.data[0..3].fill(50.0); // pixel 0 passed through, pixel 1 hidden
        color.data[3..6].fill(9.0);
        let out = with_hidden::<_, FilterError>(&color, &[true], &[false, true], |c| {
            assert!(c.data[0].is_nan() && c.data[3].is_nan() && c.data[6] == 0.5);
            Ok(Filtered {
                image: Image::new(3, 1, 3, 0.25),
                missing: 0,
            })
        })
        .unwrap();
        assert_eq!(&out.image.data[0..3], &[50.0; 3]);
        assert_eq!(&out.image.data[3..9], &[0.25; 6]);
    }

    /// A rim pixel (centre ray off the light) holding half a light: the filter sees only its
    /// reflected part, which a box mean spreads, and the light's share comes back unspread.
    #[test]
    fn emitted_radiance_is_kept_out_of_the_filter() {
        let mut color = Image::new(3, 1, 3, 0.5);
        color.data[0..3].fill(50.0); // pixel 0: the light itself (passed through)
        color.data[3..6].fill(25.5); // pixel 1: half light (25), half wall (0.5)
        let mut emitted = Image::new(3, 1, 3, 0.0);
        emitted.data[0..3].fill(50.0);
        emitted.data[3..6].fill(25.0);
        let pass = [true, false, false];
        let out = with_emitted::<_, FilterError>(&color, &pass, &emitted, |c| {
            assert!(c.data[0].is_nan(), "the light is passed through");
            assert_eq!(
                &c.data[3..9],
                &[0.5; 6],
                "the filter sees the reflected part only"
            );
            Ok(mean_filter(c))
        })
        .unwrap();
        assert_eq!(&out.image.data[0..3], &[50.0; 3]);
        assert_eq!(
            &out.image.data[3..6],
            &[25.5; 3],
            "the light's share comes back"
        );
        assert_eq!(
            &out.image.data[6..9],
            &[0.5; 3],
            "nothing spread to the wall"
        );
        // Without the plane the rim's light would have spread: the box mean of 25.5 and 0.5.
        let spread =
            with_passthrough::<_, FilterError>(&color, &pass, |c| Ok(mean_filter(c))).unwrap();
        assert_eq!(spread.image.data[6], 13.0);
        // A plane of another size is ignored (the pass-through still applies).
        let other = Image::new(2, 1, 3, 1.0);
        let out = with_emitted::<_, FilterError>(&color, &pass, &other, |c| {
            assert_eq!(c.data[3], 25.5);
            Ok(Filtered {
                image: c.clone(),
                missing: 0,
            })
        })
        .unwrap();
        assert_eq!(out.image.data[0], 50.0);
        // A missing (NaN) pixel with an emitted share stays missing for the filter.
        let mut broken = color.clone();
        broken.data[3] = f32::NAN;
        let out = with_emitted::<_, FilterError>(&broken, &pass, &emitted, |c| {
            assert!(c.data[3].is_nan(), "still missing");
            Ok(mean_filter(c))
        })
        .unwrap();
        assert_eq!(out.missing, 1);
    }
}
