//! The light search's passes ([`super::detect_emitters`]), written for speed: whole rows per
//! task in loops that vectorise (compiled for AVX-512, AVX2 and the baseline by
//! `multiversion!`), the window level's test made on sums in the log domain (no `exp` per
//! pixel, no image-sized plane of sums), and the region growing, region test and rim visiting
//! only the pixels they concern. It finds the
//! same mask as the plain version it replaced (`reference.rs`, compared in tests.rs).
//!
//! Why it matters: the search runs before every filter of a frame without an emission plane,
//! and at 14–15 ms for 512² it cost as much as the À-Trous filter itself.

use lumo_image::{luminance, rgb_of, Image};
use rayon::prelude::*;

use super::level;
use super::{EmitterMask, EmitterParams, ALBEDO_FLOOR};
use crate::common::gbuffer::{depth_is_background, position_is_background, Features};

/// The light search on checked inputs (see [`super::detect_emitters`]).
pub(super) fn search(color: &Image, features: &Features, params: &EmitterParams) -> EmitterMask {
    let (w, h) = (color.width, color.height);
    let n = w * h;
    let none = || EmitterMask {
        light: vec![false; n],
        rim: vec![false; n],
    };
    if n == 0 {
        return none();
    }
    let (d, sum, count) = demodulated(color, features);
    if count == 0 {
        return none();
    }
    // The level a pixel's surroundings set: the geometric mean of the window (robust to the
    // heavy tail of few-sample noise, and to the light itself at a light's rim), offset by a
    // small fraction of the frame's mean so that black regions do not make everything bright.
    let floor = (0.01 * sum / count as f64).max(1e-8) as f32;
    let bright = level::bright_pixels(&d, w, h, floor, params);
    let flat = |a: f32, b: f32| (a - b).abs() <= params.flatness * a.max(b);
    // Seeds: bright, with enough flat, bright neighbours.
    let mut stack: Vec<usize> = (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            let (bright, d) = (&bright, &d);
            marked(&bright[y * w..(y + 1) * w])
                .map(move |x| y * w + x)
                .filter(move |&i| {
                    neighbours(i, w, h)
                        .filter(|&j| bright[j] && flat(d[i], d[j]))
                        .count()
                        >= params.flat_neighbours
                })
        })
        .collect();
    let mut mask = vec![false; n];
    for &i in &stack {
        mask[i] = true;
    }
    // Grow through bright pixels and through flat continuations of the region (a light's
    // interior, where the window is all light and nothing is "bright" relative to it). What
    // is reached does not depend on the order pixels are visited in.
    while let Some(i) = stack.pop() {
        for j in neighbours(i, w, h) {
            if !mask[j] && d[j].is_finite() && (bright[j] || flat(d[i], d[j])) {
                mask[j] = true;
                stack.push(j);
            }
        }
    }
    drop_explained_regions(&mut mask, &d, w, h, params);
    let rim = rings(&mask, |i| d[i].is_finite(), w, h, params.dilate);
    EmitterMask { light: mask, rim }
}

/// Demodulated luminance of every pixel, NaN where the pixel takes no part (missing,
/// overflowing or background); and the sum and count of the finite ones, summed row by row
/// in the row order (whatever the threads).
fn demodulated(color: &Image, features: &Features) -> (Vec<f32>, f64, usize) {
    let w = color.width;
    let mut d = vec![0.0f32; color.width * color.height];
    let sums: Vec<(f64, usize)> = d
        .par_chunks_mut(w)
        .enumerate()
        .map_init(
            || (vec![1.0f32; w], vec![false; w]),
            |(divisor, background), (y, out)| {
                let (albedo, ac) = row_of(features.albedo, w, y);
                albedo_divisors(albedo, ac, divisor);
                let ((depth, dc), (position, pc)) = (
                    row_of(features.depth, w, y),
                    row_of(features.position, w, y),
                );
                backgrounds(depth, dc, position, pc, background);
                demodulate_row(&color.data[y * w * 3..][..w * 3], divisor, background, out);
                finite_sum(out)
            },
        )
        .collect();
    let (sum, count) = sums
        .into_iter()
        .fold((0.0, 0), |(s, c), (rs, rc)| (s + rs, c + rc));
    (d, sum, count)
}

