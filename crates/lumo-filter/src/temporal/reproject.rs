//! The per-pixel half of the temporal filter: reading a frame's samples, reprojecting the
//! history with per-tap validity, the moving averages and the variance estimate.

use lumo_image::{luminance, Image};

use super::{divisor, Resample, TemporalFrame, TemporalParams};
use crate::common::gbuffer::{is_background, Features};

/// What reprojection compares between a pixel and a history tap.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Surface {
    /// Camera distance; 0 on background.
    pub depth: f32,
    /// Unit normal (0 where not finite).
    pub normal: [f32; 3],
    /// The normal was finite.
    pub normal_ok: bool,
}

impl Surface {
    fn background(&self) -> bool {
        self.depth == 0.0
    }

    /// Whether `prev` (a history tap) shows the same surface as `self`: background only
    /// matches background; geometry needs finite normals, a relative depth difference within
    /// the tolerance and normals within the minimum dot product.
    pub fn matches(&self, prev: &Surface, p: &TemporalParams) -> bool {
        if self.background() || prev.background() {
            return self.background() && prev.background();
        }
        let dot = self.normal[0] * prev.normal[0]
            + self.normal[1] * prev.normal[1]
            + self.normal[2] * prev.normal[2];
        self.normal_ok
            && prev.normal_ok
            && (prev.depth - self.depth).abs() <= p.depth_tolerance * self.depth
            && dot >= p.normal_min_dot
    }
}

/// One pixel of the current frame.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Sample {
    /// The albedo the colour is divided by; `None`: passed through (no usable albedo).
    pub divisor: Option<[f32; 3]>,
    /// Colour / albedo (0 where not `valid`).
    pub illum: [f32; 3],
    /// Luminance moments (l, l²) of `illum`.
    pub moments: [f32; 2],
    /// The sample is usable: not passed through, colour / albedo and its moments finite.
    pub valid: bool,
    pub surface: Surface,
}

impl Sample {
    /// Pixel `i` of `frame`, sanitised.
    pub fn read(frame: &TemporalFrame, i: usize) -> Self {
        let features = Features {
            depth: Some(frame.depth),
            position: frame.position,
            ..Features::default()
        };
        let depth = if is_background(&features, i) {
            0.0
        } else {
            frame.depth.data[i * frame.depth.channels]
        };
        let nc = frame.normal.channels;
        let n = &frame.normal.data[i * nc..i * nc + 3];
        let normal_ok = n.iter().all(|v| v.is_finite());
        let surface = Surface {
            depth,
            normal: if normal_ok {
                [n[0], n[1], n[2]]
            } else {
                [0.0; 3]
            },
            normal_ok,
        };
        let divisor = divisor(frame.albedo, i);
        let c = &frame.color.data[3 * i..3 * i + 3];
        let (illum, valid) = match divisor {
            Some(d) => {
                let v = [c[0] / d[0], c[1] / d[1], c[2] / d[2]];
                let l = luminance(v);
                let ok = v.iter().all(|x| x.is_finite()) && (l * l).is_finite();
                (if ok { v } else { [0.0; 3] }, ok)
            }
            None => ([0.0; 3], false),
        };
        let l = luminance(illum);
        Self {
            divisor,
            illum,
            moments: [l, l * l],
            valid,
            surface,
        }
    }
}

/// The state kept between frames.
#[derive(Debug)]
pub(super) struct History {
    pub w: usize,
    pub h: usize,
    /// Colour / albedo: the first À-Trous level's output (3 channels).
    pub color: Image,
    /// Accumulated luminance moments.
    pub moments: Vec<[f32; 2]>,
    /// History length; 0 = none.
    pub len: Vec<u32>,
    pub surface: Vec<Surface>,
    pub ids: Option<Vec<u32>>,
}

/// One pixel after reprojection and accumulation.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Accumulated {
    /// Accumulated colour / albedo (meaningful where `len` > 0).
    pub color: [f32; 3],
    pub moments: [f32; 2],
    /// History length including this frame; 0: nothing to show (passed through, or missing
    /// with no history).
    pub len: u32,
    /// The reprojected history colour, if any.
    pub history: Option<[f32; 3]>,
}

