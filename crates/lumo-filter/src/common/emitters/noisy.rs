//! Lights that carry noise: a dim emitter also reflects the light falling on it (every light
//! in a Mitsuba scene has a BSDF, often diffuse), so at a few samples per pixel its pixels are
//! its emission plus speckles of bounce light. Passed through as they are, those speckles stay
//! in the image, and the speckled pixels the search could not call flat become holes of rim
//! inside the light, passed through too (a dim window at night in a lamp-lit room: the window
//! stayed speckled and its error was a third of the frame's).
//!
//! So after the filter, a light pixel whose neighbourhood of light pixels is not flat (its
//! luminance spread exceeds the search's own flatness: a light seen directly is flat to the
//! last few bits at any sample count, which is how it was found) takes the mean of the light
//! pixels around it: emission is smooth across a light, and the mean keeps the bounce light's
//! energy where a median would lose it. A noise-free light is flat and passes through
//! unchanged, bit for bit. Only the interior is touched: the outer rim and the light's own
//! edge pixels keep their pass-through, as their pixels mix the light with what is beside it
//! and averaging them spread the light (a first version that averaged the edge too made the
//! Cornell box at 4 spp 12× worse in relMSE; docs/filters.md).

use lumo_image::{luminance, Image};

use crate::common::boxsum::box_mean;

/// The smallest albedo a channel is demodulated by (as the search's floor): black surfaces
/// would otherwise divide by 0.
const ALBEDO_FLOOR: f32 = 0.05;

/// Radius of the window a noisy light pixel is averaged over (chosen on the tuning set's
/// `tune-nightlight`, docs/filters.md).
const RADIUS: usize = 4;

/// A rim pixel with at least this many light pixels among its 8 neighbours is a hole inside
/// the light (a speckle the search could not call flat), not its edge.
const HOLE_NEIGHBOURS: usize = 4;

/// Replaces, in `out`, each noisy pixel of a light's interior by the mean colour of the
/// interior pixels within [`RADIUS`] of it in `color` (demodulated by `albedo` when given, and
/// remodulated by the pixel's own); see the module comment. `flatness` is the search's
/// ([`crate::EmitterParams::flatness`]).
pub(super) fn smooth_noisy_lights(
    color: &Image,
    albedo: Option<&Image>,
    light: &[bool],
    rim: &[bool],
    flatness: f32,
    out: &mut Image,
) {
    // Only the lights' neighbourhood is read: its bounding box, grown by the window and the
    // one-pixel neighbour test. Over the whole frame the box sums cost the guided filter a
    // third more at 512² (32 against 22 ms with one small light), for a few hundred pixels.
    let (w, h) = (color.width, color.height);
    let Some([x0, y0, x1, y1]) = bounds(light, rim, w, h, RADIUS + 1) else {
        return;
    };
    let (cw, ch) = (x1 - x0, y1 - y0);
    if (cw, ch) == (w, h) {
        return smooth_in(color, albedo, light, rim, flatness, out);
    }
    let crop = |img: &Image| {
        let c = img.channels;
        let mut data = Vec::with_capacity(cw * ch * c);
        for y in y0..y1 {
            data.extend_from_slice(&img.data[(y * w + x0) * c..(y * w + x1) * c]);
        }
        Image::from_vec(cw, ch, c, data)
    };
    let crop_mask = |m: &[bool]| -> Vec<bool> {
        (y0..y1)
            .flat_map(|y| m[y * w + x0..y * w + x1].iter().copied())
            .collect()
    };
    let (c, a) = (crop(color), albedo.map(crop));
    let mut o = crop(out);
    smooth_in(
        &c,
        a.as_ref(),
        &crop_mask(light),
        &crop_mask(rim),
        flatness,
        &mut o,
    );
    for y in y0..y1 {
        out.data[(y * w + x0) * 3..(y * w + x1) * 3]
            .copy_from_slice(&o.data[(y - y0) * cw * 3..(y - y0 + 1) * cw * 3]);
    }
}

/// The bounding box `[x0, y0, x1, y1)` of the light and rim pixels grown by `margin` and
/// clipped to the frame; `None` without any.
fn bounds(light: &[bool], rim: &[bool], w: usize, h: usize, margin: usize) -> Option<[usize; 4]> {
    let mut b: Option<[usize; 4]> = None;
    for i in (0..w * h).filter(|&i| light[i] || rim[i]) {
        let (x, y) = (i % w, i / w);
        let e = b.get_or_insert([x, y, x, y]);
        *e = [e[0].min(x), e[1].min(y), e[2].max(x), e[3].max(y)];
    }
    b.map(|[x0, y0, x1, y1]| {
        [
            x0.saturating_sub(margin),
            y0.saturating_sub(margin),
            (x1 + margin + 1).min(w),
            (y1 + margin + 1).min(h),
        ]
    })
}

