//! The per-pixel input rules of input.rs (`Input::pixel`, `Input::variance`) for whole runs of
//! pixels, written branch-free over lanes so that they vectorise.
//!
//! Why: the images are interleaved (RGB, xyz), and on interleaved data the compiler kept the
//! conversion scalar (~13 % of a 512² filter). Each run is first copied into [`LANES`] lanes
//! per channel; the arithmetic on the lanes then compiles to vector code. The results equal
//! the per-pixel rules bit for bit (`tests/passes.rs`).

use lumo_image::{luminance, Image};

use super::input::Input;
use crate::common::albedo::ALBEDO_EPS;

/// The colour and validity planes of one block's columns being filled.
pub(super) struct ColorPlanes<'a> {
    pub(super) r: &'a mut [f32],
    pub(super) g: &'a mut [f32],
    pub(super) b: &'a mut [f32],
    pub(super) v: &'a mut [f32],
}

/// `n` albedo pixels from pixel `i0` (all channels).
pub(super) fn albedo_row(a: Option<&Image>, i0: usize, n: usize) -> &[f32] {
    a.map_or(&[][..], |a| &a.data[i0 * a.channels..(i0 + n) * a.channels])
}

/// Lanes of the input conversion loops: runs of interleaved pixels are first copied into
/// this many lanes per channel, so that the arithmetic after it vectorises (on the
/// interleaved data the compiler kept it scalar: ~13 % of a 512² filter).
pub(super) use lumo_simd::LANES;

/// Pixels `t0 .. t0 + n` (n ≤ [`LANES`]) of interleaved `data` with `C` channels into the first
/// `n` of three lanes per channel: lane k from channel k, or from channel 0 when `C` is 1
/// (grey); lanes of channels the data lacks are left as they are.
#[inline(always)]
fn to_lanes<const C: usize>(data: &[f32], t0: usize, n: usize, out: &mut [[f32; LANES]; 3]) {
    // Sliced first, so the loops carry no bounds checks.
    #[inline(always)]
    fn copy<const C: usize>(d: &[f32], n: usize, out: &mut [[f32; LANES]; 3]) {
        for t in 0..n {
            for (k, o) in out.iter_mut().enumerate() {
                if C == 1 {
                    o[t] = d[t];
                } else if k < C {
                    o[t] = d[C * t + k];
                }
            }
        }
    }
    // A constant count for whole runs: that copy compiles to vector loads and permutes.
    if n == LANES {
        copy::<C>(&data[C * t0..C * (t0 + LANES)], LANES, out);
    } else {
        copy::<C>(&data[C * t0..C * (t0 + n)], n, out);
    }
}

/// `albedo_divisor` for one pixel's albedo, branch-free: whether it is usable (finite, some
/// channel at least [`ALBEDO_EPS`]), and the divisor (each channel clamped to at least that).
#[inline(always)]
fn albedo_lane(a: [f32; 3]) -> (bool, [f32; 3]) {
    let finite = a[0].is_finite() & a[1].is_finite() & a[2].is_finite();
    let usable = finite & (a[0].max(a[1]).max(a[2]) >= ALBEDO_EPS);
    (usable, a.map(|c| c.max(ALBEDO_EPS)))
}

/// Colour (divided by the albedo when `AC` > 0, the albedo's channel count) and validity of
/// a run of pixels, with the rules of `Input::pixel`, written branch-free; colour is 0 where
/// the validity is.
#[inline(always)]
fn color_row<const AC: usize>(color: &[f32], albedo: &[f32], out: ColorPlanes) {
    let n = out.r.len();
    let mut t0 = 0;
    while t0 < n {
        let m = LANES.min(n - t0);
        let (o, _) = color_lanes::<AC>(color, albedo, t0, m);
        out.r[t0..t0 + m].copy_from_slice(&o[0][..m]);
        out.g[t0..t0 + m].copy_from_slice(&o[1][..m]);
        out.b[t0..t0 + m].copy_from_slice(&o[2][..m]);
        out.v[t0..t0 + m].copy_from_slice(&o[3][..m]);
        t0 += LANES;
    }
}