/// The reprojected history at pixel (x, y): colour, moments and length, bilinear over the
/// 2×2 taps around pixel + motion that pass the validity tests (weights renormalised).
fn reproject(
    p: &TemporalParams,
    hist: &History,
    frame: &TemporalFrame,
    cur: &Surface,
    x: usize,
    y: usize,
) -> Option<([f32; 3], [f32; 2], u32)> {
    let (w, h) = (hist.w, hist.h);
    let i = y * w + x;
    let (mx, my) = match frame.motion {
        Some(m) => (m.data[i * m.channels], m.data[i * m.channels + 1]),
        None => (0.0, 0.0),
    };
    let (px, py) = (x as f32 + mx, y as f32 + my);
    // Also rejects non-finite motion (the comparisons are false for NaN).
    if !(px > -1.0 && py > -1.0 && px < w as f32 && py < h as f32) {
        return None;
    }
    let (x0, y0) = (px.floor(), py.floor());
    let (fx, fy) = (px - x0, py - y0);
    let (x0, y0) = (x0 as isize, y0 as isize);
    let mut color = [0.0f32; 3];
    let mut moments = [0.0f32; 2];
    let mut sum = 0.0f32;
    let (mut best_w, mut len) = (-1.0f32, 0u32);
    for (dx, dy, wt) in [
        (0, 0, (1.0 - fx) * (1.0 - fy)),
        (1, 0, fx * (1.0 - fy)),
        (0, 1, (1.0 - fx) * fy),
        (1, 1, fx * fy),
    ] {
        let (tx, ty) = (x0 + dx, y0 + dy);
        if tx < 0 || ty < 0 || tx >= w as isize || ty >= h as isize {
            continue;
        }
        let t = ty as usize * w + tx as usize;
        if hist.len[t] == 0 || !cur.matches(&hist.surface[t], p) {
            continue;
        }
        if let (Some(ci), Some(hi)) = (frame.ids, hist.ids.as_ref()) {
            if ci[i] != hi[t] {
                continue;
            }
        }
        let c = &hist.color.data[3 * t..3 * t + 3];
        for k in 0..3 {
            color[k] += wt * c[k];
        }
        moments[0] += wt * hist.moments[t][0];
        moments[1] += wt * hist.moments[t][1];
        sum += wt;
        if wt > best_w {
            best_w = wt;
            len = hist.len[t];
        }
    }
    // SVGF's threshold: a history made of slivers of taps is not trusted.
    if sum < 0.01 {
        return None;
    }
    let inv = 1.0 / sum;
    let mut color = color.map(|c| c * inv);
    // All four bilinear taps valid: the sharper Catmull-Rom colour when its 4×4 taps all are.
    if p.resample == Resample::CatmullRom && sum > 0.999 {
        if let Some(c) = catmull_rom(p, hist, frame, cur, i, x0, y0, fx, fy) {
            color = c;
        }
    }
    Some((color, moments.map(|m| m * inv), len))
}

/// The Catmull-Rom (cubic convolution, a = −½) weights of the four taps at −1, 0, 1, 2 for a
/// point at fraction `t` ∈ [0, 1) past tap 0. They sum to 1 and reproduce polynomials up to
/// degree 2 exactly (bilinear only up to degree 1).
pub(super) fn catmull_rom_weights(t: f32) -> [f32; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ]
}

/// The history colour at (x0 + fx, y0 + fy) by Catmull-Rom over the 4×4 taps x0 − 1 … x0 + 2
/// (likewise y), clamped per channel to the range of the four central taps (the cubic
/// overshoots at steps; the clamp keeps it from ringing and from going negative). `None`
/// when a tap is outside the image or fails the validity tests of [`reproject`].
#[allow(clippy::too_many_arguments)]
fn catmull_rom(
    p: &TemporalParams,
    hist: &History,
    frame: &TemporalFrame,
    cur: &Surface,
    i: usize,
    x0: isize,
    y0: isize,
    fx: f32,
    fy: f32,
) -> Option<[f32; 3]> {
    let (w, h) = (hist.w as isize, hist.h as isize);
    if x0 < 1 || y0 < 1 || x0 + 2 >= w || y0 + 2 >= h {
        return None;
    }
    let (wx, wy) = (catmull_rom_weights(fx), catmull_rom_weights(fy));
    let mut color = [0.0f32; 3];
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for (j, wyj) in wy.iter().enumerate() {
        for (k, wxk) in wx.iter().enumerate() {
            let t = (y0 + j as isize - 1) as usize * hist.w + (x0 + k as isize - 1) as usize;
            if hist.len[t] == 0 || !cur.matches(&hist.surface[t], p) {
                return None;
            }
            if let (Some(ci), Some(hi)) = (frame.ids, hist.ids.as_ref()) {
                if ci[i] != hi[t] {
                    return None;
                }
            }
            let c = &hist.color.data[3 * t..3 * t + 3];
            let wt = wyj * wxk;
            let central = (1..=2).contains(&j) && (1..=2).contains(&k);
            for ch in 0..3 {
                color[ch] += wt * c[ch];
                if central {
                    lo[ch] = lo[ch].min(c[ch]);
                    hi[ch] = hi[ch].max(c[ch]);
                }
            }
        }
    }
    Some([0, 1, 2].map(|ch| color[ch].clamp(lo[ch], hi[ch])))
}

/// A pixel's reprojected history: colour / albedo, luminance moments, length.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Prev {
    pub color: [f32; 3],
    pub moments: [f32; 2],
    pub len: u32,
}

/// The history scaled by `scale` (the lighting's change measured by re-shading; `None` or 1:
/// unchanged): colour and first moment by ρ, second moment by ρ².
pub(super) fn rescale_history(pr: Prev, scale: Option<f32>) -> Prev {
    match scale {
        Some(r) if r != 1.0 => Prev {
            color: pr.color.map(|c| c * r),
            moments: [pr.moments[0] * r, pr.moments[1] * r * r],
            len: pr.len,
        },
        _ => pr,
    }
}