/// Row `y` of a plane `w` pixels wide and its channel count; empty when the plane is absent.
fn row_of(plane: Option<&Image>, w: usize, y: usize) -> (&[f32], usize) {
    plane.map_or((&[][..], 0), |p| {
        (&p.data[y * w * p.channels..][..w * p.channels], p.channels)
    })
}

multiversion! {
    /// What each pixel of a row is demodulated by: its albedo's luminance (the row of a plane
    /// of `channels` values a pixel), at least [`ALBEDO_FLOOR`] (1 where the albedo is absent,
    /// `channels` 0, or not finite).
    fn albedo_divisors(albedo: &[f32], channels: usize, out: &mut [f32]) as albedo_divisors_impl {
        let floor = |v: f32| if v.is_finite() { v.max(ALBEDO_FLOOR) } else { 1.0 };
        match channels {
            0 => out.fill(1.0),
            3 => {
                for (o, a) in out.iter_mut().zip(albedo.chunks_exact(3)) {
                    *o = floor(luminance([a[0], a[1], a[2]]));
                }
            }
            c => {
                for (o, a) in out.iter_mut().zip(albedo.chunks_exact(c)) {
                    *o = floor(luminance(rgb_of(&a[..c.min(3)])));
                }
            }
        }
    }
}

multiversion! {
    /// Which pixels of a row are background ([`crate::common::gbuffer::is_background`]), from
    /// the rows of the depth and position planes and their channel counts (0: absent).
    fn backgrounds(depth: &[f32], dc: usize, position: &[f32], pc: usize, out: &mut [bool])
        as backgrounds_impl {
        out.fill(false);
        if dc > 0 {
            for (o, d) in out.iter_mut().zip(depth.chunks_exact(dc)) {
                *o |= depth_is_background(d[0]);
            }
        }
        match pc {
            0 => {}
            3 => {
                for (o, p) in out.iter_mut().zip(position.chunks_exact(3)) {
                    *o |= position_is_background(p);
                }
            }
            _ => {
                for (o, p) in out.iter_mut().zip(position.chunks_exact(pc)) {
                    *o |= position_is_background(&p[..3]);
                }
            }
        }
    }
}

multiversion! {
    /// One row's demodulated luminance (see [`demodulated`]).
    fn demodulate_row(color: &[f32], divisor: &[f32], background: &[bool], out: &mut [f32])
        as demodulate_row_impl {
        for (((o, c), &a), &bg) in out
            .iter_mut()
            .zip(color.chunks_exact(3))
            .zip(divisor)
            .zip(background)
        {
            let l = luminance([c[0], c[1], c[2]]);
            *o = if l.is_finite() && !bg { (l / a).max(0.0) } else { f32::NAN };
        }
    }
}

/// The sum and count of a row's finite values (four partial sums, so that the additions'
/// latencies overlap).
fn finite_sum(out: &[f32]) -> (f64, usize) {
    let (mut sum, mut count) = ([0.0f64; 4], [0usize; 4]);
    let mut quads = out.chunks_exact(4);
    for q in &mut quads {
        for k in 0..4 {
            let ok = q[k].is_finite();
            sum[k] += if ok { q[k] as f64 } else { 0.0 };
            count[k] += usize::from(ok);
        }
    }
    for &v in quads.remainder() {
        if v.is_finite() {
            sum[0] += v as f64;
            count[0] += 1;
        }
    }
    (sum[0] + sum[1] + (sum[2] + sum[3]), count.iter().sum())
}

