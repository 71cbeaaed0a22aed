//! The rim of a light after the filter: its pixels are passed through, so at a few samples per
//! pixel each keeps its own noise, and two kinds of it show as artefacts along every light's
//! edge: black pixels (a 1-spp sample that missed the light and found a dark path on the
//! surface beside it) and speckles brighter than the light itself (a firefly of that surface).
//!
//! A rim pixel mixes the light with the surface beside it, so its true value lies between the
//! two, and both are known after the filter: the light's level from the light pixels around it,
//! the surface's from the filtered pixels around it. So each rim pixel is clamped to that
//! range, with a lower end that allows for a rim darker than the surface around it: a lamp's
//! frame, a recess, the strip of ceiling beside the Cornell box's light, which its light does
//! not reach. That end is the smaller of half the filtered surface's mean and the mean of the
//! rim pixels' own values around the pixel: a rim that is dark all along is believed, a single
//! black pixel among brighter rim pixels is not. (Chosen on the tuning set, the scan in
//! docs/filters.md: half the surface's mean alone made the Cornell box at 4 spp 3 % worse in
//! relMSE, the whole mean 15 %; with the rim's own mean no tuning frame got worse.)

use lumo_image::{luminance, Image};

/// Radius of the square around a rim pixel whose light and surface pixels bound it.
const RADIUS: usize = 2;

/// The lower bound's share of the surface's filtered mean (chosen on the tuning set, see the
/// module comment).
const SURFACE_SHARE: f32 = 0.5;

/// Clamps each rim pixel of `out` (3 channels, the filter's output with the rim and the lights
/// passed through) per channel between the smaller of [`SURFACE_SHARE`] × the mean of the
/// filtered pixels (neither light nor rim) within [`RADIUS`] and the mean of the rim pixels'
/// values in `color` there (itself included), and the brightest light pixel (by luminance)
/// there; a bound with no pixel to set it is left open, non-finite values set none. Bounds are
/// read from `color` and from pixels the clamp does not change, so the pixels can be clamped in
/// place in any order.
pub(super) fn clamp_rim(color: &Image, light: &[bool], rim: &[bool], out: &mut Image) {
    let (w, h) = (out.width, out.height);
    debug_assert_eq!(out.channels, 3);
    for (i, _) in rim.iter().enumerate().filter(|(_, &r)| r) {
        let (x, y) = (i % w, i / w);
        let (mut surface, mut own_rim) = (Mean::default(), Mean::default());
        let mut brightest: Option<([f32; 3], f32)> = None;
        for qy in y.saturating_sub(RADIUS)..(y + RADIUS + 1).min(h) {
            for qx in x.saturating_sub(RADIUS)..(x + RADIUS + 1).min(w) {
                let j = qy * w + qx;
                if rim[j] {
                    own_rim.add(pixel(color, j));
                } else if !light[j] {
                    surface.add(pixel(out, j));
                } else if let Some(v) = finite(pixel(out, j)) {
                    let l = luminance(v);
                    if brightest.is_none_or(|(_, b)| l > b) {
                        brightest = Some((v, l));
                    }
                }
            }
        }
        let own = pixel(out, i);
        let mut v = own;
        // (A non-finite own value stays as it is: `clamp` keeps NaN.)
        for c in 0..3 {
            let hi = brightest.map_or(f32::INFINITY, |(b, _)| b[c]);
            let lo = match (surface.of(c), own_rim.of(c)) {
                (Some(s), rim_mean) => {
                    (SURFACE_SHARE as f64 * s).min(rim_mean.unwrap_or(f64::INFINITY)) as f32
                }
                (None, _) => f32::NEG_INFINITY,
            };
            // Where the surface is brighter than the light (a dim light on a lit wall) the
            // range is the light's level alone.
            let lo = lo.min(hi);
            v[c] = own[c].clamp(lo, hi.max(lo));
        }
        out.data[i * 3..i * 3 + 3].copy_from_slice(&v);
    }
}

/// Pixel `i` of a 3-channel image.
fn pixel(img: &Image, i: usize) -> [f32; 3] {
    let p = &img.data[i * 3..i * 3 + 3];
    [p[0], p[1], p[2]]
}

/// `v` if every channel is finite.
fn finite(v: [f32; 3]) -> Option<[f32; 3]> {
    v.iter().all(|c| c.is_finite()).then_some(v)
}

/// A per-channel mean of the finite pixels added to it.
#[derive(Default)]
struct Mean {
    sum: [f64; 3],
    count: usize,
}

impl Mean {
    fn add(&mut self, v: [f32; 3]) {
        if let Some(v) = finite(v) {
            for (s, c) in self.sum.iter_mut().zip(v) {
                *s += f64::from(c);
            }
            self.count += 1;
        }
    }