/// Reprojects pixel (x, y)'s history (`None`: none, or the pixel is passed through).
pub(super) fn reproject_pixel(
    p: &TemporalParams,
    hist: Option<&History>,
    frame: &TemporalFrame,
    samples: &[Sample],
    x: usize,
    y: usize,
) -> Option<Prev> {
    let s = &samples[y * frame.color.width + x];
    s.divisor?;
    let (color, moments, len) = reproject(p, hist?, frame, &s.surface, x, y)?;
    Some(Prev {
        color,
        moments,
        len,
    })
}

/// `prev` with its colour's luminance clamped to `bounds` (lo, hi) by scaling the colour
/// (neighbourhood clamping, [`TemporalParams::clamp_sigmas`]); unchanged without bounds, inside
/// them, or where its luminance is not positive. The clamp only ever moves the luminance
/// towards the interval.
pub(super) fn clamp_history(mut prev: Prev, bounds: Option<[f32; 2]>) -> Prev {
    let Some([lo, hi]) = bounds else {
        return prev;
    };
    let l = luminance(prev.color);
    if !(l > 0.0) {
        return prev;
    }
    let target = if l > hi {
        hi.max(0.0)
    } else if l < lo {
        lo
    } else {
        return prev;
    };
    let s = target / l;
    if s.is_finite() {
        prev.color = prev.color.map(|c| c * s);
    }
    prev
}

/// Blends sample `s` into its reprojected history `prev`. `lambda` ∈ [0, 1] is the history
/// rejection of [`super::gradient`]: the blend weights become (1 − λ)·α + λ and, where λ > 0,
/// the history length is cut to what that weight means (⌈1 / weight⌉ frames), so a young
/// history's variance is estimated spatially again.
pub(super) fn blend(
    p: &TemporalParams,
    s: &Sample,
    prev: Option<Prev>,
    lambda: f32,
) -> Accumulated {
    if s.divisor.is_none() {
        return Accumulated::default();
    }
    match (s.valid, prev) {
        (true, Some(pr)) => {
            let mut len = (pr.len + 1).min(p.max_history);
            let a = p.alpha.max(1.0 / len as f32);
            let am = p.alpha_moments.max(1.0 / len as f32);
            let (a, am) = if lambda > 0.0 {
                let (a, am) = (a + lambda * (1.0 - a), am + lambda * (1.0 - am));
                len = len.min((1.0 / a).ceil() as u32).max(1);
                (a, am)
            } else {
                (a, am)
            };
            Accumulated {
                color: [0, 1, 2].map(|k| pr.color[k] + a * (s.illum[k] - pr.color[k])),
                moments: [0, 1].map(|k| pr.moments[k] + am * (s.moments[k] - pr.moments[k])),
                len,
                history: Some(pr.color),
            }
        }
        (true, None) => Accumulated {
            color: s.illum,
            moments: s.moments,
            len: 1,
            history: None,
        },
        // A missing sample keeps its history as it is.
        (false, Some(pr)) => Accumulated {
            color: pr.color,
            moments: pr.moments,
            len: pr.len,
            history: Some(pr.color),
        },
        (false, None) => Accumulated::default(),
    }
}

/// The luminance variance of colour / albedo at pixel (x, y): from the accumulated moments
/// once the history is long enough, else from their mean over the window of consistent
/// pixels, boosted by `variance_history / len` (SVGF).
pub(super) fn variance(
    p: &TemporalParams,
    samples: &[Sample],
    acc: &[Accumulated],
    w: usize,
    h: usize,
    x: usize,
    y: usize,
) -> f32 {
    let a = &acc[y * w + x];
    let v = if a.len == 0 {
        0.0
    } else if a.len >= p.variance_history {
        let v = a.moments[1] - a.moments[0] * a.moments[0];
        if p.scale_variance {
            v * (1.0 / a.len as f32).max(p.alpha / (2.0 - p.alpha))
        } else {
            v
        }
    } else {
        let r = p.spatial_radius;
        let cur = &samples[y * w + x].surface;
        let (mut m1, mut m2, mut n) = (0.0f32, 0.0f32, 0.0f32);
        for yy in y.saturating_sub(r)..(y + r + 1).min(h) {
            for xx in x.saturating_sub(r)..(x + r + 1).min(w) {
                let j = yy * w + xx;
                if acc[j].len > 0 && cur.matches(&samples[j].surface, p) {
                    m1 += acc[j].moments[0];
                    m2 += acc[j].moments[1];
                    n += 1.0;
                }
            }
        }
        if n > 0.0 {
            let (m1, m2) = (m1 / n, m2 / n);
            (m2 - m1 * m1) * (p.variance_history as f32 / a.len as f32)
        } else {
            0.0
        }
    };
    if v.is_finite() && v > 0.0 {
        v
    } else {
        0.0
    }
}
