//! Albedo demodulation: filter illumination (colour / albedo) instead of colour, so texture
//! detail, which the albedo plane holds noise-free, is not blurred; multiply back afterwards.

use std::borrow::Cow;

use lumo_image::{luminance, Image};
use rayon::prelude::*;

use crate::common::gbuffer::{
    check_color, check_size, is_background, missing_pixels, Features, Filtered,
};
use crate::common::passthrough::passed;
use crate::common::zeroed::zeroed_image;
use crate::FilterError;

/// Albedo below this (in every channel) cannot be divided by safely: such pixels (black
/// surfaces, emitters, background with no albedo) are passed through unfiltered.
pub const ALBEDO_EPS: f32 = 1e-3;

/// The albedo pixel `i` of `a` (1 channel broadcast, or the first 3) is divided by, each
/// channel clamped to ≥ [`ALBEDO_EPS`]; `None` where the pixel is passed through (albedo not
/// finite, or below ALBEDO_EPS in every channel).
pub(crate) fn albedo_divisor(a: &Image, i: usize) -> Option<[f32; 3]> {
    let p = &a.data[i * a.channels..][..a.channels];
    let v = if a.channels == 1 {
        [p[0]; 3]
    } else {
        [p[0], p[1], p[2]]
    };
    let usable =
        v.iter().all(|x| x.is_finite()) && v.iter().fold(0.0f32, |m, &x| m.max(x)) >= ALBEDO_EPS;
    usable.then(|| v.map(|x| x.max(ALBEDO_EPS)))
}

/// Whether albedo pixel `i` of `a` is passed through unfiltered by demodulation (not finite, or
/// below [`ALBEDO_EPS`] in every channel): [`albedo_divisor`]'s rule, for callers that warn
/// about it.
pub fn albedo_passes_through(a: &Image, i: usize) -> bool {
    albedo_divisor(a, i).is_none()
}

/// Variance of the illumination of a pixel whose variance is `v` and which was divided by
/// `albedo`: v / luminance(albedo)².
pub(crate) fn illumination_variance(v: f32, albedo: [f32; 3]) -> f32 {
    let l = luminance(albedo).max(ALBEDO_EPS);
    v / (l * l)
}

/// Colour split into illumination and the albedo it was divided by.
#[derive(Clone, Debug)]
pub struct Demodulated {
    /// Colour / albedo; NaN at pass-through pixels so that filters treat them as missing
    /// (they neither receive nor give weight).
    pub illumination: Image,
    /// The albedo actually divided by (each channel clamped to ≥ [`ALBEDO_EPS`]), 3 channels.
    pub albedo: Image,
    /// True where the pixel is passed through (albedo ≈ 0 or not finite).
    pub passthrough: Vec<bool>,
}

/// Splits `color` (3 channels) by `albedo` (1 or 3 channels, same size).
pub fn demodulate(color: &Image, albedo: &Image) -> Result<Demodulated, FilterError> {
    check_color("color", color)?;
    check_size("albedo", albedo, "color", color.width, color.height)?;
    if !(albedo.channels == 1 || albedo.channels >= 3) {
        return Err(FilterError::Channels {
            name: "albedo",
            got: albedo.channels,
            expected: "1 or 3",
        });
    }
    let n = color.pixel_count();
    let mut illum = zeroed_image(color.width, color.height, 3);
    let mut used = Image::new(color.width, color.height, 3, 1.0);
    let mut passthrough = vec![false; n];
    for i in 0..n {
        let Some(a) = albedo_divisor(albedo, i) else {
            passthrough[i] = true;
            illum.data[i * 3..i * 3 + 3].fill(f32::NAN);
            continue;
        };
        for c in 0..3 {
            used.data[i * 3 + c] = a[c];
            illum.data[i * 3 + c] = color.data[i * 3 + c] / a[c];
        }
    }
    Ok(Demodulated {
        illumination: illum,
        albedo: used,
        passthrough,
    })
}

impl Demodulated {
    /// Multiplies filtered illumination by the albedo; pass-through pixels get the original
    /// colour (0 where that is not finite).
    pub fn remodulate(&self, filtered: &Image, color: &Image) -> Image {
        let mut out = filtered.clone();
        for (i, &pt) in self.passthrough.iter().enumerate() {
            for c in 0..3 {
                let k = i * 3 + c;
                out.data[k] = if pt {
                    passed(color.data[k])
                } else {
                    filtered.data[k] * self.albedo.data[k]
                };
            }
        }
        out
    }

    /// Variance of the illumination: variance / luminance(albedo)², 0 at pass-through pixels.
    pub fn demodulate_variance(&self, variance: &[f32]) -> Vec<f32> {
        variance
            .iter()
            .enumerate()
            .map(|(i, &v)| {
                if self.passthrough[i] {
                    0.0
                } else {
                    let a = &self.albedo.data[i * 3..i * 3 + 3];
                    illumination_variance(v, [a[0], a[1], a[2]])
                }
            })
            .collect()
    }
}

/// Runs `filter` on the illumination `color / albedo` and multiplies the result back.
/// The reported missing count is that of the original colour.
pub fn with_demodulation<F>(
    color: &Image,
    albedo: &Image,
    filter: F,
) -> Result<Filtered, FilterError>
where
    F: FnOnce(&Image) -> Result<Filtered, FilterError>,
{
    let d = demodulate(color, albedo)?;
    let filtered = filter(&d.illumination)?;
    Ok(Filtered {
        image: d.remodulate(&filtered.image, color),
        missing: missing_pixels(color),
    })
}

/// The albedo to demodulate by: `features.albedo`, but 0 at background pixels (the
/// pixel-centre ray missed), so that they are passed through unfiltered like any pixel
/// without a usable albedo. Borrowed when no background pixel has a usable albedo.
///
/// Why: renderers (lumo, Mitsuba's `aov` integrator) average the albedo over a pixel's
/// samples, misses counting 0. At more than one sample per pixel, a sky pixel that a wire
/// crosses off-centre then has a small albedo — a quarter of the wire's at 4 spp — and its
/// colour (mostly sky) divided by it is tens of times any neighbour's illumination. Filtered
/// among the background pixels and multiplied back, it lost the wire's darkening and spread
/// light onto other mixed pixels: on the tuning scene `tune-wires` at 4 spp, `auto` had
/// 6× the unfiltered frame's error on the sky (docs/filters.md, "Background pixels").
pub fn surface_albedo<'a>(features: &Features<'a>) -> Option<Cow<'a, Image>> {
    let a = features.albedo?;
    let n = a.pixel_count();
    // Mismatched planes are the filter's validation to report, not this helper's to index.
    let sized = |p: Option<&Image>| p.is_none_or(|p| p.pixel_count() == n);
    if !sized(features.depth) || !sized(features.position) {
        return Some(Cow::Borrowed(a));
    }
    let stray = |i: usize| is_background(features, i) && albedo_divisor(a, i).is_some();
    // In parallel: this scan runs on every demodulating call (≈ 3 % of a 512² À-Trous call's
    // CPU time, serial).
    if !(0..n).into_par_iter().any(stray) {
        return Some(Cow::Borrowed(a));
    }
    let mut masked = a.clone();
    masked
        .data
        .par_chunks_mut(a.channels)
        .enumerate()
        .filter(|&(i, _)| stray(i))
        .for_each(|(_, px)| px.fill(0.0));
    Some(Cow::Owned(masked))
}