/// Indices of the set entries of `mask`, skipping clear runs 64 entries at a time: most of a
/// frame is no light, and a plain scan of every entry cost a tenth of the search.
fn marked(mask: &[bool]) -> impl Iterator<Item = usize> + '_ {
    mask.chunks(64)
        .enumerate()
        // `fold`, not `any`: without the early exit the test vectorises.
        .filter(|(_, run)| run.iter().fold(false, |a, &b| a | b))
        .flat_map(|(k, run)| {
            run.iter()
                .enumerate()
                .filter(|(_, &b)| b)
                .map(move |(i, _)| k * 64 + i)
        })
}

/// The 8 neighbours of pixel `i` of a `w`×`h` image, clipped to the image.
#[inline]
fn neighbours(i: usize, w: usize, h: usize) -> impl Iterator<Item = usize> {
    window(i, w, h).filter(move |&j| j != i)
}

/// The 3×3 window around pixel `i`, clipped to the image, row by row (`i` included).
#[inline]
fn window(i: usize, w: usize, h: usize) -> impl Iterator<Item = usize> {
    let (x, y) = (i % w, i / w);
    let xs = x.saturating_sub(1)..(x + 2).min(w);
    (y.saturating_sub(1)..(y + 2).min(h)).flat_map(move |yy| xs.clone().map(move |xx| yy * w + xx))
}

/// The `steps` rings of 8-neighbours around `core`, through `eligible` pixels only (after
/// each step a pixel is in when it was, or it is eligible and a neighbour was), less `core`
/// itself. Visits only the pixels next to the last ring.
pub(super) fn rings(
    core: &[bool],
    eligible: impl Fn(usize) -> bool,
    w: usize,
    h: usize,
    steps: usize,
) -> Vec<bool> {
    let mut rim = vec![false; core.len()];
    if steps == 0 {
        return rim;
    }
    let mut ring: Vec<usize> = marked(core).collect();
    for _ in 0..steps {
        let mut next = Vec::new();
        for &i in &ring {
            for j in window(i, w, h) {
                if !core[j] && !rim[j] && eligible(j) {
                    rim[j] = true;
                    next.push(j);
                }
            }
        }
        ring = next;
    }
    rim
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
    if !mask.contains(&true) {
        return;
    }
    let mut visited = vec![false; mask.len()];
    let mut stack = Vec::new();
    let mut members = Vec::new();
    let mut near = Vec::new();
    let mut drop = Vec::new();
    let starts: Vec<usize> = marked(mask).collect();
    for start in starts {
        if visited[start] {
            continue;
        }
        // The region of `start` (8-connected), its pixels' levels and bounding box.
        members.clear();
        let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
        visited[start] = true;
        stack.push(start);
        while let Some(i) = stack.pop() {
            members.push(i);
            let (x, y) = (i % w, i / w);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
            for j in window(i, w, h) {
                if mask[j] && !visited[j] {
                    visited[j] = true;
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
        // bounce samples are dense, as the tests show.)
        let r = params.radius;
        // The surroundings' box, and in it the region's pixels and their 8-neighbours.
        let (bx0, by0) = (x0.saturating_sub(r), y0.saturating_sub(r));
        let (bx1, by1) = ((x1 + r + 1).min(w), (y1 + r + 1).min(h));
        let bw = bx1 - bx0;
        near.clear();
        near.resize(bw * (by1 - by0), false);
        for &i in &members {
            for j in window(i, w, h) {
                near[(j / w - by0) * bw + j % w - bx0] = true;
            }
        }
        let (mut sum, mut count) = (0.0f64, 0usize);
        for yy in by0..by1 {
            let near_row = &near[(yy - by0) * bw..][..bw];
            for (&v, &is_near) in d[yy * w + bx0..yy * w + bx1].iter().zip(near_row) {
                if v.is_finite() && !is_near {
                    sum += v as f64;
                    count += 1;
                }
            }
        }
        // Nothing around it to compare with (a light filling the frame): keep it.
        if count > 0 && (level as f64) < params.region_contrast as f64 * sum / count as f64 {
            drop.extend_from_slice(&members);
        }
    }
    for i in drop {
        mask[i] = false;
    }
}
