//! Finding lights (and other noise-free, far too bright pixels) in a frame that comes without
//! an emission plane, so that they can be passed through instead of smeared over their
//! neighbours.
//!
//! Why not a threshold on brightness alone: a sunlit floor patch, a 1-spp firefly and an area
//! light can all be 50× brighter than the rest of the frame. What sets a light apart is that
//! emitted radiance seen directly is noise-free: neighbouring pixels inside a light carry the
//! same value to the last few bits at any sample count, while a bright pixel of a noisy lit
//! surface has no neighbour within a few per cent of it. So the detector asks two things of a
//! seed pixel — far brighter than its surroundings can explain, and flat with its neighbours —
//! and then grows the region from the seeds through pixels that are bright or equally flat
//! (a light larger than the window is bright only at its rim, flat inside). A region found
//! that way must then stand far above the arithmetic mean of what surrounds it: clusters of
//! equal 1-spp samples of one bright area's bounce light pass the first tests but not that one.

use std::collections::VecDeque;

use lumo_image::{luminance, rgb_of, Image};

use crate::common::boxsum::box_mean_finite;
use crate::common::gbuffer::{check_features, Features};
use crate::FilterError;

/// Settings of [`detect_emitters`]; the defaults were chosen on the tuning set
/// (scenes/tuning, docs/filters.md), never on the held-out scenes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmitterParams {
    /// A seed is at least this many times brighter (demodulated luminance) than the geometric
    /// mean of its window.
    pub brightness: f32,
    /// Radius of the window of that geometric mean, in pixels.
    pub radius: usize,
    /// Two pixels are "flat" when their demodulated luminances differ by at most this
    /// fraction of the larger.
    pub flatness: f32,
    /// A seed needs at least this many flat, bright neighbours among its 8.
    pub flat_neighbours: usize,
    /// Rings of pixels around the region, passed through with it ([`EmitterMask::rim`]): the
    /// anti-aliased rim of a light, partly covered, is neither flat nor always bright enough
    /// to be found, and would spread.
    pub dilate: usize,
    /// A region is kept only if its median demodulated luminance is at least this many times
    /// the arithmetic mean of its surroundings (0: every region is kept); see
    /// `drop_explained_regions`.
    pub region_contrast: f32,
}

impl Default for EmitterParams {
    fn default() -> Self {
        Self {
            brightness: 8.0,
            radius: 8,
            flatness: 0.02,
            flat_neighbours: 3,
            dilate: 1,
            region_contrast: 4.0,
        }
    }
}

/// What [`detect_emitters`] found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EmitterMask {
    /// Pixels of lights: pass them through unfiltered, as an emission plane would mark them.
    pub light: Vec<bool>,
    /// The rings around them ([`EmitterParams::dilate`]): the anti-aliased rim, partly light.
    pub rim: Vec<bool>,
}

impl EmitterMask {
    /// Runs `filter` with the lights and their rims passed through ([`crate::with_passthrough`]).
    ///
    /// Why the rim is passed through rather than hidden and filled ([`crate::with_hidden`]):
    /// on the tuning set a filled rim loses the light's share of its partly covered pixels
    /// (tune-room, guided: relMSE 3.5e-3 → 4.2e-3 at 1 spp, 2.6e-3 → 3.4e-3 at 4 spp), which
    /// costs more than the rim's unfiltered noise.
    pub fn filter<F, E>(&self, color: &Image, filter: F) -> Result<crate::Filtered, E>
    where
        F: FnOnce(&Image) -> Result<crate::Filtered, E>,
    {
        let pass: Vec<bool> = self
            .light
            .iter()
            .zip(&self.rim)
            .map(|(&l, &r)| l || r)
            .collect();
        crate::common::passthrough::with_passthrough(color, &pass, filter)
    }