/// Pixels `t0 .. t0 + m` (m ≤ LANES) of a run as lanes: colour (divided by the albedo when
/// `AC` > 0), validity, and whether the input colour itself was finite (1) or missing (0).
/// Lanes past the run hold colour 0 and albedo 1 (valid and finite; callers ignore them).
#[inline(always)]
fn color_lanes<const AC: usize>(
    color: &[f32],
    albedo: &[f32],
    t0: usize,
    m: usize,
) -> ([[f32; LANES]; 4], [f32; LANES]) {
    let mut c = [[0.0f32; LANES]; 3];
    let mut a = [[1.0f32; LANES]; 3];
    to_lanes::<3>(color, t0, m, &mut c);
    if AC > 0 {
        to_lanes::<AC>(albedo, t0, m, &mut a);
    }
    let mut o = [[0.0f32; LANES]; 4];
    let mut finite = [0.0f32; LANES];
    for t in 0..LANES {
        finite[t] = (c[0][t].is_finite() & c[1][t].is_finite() & c[2][t].is_finite()) as u8 as f32;
    }
    for t in 0..LANES {
        let mut rgb = [c[0][t], c[1][t], c[2][t]];
        let mut ok = true;
        if AC > 0 {
            let (usable, divisor) = albedo_lane([a[0][t], a[1][t], a[2][t]]);
            ok = usable;
            for k in 0..3 {
                rgb[k] /= divisor[k];
            }
        }
        ok &= rgb[0].is_finite() & rgb[1].is_finite() & rgb[2].is_finite();
        // Denormals flushed to 0 (they would slow every product they enter); 0 where
        // invalid.
        let f = |x: f32| if ok && x.abs() >= 1e-30 { x } else { 0.0 };
        for k in 0..3 {
            o[k][t] = f(rgb[k]);
        }
        o[3][t] = ok as u8 as f32;
    }
    (o, finite)
}

/// Statistics of a run of `n` pixels (the rules of `Input::pixel`): the |luminance| of the
/// valid pixels and their count, in eight partial sums (pixel k of the first n − n % 8 into
/// sum k % 8, the rest into sum 0, in order: a fixed order on any thread count), and the
/// number of pixels whose colour is not finite.
#[inline(always)]
fn color_stats_run<const AC: usize>(
    color: &[f32],
    albedo: &[f32],
    n: usize,
) -> ([f32; 8], [f32; 8], usize) {
    let mut lum = [0.0f32; 8];
    let mut valid = [0.0f32; 8];
    let mut finite = 0.0f32;
    let n8 = n - n % 8;
    let mut t0 = 0;
    while t0 < n {
        let m = LANES.min(n - t0);
        let (o, fin) = color_lanes::<AC>(color, albedo, t0, m);
        let mut l = [0.0f32; LANES];
        for t in 0..LANES {
            l[t] = (0.2126 * o[0][t] + 0.7152 * o[1][t] + 0.0722 * o[2][t]).abs();
        }
        if t0 + LANES <= n8 {
            for h in 0..LANES / 8 {
                for k in 0..8 {
                    lum[k] += l[8 * h + k];
                    valid[k] += o[3][8 * h + k];
                }
            }
            finite += fin.iter().sum::<f32>();
        } else {
            for t in 0..m {
                let k = if t0 + t < n8 { t % 8 } else { 0 };
                lum[k] += l[t];
                valid[k] += o[3][t];
                finite += fin[t];
            }
        }
        t0 += LANES;
    }
    (lum, valid, n - finite as usize)
}

/// [`color_stats_run`] for the colour of `inp` (demodulated when asked).
#[inline(always)]
pub(super) fn color_stats(inp: &Input, i0: usize, n: usize) -> ([f32; 8], [f32; 8], usize) {
    let color = &inp.color.data[3 * i0..3 * (i0 + n)];
    let albedo = inp.features.albedo.filter(|_| inp.demodulate);
    match albedo.map(|a| a.channels) {
        None => color_stats_run::<0>(color, &[], n),
        Some(1) => color_stats_run::<1>(color, albedo_row(albedo, i0, n), n),
        Some(3) => color_stats_run::<3>(color, albedo_row(albedo, i0, n), n),
        Some(4) => color_stats_run::<4>(color, albedo_row(albedo, i0, n), n),
        Some(_) => {
            // Unusual albedo layouts: per pixel, in the same partial-sum order.
            let (mut lum, mut valid, mut missing) = ([0.0f32; 8], [0.0f32; 8], 0);
            let n8 = n - n % 8;
            for t in 0..n {
                let c = &color[3 * t..3 * t + 3];
                missing += !(c[0].is_finite() && c[1].is_finite() && c[2].is_finite()) as usize;
                let px = inp.pixel(i0 + t);
                let v = px.valid as u8 as f32;
                let [r, g, b] = px.rgb.map(|x| x * v);
                let k = if t < n8 { t % 8 } else { 0 };
                lum[k] += (0.2126 * r + 0.7152 * g + 0.0722 * b).abs();
                valid[k] += v;
            }
            (lum, valid, missing)
        }
    }
}

