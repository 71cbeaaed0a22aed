//! The light search as it was before it was rewritten for speed (one pass per step over whole
//! image-sized boolean planes, a queue, window iterators): the reference the fast search must
//! match (tests.rs; the two forms of the brightness test round differently, so they may part
//! only for a pixel within a few 1e-7 of the threshold, which no test frame has). Kept
//! verbatim but for its name.

use std::collections::VecDeque;

use lumo_image::{luminance, rgb_of, Image};

use super::{EmitterMask, EmitterParams, ALBEDO_FLOOR};
use crate::common::boxsum::box_mean_finite;
use crate::common::gbuffer::{check_features, Features};
use crate::FilterError;

/// Pixels of `color` that look like directly visible emitters ([`EmitterMask::light`]) and
/// the rim around them ([`EmitterMask::rim`]); [`EmitterMask::filter`] passes both through,
/// as an emission plane would mark them.
///
/// Reads the albedo (to tell texture from light; without it, luminance is used as is) and the
/// depth / position planes of `features` (background pixels are never marked: the filters
/// keep them apart from geometry already, and they do not count towards any window's level).
/// Non-finite colour pixels are never marked (the filters treat them as missing).
pub(super) fn detect_emitters_reference(
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