    /// The mask an emission plane gives: its non-zero pixels (any channel; NaN counts) are
    /// lights, and `dilate` rings around the non-background ones, over non-background pixels,
    /// are their rim, passed through with them as [`detect_emitters`]' rim is.
    ///
    /// Why the rim: a renderer's emission plane (lumo's is the pixel-centre ray's) marks a
    /// pixel on a light's anti-aliased edge only when its centre sees the light, yet its
    /// colour holds the light's share either way; filtered, that share spread a glow around the
    /// light and the light pulled its neighbours' error estimates (a dark ring), so the plane
    /// made `lumo denoise` worse than its own light search (cornell 512², 4 spp, `auto`, against
    /// 1024 spp: relMSE 4.4e-3 with the plane, 1.7e-3 without; 1.7e-3 with this rim). The sky's edge needs no rim: background pixels
    /// are kept apart from geometry by every filter already.
    pub fn from_emission(
        emission: &Image,
        features: &Features,
        dilate: usize,
    ) -> Result<EmitterMask, FilterError> {
        let (w, h) = (emission.width, emission.height);
        check_features(features, w, h)?;
        let n = w * h;
        let c = emission.channels;
        let light: Vec<bool> = (0..n)
            .map(|i| emission.data[i * c..(i + 1) * c].iter().any(|&v| v != 0.0))
            .collect();
        let background: Vec<bool> = (0..n)
            .map(|i| crate::common::gbuffer::is_background(features, i))
            .collect();
        let mut grown: Vec<bool> = (0..n).map(|i| light[i] && !background[i]).collect();
        for _ in 0..dilate {
            grown = (0..n)
                .map(|i| grown[i] || (!background[i] && window(i, 1, w, h).any(|j| grown[j])))
                .collect();
        }
        let rim = (0..n).map(|i| grown[i] && !light[i]).collect();
        Ok(EmitterMask { light, rim })
    }
}

/// The darkest albedo luminance a pixel is demodulated by: black surfaces would otherwise
/// divide by 0.
const ALBEDO_FLOOR: f32 = 0.05;