/// A run of pixels' variance from `i0` into `out`, in units of mean luminance² (`scale` =
/// 1/ml²), with the rules of `Input::variance`; tiny values are flushed to 0, so Σ w²·var
/// never reaches the (slow) denormal range.
#[inline(always)]
pub(super) fn variance_run(inp: &Input, i0: usize, scale: f32, out: &mut [f32]) {
    let n = out.len();
    let Some(var) = inp.features.variance else {
        out.fill(0.0);
        return;
    };
    let albedo = inp.features.albedo.filter(|_| inp.demodulate);
    let vs = &var.data[var.channels * i0..var.channels * (i0 + n)];
    macro_rules! go {
        ($vc:literal) => {
            match albedo.map(|a| a.channels) {
                None => variance_row::<$vc, 0>(vs, &[], scale, out),
                Some(1) => variance_row::<$vc, 1>(vs, albedo_row(albedo, i0, n), scale, out),
                Some(3) => variance_row::<$vc, 3>(vs, albedo_row(albedo, i0, n), scale, out),
                Some(4) => variance_row::<$vc, 4>(vs, albedo_row(albedo, i0, n), scale, out),
                Some(_) => variance_pixels(inp, i0, scale, out),
            }
        };
    }
    match var.channels {
        1 => go!(1),
        3 => go!(3),
        4 => go!(4),
        _ => variance_pixels(inp, i0, scale, out),
    }
}

/// [`variance_run`] pixel by pixel, for unusual channel counts.
fn variance_pixels(inp: &Input, i0: usize, scale: f32, out: &mut [f32]) {
    for (t, o) in out.iter_mut().enumerate() {
        let v = inp.variance(i0 + t) * scale;
        *o = if v > 1e-12 { v } else { 0.0 };
    }
}

/// [`variance_run`] for variance with `VC` channels (1, 3 or 4) and, when demodulating, an
/// albedo with `AC` channels (0: not demodulating), copied into lanes first so that the
/// arithmetic vectorises; the operations of `Input::variance`, written branch-free.
#[inline(always)]
fn variance_row<const VC: usize, const AC: usize>(
    var: &[f32],
    albedo: &[f32],
    scale: f32,
    out: &mut [f32],
) {
    let n = out.len();
    let mut t0 = 0;
    while t0 < n {
        let m = LANES.min(n - t0);
        let mut v = [[0.0f32; LANES]; 3];
        let mut a = [[1.0f32; LANES]; 3];
        to_lanes::<VC>(var, t0, m, &mut v);
        if AC > 0 {
            to_lanes::<AC>(albedo, t0, m, &mut a);
        }
        let mut o = [0.0f32; LANES];
        for t in 0..LANES {
            let x = if VC >= 3 {
                luminance([v[0][t], v[1][t], v[2][t]])
            } else {
                v[0][t]
            };
            let mut x = if x.is_finite() && x > 0.0 { x } else { 0.0 };
            if AC > 0 {
                // `albedo_divisor` and `illumination_variance`: pass-through pixels (no
                // usable albedo) have no illumination variance.
                let (usable, divisor) = albedo_lane([a[0][t], a[1][t], a[2][t]]);
                let l = luminance(divisor).max(ALBEDO_EPS);
                x = if usable { x / (l * l) } else { 0.0 };
            }
            let x = x * scale;
            o[t] = if x > 1e-12 { x } else { 0.0 };
        }
        out[t0..t0 + m].copy_from_slice(&o[..m]);
        t0 += LANES;
    }
}

/// A run of pixels from `i0` into colour and validity planes, with the rules of
/// `Input::pixel` (colour 0 where the validity is).
#[inline(always)]
pub(super) fn color_run(inp: &Input, i0: usize, out: ColorPlanes) {
    let n = out.r.len();
    let color = &inp.color.data[3 * i0..3 * (i0 + n)];
    let albedo = inp.features.albedo.filter(|_| inp.demodulate);
    match albedo.map(|a| a.channels) {
        None => color_row::<0>(color, &[], out),
        Some(1) => color_row::<1>(color, albedo_row(albedo, i0, n), out),
        Some(3) => color_row::<3>(color, albedo_row(albedo, i0, n), out),
        Some(4) => color_row::<4>(color, albedo_row(albedo, i0, n), out),
        Some(_) => {
            for t in 0..n {
                let px = inp.pixel(i0 + t);
                let v = px.valid as u8 as f32;
                out.r[t] = px.rgb[0] * v;
                out.g[t] = px.rgb[1] * v;
                out.b[t] = px.rgb[2] * v;
                out.v[t] = v;
            }
        }
    }
}