/// [`smooth_noisy_lights`] over the whole of the given frame.
fn smooth_in(
    color: &Image,
    albedo: Option<&Image>,
    light: &[bool],
    rim: &[bool],
    flatness: f32,
    out: &mut Image,
) {
    let (w, h) = (color.width, color.height);
    // Averaged demodulated: a lit surface the search took for a light (a sunlit patch on a
    // checkered floor) keeps its texture (tune-sunroom 1 spp: relMSE 0.0469 → 0.0474 on the
    // colour, → 0.0428 demodulated).
    let divisor = |i: usize, k: usize| -> f32 {
        let Some(a) = albedo else { return 1.0 };
        let v = a.data[i * a.channels + k.min(a.channels - 1)];
        if v.is_finite() {
            v.max(ALBEDO_FLOOR)
        } else {
            1.0
        }
    };
    let demod: Vec<f32> = (0..w * h * 3)
        .map(|j| color.data[j] / divisor(j / 3, j % 3))
        .collect();
    let lum: Vec<f32> = demod
        .chunks_exact(3)
        .map(|c| luminance([c[0], c[1], c[2]]))
        .collect();
    let interior = interior(light, rim, &lum, flatness, w, h);
    if !interior.iter().any(|&b| b) {
        return;
    }
    // Per pixel: [is interior, L, L², r, g, b], so that window means give the interior
    // pixels' share, luminance moments and mean colour.
    let mut planes = vec![0.0f32; w * h * 6];
    for (i, p) in planes.chunks_exact_mut(6).enumerate() {
        let c = &demod[i * 3..i * 3 + 3];
        if interior[i] && c.iter().all(|v| v.is_finite()) {
            let l = lum[i];
            p.copy_from_slice(&[1.0, l, l * l, c[0], c[1], c[2]]);
        }
    }
    let m = box_mean(&planes, w, h, 6, RADIUS);
    for (i, s) in m.chunks_exact(6).enumerate() {
        if !interior[i] || s[0] <= 0.0 {
            continue;
        }
        let mean = s[1] / s[0];
        let spread = (s[2] / s[0] - mean * mean).max(0.0).sqrt();
        if spread > flatness * mean {
            for k in 0..3 {
                out.data[i * 3 + k] = s[3 + k] / s[0] * divisor(i, k);
            }
        }
    }
}

/// The 8 neighbours of pixel `i` inside the frame.
fn neighbours(i: usize, w: usize, h: usize) -> impl Iterator<Item = Option<usize>> {
    let (x, y) = ((i % w) as isize, (i / w) as isize);
    (-1isize..=1)
        .flat_map(|dy| (-1isize..=1).map(move |dx| (dx, dy)))
        .filter(|&d| d != (0, 0))
        .map(move |(dx, dy)| {
            let (nx, ny) = (x + dx, y + dy);
            let inside = nx >= 0 && ny >= 0 && (nx as usize) < w && (ny as usize) < h;
            inside.then(|| ny as usize * w + nx as usize)
        })
}

/// The lights' interior: light pixels and holes (rim pixels enclosed by the light, with at
/// least [`HOLE_NEIGHBOURS`] light neighbours and no darker than the darkest of them by more
/// than `flatness`: a speckle of bounce light on top of the emission, not the light's edge,
/// whose pixels mix the light with something darker), less every such pixel with a
/// neighbour outside them (or outside the frame): those mix the light with its surroundings.
fn interior(
    light: &[bool],
    rim: &[bool],
    lum: &[f32],
    flatness: f32,
    w: usize,
    h: usize,
) -> Vec<bool> {
    let inside: Vec<bool> = (0..w * h)
        .map(|i| {
            if light[i] {
                return true;
            }
            if !rim[i] {
                return false;
            }
            let mut lit = 0;
            let mut darkest = f32::INFINITY;
            for n in neighbours(i, w, h) {
                match n {
                    Some(n) if light[n] => {
                        lit += 1;
                        darkest = darkest.min(lum[n]);
                    }
                    Some(n) if rim[n] => {}
                    _ => return false,
                }
            }
            lit >= HOLE_NEIGHBOURS && lum[i] >= (1.0 - flatness) * darkest
        })
        .collect();
    (0..w * h)
        .map(|i| inside[i] && neighbours(i, w, h).all(|n| n.is_some_and(|n| inside[n])))
        .collect()
}