/// Pixels of `color` that look like directly visible emitters ([`EmitterMask::light`]) and
/// the rim around them ([`EmitterMask::rim`]); [`EmitterMask::filter`] passes both through,
/// as an emission plane would mark them.
///
/// Reads the albedo (to tell texture from light; without it, luminance is used as is) and the
/// depth / position planes of `features` (background pixels are never marked: the filters
/// keep them apart from geometry already, and they do not count towards any window's level).
/// Non-finite colour pixels are never marked (the filters treat them as missing).
pub fn detect_emitters(
    color: &Image,
    features: &Features,
    params: &EmitterParams,
) -> Result<EmitterMask, FilterError> {
    crate::common::gbuffer::check_color("color", color)?;
    let (w, h) = (color.width, color.height);
    check_features(features, w, h)?;
    // (Written so that NaN parameters fail too.)
    let valid = params.brightness > 1.0
        && params.flatness >= 0.0
        && params.flat_neighbours <= 8
        && params.region_contrast >= 0.0
        && params.region_contrast.is_finite();
    if !valid {
        return Err(crate::common::error::param(
            "emitter detection",
            format!(
                "{params:?} (brightness must be > 1, flatness ≥ 0, flat_neighbours ≤ 8, \
                 region_contrast finite and ≥ 0)"
            ),
        ));
    }
    let n = w * h;
    let background: Vec<bool> = (0..n)
        .map(|i| crate::common::gbuffer::is_background(features, i))
        .collect();
    // Demodulated luminance; NaN where the pixel takes no part (missing or background).
    let d: Vec<f32> = (0..n)
        .map(|i| {
            let l = luminance(rgb_of(&color.data[i * 3..i * 3 + 3]));
            if !l.is_finite() || background[i] {
                return f32::NAN;
            }
            let a = features.albedo.map_or(1.0, |a| {
                let v = luminance(rgb_of(&a.data[i * a.channels..][..a.channels.min(3)]));
                if v.is_finite() {
                    v.max(ALBEDO_FLOOR)
                } else {
                    1.0
                }
            });
            (l / a).max(0.0)
        })
        .collect();
    // The level a pixel's surroundings set: the geometric mean of the window (robust to the
    // heavy tail of few-sample noise, and to the light itself at a light's rim), offset by a
    // small fraction of the frame's mean so that black regions do not make everything bright.
    let (sum, count) = d
        .iter()
        .filter(|v| v.is_finite())
        .fold((0.0f64, 0usize), |(s, c), &v| (s + v as f64, c + 1));
    if count == 0 {
        return Ok(EmitterMask {
            light: vec![false; n],
            rim: vec![false; n],
        });
    }
    let floor = (0.01 * sum / count as f64).max(1e-8) as f32;
    let logs: Vec<f32> = d.iter().map(|&v| (v + floor).ln()).collect();
    let log_means = box_mean_finite(&logs, w, h, params.radius);
    let bright: Vec<bool> = (0..n)
        .map(|i| {
            let m = log_means[i];
            d[i].is_finite() && m.is_finite() && d[i] + floor > params.brightness * m.exp()
        })
        .collect();
    let flat = |a: f32, b: f32| (a - b).abs() <= params.flatness * a.max(b);
    let neighbours = |i: usize| window(i, 1, w, h).filter(move |&j| j != i);
    let mut mask = vec![false; n];
    let mut queue = VecDeque::new();
    for i in 0..n {
        if bright[i]
            && neighbours(i)
                .filter(|&j| bright[j] && flat(d[i], d[j]))
                .count()
                >= params.flat_neighbours
        {
            mask[i] = true;
            queue.push_back(i);
        }
    }
    // Grow through bright pixels and through flat continuations of the region (a light's
    // interior, where the window is all light and nothing is "bright" relative to it).
    while let Some(i) = queue.pop_front() {
        for j in neighbours(i).collect::<Vec<_>>() {
            if !mask[j] && d[j].is_finite() && (bright[j] || flat(d[i], d[j])) {
                mask[j] = true;
                queue.push_back(j);
            }
        }
    }
    drop_explained_regions(&mut mask, &d, w, h, params);
    let mut grown = mask.clone();
    for _ in 0..params.dilate {
        grown = (0..n)
            .map(|i| grown[i] || (d[i].is_finite() && neighbours(i).any(|j| grown[j])))
            .collect();
    }
    let rim = (0..n).map(|i| grown[i] && !mask[i]).collect();
    Ok(EmitterMask { light: mask, rim })
}

/// Indices of the pixels of the (2r+1)² window around pixel `i` of a `w`×`h` image, clipped to
/// the image, row by row (`i` itself included).
fn window(i: usize, r: usize, w: usize, h: usize) -> impl Iterator<Item = usize> {
    let (x, y) = (i % w, i / w);
    (y.saturating_sub(r)..(y + r + 1).min(h))
        .flat_map(move |yy| (x.saturating_sub(r)..(x + r + 1).min(w)).map(move |xx| yy * w + xx))
}