    /// Channel `c`'s mean, `None` without pixels.
    fn of(&self, c: usize) -> Option<f64> {
        (self.count > 0).then(|| self.sum[c] / self.count as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const W: usize = 5;

    /// A 5×4 frame: a light (row 0, level 10), its rim (row 1, values `rim_row`), a filtered
    /// surface (rows 2–3, level 2). Returns the masks, the input colour and the filter's output
    /// (the input with the surface filtered; here the same).
    fn frame(rim_row: [f32; W]) -> (Vec<bool>, Vec<bool>, Image) {
        let light: Vec<bool> = (0..W * 4).map(|i| i < W).collect();
        let rim: Vec<bool> = (0..W * 4).map(|i| (W..2 * W).contains(&i)).collect();
        let mut img = Image::new(W, 4, 3, 2.0);
        img.data[..W * 3].fill(10.0);
        for (x, v) in rim_row.iter().enumerate() {
            img.data[(W + x) * 3..(W + x) * 3 + 3].fill(*v);
        }
        (light, rim, img)
    }

    /// [`frame`]'s input and its output through [`clamp_rim`] (the filter's output taken as
    /// the input itself).
    fn clamped(rim_row: [f32; W]) -> (Image, Image) {
        let (light, rim, color) = frame(rim_row);
        let mut out = color.clone();
        clamp_rim(&color, &light, &rim, &mut out);
        (color, out)
    }

    fn rim_of(img: &Image) -> Vec<f32> {
        (0..W).map(|x| img.data[(W + x) * 3]).collect()
    }

    #[test]
    fn a_black_rim_pixel_among_brighter_ones_is_raised_to_half_the_surface() {
        let (color, out) = clamped([3.0, 0.0, 3.0, 3.0, 3.0]);
        // Pixel 1: surface mean 2 → 1; its rim's mean (3 + 0 + 3 + 3) / 4 is larger.
        assert_eq!(rim_of(&out), [3.0, 1.0, 3.0, 3.0, 3.0]);
        assert_eq!(
            &out.data[2 * W * 3..],
            &color.data[2 * W * 3..],
            "surface untouched"
        );
        assert_eq!(&out.data[..W * 3], &color.data[..W * 3], "light untouched");
    }

    #[test]
    fn a_rim_dark_all_along_is_believed() {
        let (color, out) = clamped([0.0; W]);
        assert_eq!(out, color);
        // With a little noise it moves at most to its own mean, not to the surface's 1.
        let (_, out) = clamped([0.0, 0.1, 0.0, 0.0, 0.0]);
        assert!(rim_of(&out).iter().all(|&v| v <= 0.1), "{:?}", rim_of(&out));
    }

    #[test]
    fn a_rim_speckle_above_the_light_is_lowered_to_it() {
        let (_, out) = clamped([3.0, 80.0, 3.0, 3.0, 3.0]);
        assert_eq!(rim_of(&out), [3.0, 10.0, 3.0, 3.0, 3.0]);
    }

    #[test]
    fn rim_pixels_between_surface_and_light_keep_their_values() {
        let row = [1.0, 1.5, 6.0, 10.0, 2.0];
        let (_, out) = clamped(row);
        assert_eq!(rim_of(&out), row);
    }

    #[test]
    fn a_surface_brighter_than_the_light_bounds_the_rim_by_the_light() {
        let (light, rim, color) = frame([30.0, 0.0, 30.0, 30.0, 30.0]);
        let mut out = color.clone();
        out.data[2 * W * 3..].fill(50.0); // filtered surface 50: half of it is above the light
        clamp_rim(&color, &light, &rim, &mut out);
        assert_eq!(rim_of(&out), [10.0; W]);
    }

    #[test]
    fn channels_are_clamped_each_between_their_own_bounds() {
        let (light, rim, mut color) = frame([3.0, 0.0, 3.0, 3.0, 3.0]);
        for x in 0..W {
            color.data[x * 3..x * 3 + 3].copy_from_slice(&[10.0, 4.0, 1.0]);
        }
        color.data[(W + 1) * 3..(W + 1) * 3 + 3].copy_from_slice(&[0.0, 9.0, 0.5]);
        let mut out = color.clone();
        clamp_rim(&color, &light, &rim, &mut out);
        // R raised to 1; G lowered to the light's 4; B raised to 1 (≤ the light's 1).
        assert_eq!(&out.data[(W + 1) * 3..(W + 1) * 3 + 3], &[1.0, 4.0, 1.0]);
    }

    #[test]
    fn bounds_without_pixels_are_open_and_missing_values_set_none() {
        // No surface pixel near: only the upper bound applies.
        let light = vec![true, false];
        let rim = vec![false, true];
        let mut color = Image::new(2, 1, 3, 0.0);
        color.data[0..3].fill(5.0);
        let mut out = color.clone();
        clamp_rim(&color, &light, &rim, &mut out);
        assert_eq!(out, color);
        // Non-finite surface and rim values set no bound; the clean ones do.
        let (light, rim, color) = frame([3.0, 0.0, f32::NAN, 3.0, 3.0]);
        let mut out = color.clone();
        out.data[2 * W * 3] = f32::INFINITY; // surface pixel (0, 2)
        out.data[(W + 2) * 3..(W + 2) * 3 + 3].fill(0.0); // the pass-through of the NaN
        clamp_rim(&color, &light, &rim, &mut out);
        // Pixel 1: rim mean (3 + 0 + 3) / 3 = 2; surface mean 2 → lower bound 1.
        assert_eq!(out.data[(W + 1) * 3], 1.0);
    }
}