/// Unmarks every connected region of `mask` whose median demodulated luminance is less than
/// [`EmitterParams::region_contrast`] × the arithmetic mean of the pixels around it (the region's
/// bounding box grown by [`EmitterParams::radius`], less the region and the ring one pixel
/// wide around it).
///
/// Why: where a surface is lit only by light bouncing off one bright uniform area (a sunlit
/// patch, a light hidden from view), every 1-spp sample that reaches that area brings the same
/// value (cosine sampling cancels the cosine), so at a few samples per pixel clusters of
/// neighbouring pixels with one such sample each are flat and far brighter than the window's
/// geometric mean — they pass the seed test. Their surroundings' *arithmetic* mean, which
/// counts the other such samples, explains them (a cluster pixel is a few times the mean); a
/// light or a sunlit patch stays far above it.
fn drop_explained_regions(
    mask: &mut [bool],
    d: &[f32],
    w: usize,
    h: usize,
    params: &EmitterParams,
) {
    let n = w * h;
    // Region of each marked pixel (`usize::MAX`: none yet).
    let mut region = vec![usize::MAX; n];
    let mut stack = Vec::new();
    let mut drop = Vec::new();
    for start in 0..n {
        if !mask[start] || region[start] != usize::MAX {
            continue;
        }
        // The region of `start` (8-connected), its pixels' levels and bounding box.
        let mut members = Vec::new();
        let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
        region[start] = start;
        stack.push(start);
        while let Some(i) = stack.pop() {
            members.push(i);
            let (x, y) = (i % w, i / w);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
            for j in window(i, 1, w, h) {
                if mask[j] && region[j] == usize::MAX {
                    region[j] = start;
                    stack.push(j);
                }
            }
        }
        let mut levels: Vec<f32> = members.iter().map(|&i| d[i]).collect();
        let mid = levels.len() / 2;
        let level = *levels.select_nth_unstable_by(mid, f32::total_cmp).1;
        // The surroundings: everything in the grown box but the region and the ring one pixel
        // wide around it (a light's anti-aliased rim, partly light). Other regions count:
        // clusters of bounce samples are samples of one surface, and where they are dense
        // most of that surface's bright samples lie in them. (Leaving every region out was a
        // little better on the tuning set's FLIP — 1.102 against 1.105 of OIDN's, the
        // atrium's sunlit fragments kept as lights — but kept every cluster of a frame whose
        // bounce samples are dense, as the test below shows.)
        let r = params.radius;
        let (mut sum, mut count) = (0.0f64, 0usize);
        for yy in y0.saturating_sub(r)..(y1 + r + 1).min(h) {
            for xx in x0.saturating_sub(r)..(x1 + r + 1).min(w) {
                let j = yy * w + xx;
                if d[j].is_finite() && !window(j, 1, w, h).any(|k| region[k] == start) {
                    sum += d[j] as f64;
                    count += 1;
                }
            }
        }
        // Nothing around it to compare with (a light filling the frame): keep it.
        if count > 0 && (level as f64) < params.region_contrast as f64 * sum / count as f64 {
            drop.extend(members);
        }
    }
    for i in drop {
        mask[i] = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A noisy grey wall (deterministic hash noise of relative amplitude `amp`) with a
    /// light of radiance `le` in the rectangle [x0, x1) × [y0, y1).
    fn wall_with_light(w: usize, h: usize, amp: f32, le: f32, rect: [usize; 4]) -> Image {
        let mut img = Image::new(w, h, 3, 0.0);
        for y in 0..h {
            for x in 0..w {
                let u = (((x * 73856093) ^ (y * 19349663)) % 1000) as f32 / 1000.0;
                let v = if (rect[0]..rect[1]).contains(&x) && (rect[2]..rect[3]).contains(&y) {
                    le
                } else {
                    0.4 * (1.0 + amp * (2.0 * u - 1.0))
                };
                img.pixel_mut(x, y).fill(v);
            }
        }
        img
    }

    #[test]
    fn finds_a_large_light_and_its_rim_and_nothing_else() {
        let img = wall_with_light(64, 48, 0.9, 30.0, [10, 40, 5, 30]);
        let found = detect_emitters(&img, &Features::default(), &EmitterParams::default()).unwrap();
        let m: Vec<bool> = (0..64 * 48)
            .map(|i| found.light[i] || found.rim[i])
            .collect();
        for y in 0..48 {
            for x in 0..64 {
                let inside = (10..40).contains(&x) && (5..30).contains(&y);
                let rim = (9..41).contains(&x) && (4..31).contains(&y);
                assert!(!inside || m[y * 64 + x], "light pixel ({x}, {y}) missed");
                assert!(rim || !m[y * 64 + x], "wall pixel ({x}, {y}) marked");
            }
        }
    }

    #[test]
    fn an_isolated_firefly_and_a_constant_frame_are_not_lights() {
        let mut img = wall_with_light(32, 32, 0.9, 0.4, [0, 0, 0, 0]);
        img.pixel_mut(16, 16).fill(500.0);
        let m = detect_emitters(&img, &Features::default(), &EmitterParams::default()).unwrap();
        assert!(m.light.iter().chain(&m.rim).all(|&b| !b));
        let flat = Image::new(32, 32, 3, 2.0);
        let m = detect_emitters(&flat, &Features::default(), &EmitterParams::default()).unwrap();
        assert!(m.light.iter().chain(&m.rim).all(|&b| !b));
    }

    #[test]
    fn clusters_of_equal_bounce_samples_are_not_lights_but_a_light_among_them_is() {
        // A ceiling lit only by one bright uniform patch, at one sample per pixel: 30 % of
        // the pixels found the patch and carry exactly its value (1.0), the rest almost
        // nothing. Neighbouring hits are flat and far above the window's geometric mean.
        let (w, h) = (64, 64);
        let mut img = Image::new(w, h, 3, 0.0);
        for y in 0..h {
            for x in 0..w {
                // A well-mixed hash (splitmix64) of the pixel: independent samples.
                let mut z = (y * w + x) as u64 + 0x9e37_79b9_7f4a_7c15;
                z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
                let u = ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32;
                let v = if u < 0.3 { 1.0 } else { 0.01 * u };
                img.pixel_mut(x, y).fill(v);
            }
        }
        let count = |m: &EmitterMask| m.light.iter().filter(|&&b| b).count();
        let keep_all = EmitterParams {
            region_contrast: 0.0,
            ..EmitterParams::default()
        };
        let f = Features::default();
        let before = count(&detect_emitters(&img, &f, &keep_all).unwrap());
        let after = count(&detect_emitters(&img, &f, &EmitterParams::default()).unwrap());
        // (A cluster at the border, where its surroundings are few, may survive by chance.)
        assert!(before > 200 && after * 10 < before, "{before} → {after}");
        // A light of radiance 20 on the same ceiling is still found, whole.
        for y in 20..32 {
            for x in 24..40 {
                img.pixel_mut(x, y).fill(20.0);
            }
        }
        let found = detect_emitters(&img, &f, &EmitterParams::default()).unwrap();
        let mut outside = 0;
        for y in 0..h {
            for x in 0..w {
                let inside = (24..40).contains(&x) && (20..32).contains(&y);
                assert!(
                    !inside || found.light[y * w + x],
                    "light pixel ({x}, {y}) missed"
                );
                outside += usize::from(!inside && found.light[y * w + x]);
            }
        }
        assert!(outside * 10 < before, "{outside} ceiling pixels marked");
    }

    #[test]
    fn a_nan_or_negative_region_contrast_is_an_error() {
        let img = Image::new(8, 8, 3, 1.0);
        for bad in [f32::NAN, -1.0, f32::INFINITY] {
            let p = EmitterParams {
                region_contrast: bad,
                ..EmitterParams::default()
            };
            let e = detect_emitters(&img, &Features::default(), &p).unwrap_err();
            assert!(e.to_string().contains("region_contrast"), "{e}");
        }
    }

    #[test]
    fn a_bright_texture_explained_by_its_albedo_is_not_a_light() {
        // White squares (albedo 0.9) on a black floor (albedo 0.005) under even light: 180×
        // brighter, flat — and fully explained by the albedo.
        let (w, h) = (48, 48);
        let mut albedo = Image::new(w, h, 3, 0.0);
        let mut color = Image::new(w, h, 3, 0.0);
        for y in 0..h {
            for x in 0..w {
                let a = if (x / 8 + y / 8) % 2 == 0 { 0.9 } else { 0.005 };
                albedo.pixel_mut(x, y).fill(a);
                color.pixel_mut(x, y).fill(a * 0.7);
            }
        }
        let f = Features {
            albedo: Some(&albedo),
            ..Features::default()
        };
        let m = detect_emitters(&color, &f, &EmitterParams::default()).unwrap();
        assert!(m.light.iter().all(|&b| !b));
        // Without the albedo the same frame's white squares would pass for lights.
        let m = detect_emitters(&color, &Features::default(), &EmitterParams::default()).unwrap();
        assert!(m.light.iter().any(|&b| b));
    }
}
