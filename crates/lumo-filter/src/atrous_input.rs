//! Reading the À-Trous inputs straight into the working layout, and writing the result back
//! (with albedo demodulation and pass-through pixels folded into both).
//!
//! Why not `Prepared` + `demodulate` as the other filters do: at 512² the kernel itself takes
//! a few milliseconds, and building a dozen intermediate full-image planes (serially, in fresh
//! page-faulted memory) took longer than that. Here two parallel passes read each input
//! pixel where it lies: one for the image-wide statistics (mean luminance, scene extent), one
//! that fills every block. The per-pixel rules are those of `Prepared::new` and
//! `demodulate`, which the tests use as the reference.

use lumo_image::{luminance, Image};
use rayon::prelude::*;

use crate::albedo::{albedo_divisor, illumination_variance, ALBEDO_EPS};
use crate::atrous::BACKGROUND_SCALE;
use crate::atrous_kernel::{K, KA};
use crate::atrous_layout::{Layout, CW, M, QW};
use crate::gbuffer::{depth_is_background, flush, position_is_background, Features};
use crate::passthrough::passed;

/// The input images of one call, and whether colour is demodulated by the albedo.
pub(crate) struct Input<'a> {
    pub color: &'a Image,
    pub features: &'a Features<'a>,
    /// Divide colour by the albedo (`features.albedo` is then present).
    pub demodulate: bool,
    /// Use `features.variance` (SVGF's variance-guided colour weight).
    pub use_variance: bool,
}

/// One input pixel as the filter sees it.
struct Pixel {
    /// Colour (or illumination), denormals flushed; 0 where not `valid`.
    rgb: [f32; 3],
    /// Colour usable (finite, and with a usable albedo when demodulating).
    valid: bool,
}

/// Image-wide values the scales depend on.
pub(crate) struct Stats {
    /// Mean |luminance| of the valid pixels (1 if there are none).
    pub mean_luminance: f32,
    /// Non-finite pixels of the input colour.
    pub missing: usize,
    /// Diagonal of the non-background positions' bounding box (1 if degenerate).
    pub extent: f32,
    /// Per coordinate, the largest non-background position (−inf if none).
    pub position_max: [f32; 3],
}

impl Input<'_> {
    fn pixel(&self, i: usize) -> Pixel {
        let c = &self.color.data[i * 3..i * 3 + 3];
        let mut rgb = [c[0], c[1], c[2]];
        let mut valid = true;
        if self.demodulate {
            match self.features.albedo.and_then(|a| albedo_divisor(a, i)) {
                Some(a) => {
                    for k in 0..3 {
                        rgb[k] /= a[k];
                    }
                }
                // Passed through unfiltered: no usable albedo.
                None => valid = false,
            }
        }
        valid &= rgb.iter().all(|v| v.is_finite());
        // Denormal inputs flushed to 0: they would slow every product they enter.
        let rgb = if valid { rgb.map(flush) } else { [0.0; 3] };
        Pixel { rgb, valid }
    }

    /// Luminance variance of the (demodulated) pixel, 0 where unknown or negative.
    fn variance(&self, i: usize) -> f32 {
        let Some(v) = self.features.variance.filter(|_| self.use_variance) else {
            return 0.0;
        };
        let p = &v.data[i * v.channels..][..v.channels];
        let x = if p.len() >= 3 {
            luminance([p[0], p[1], p[2]])
        } else {
            p[0]
        };
        let x = if x.is_finite() && x > 0.0 { x } else { 0.0 };
        if !self.demodulate {
            return x;
        }
        // Pass-through pixels (no usable albedo) have no illumination variance.
        match self.features.albedo.and_then(|a| albedo_divisor(a, i)) {
            Some(a) => illumination_variance(x, a),
            None => 0.0,
        }
    }
}

/// How the first level's feature and variance planes are filled.
pub(crate) struct FillScales {
    /// Variance divided by mean luminance².
    pub inv_ml2: f32,
    /// Normal coordinate scale, `None` when the normal weight is off.
    pub normal: Option<f32>,
    /// Position coordinate scale (after division by the extent), `None` when off.
    pub position: Option<f32>,
    pub inv_extent: f32,
    /// Per coordinate, the (scaled) position background pixels get.
    pub position_background: [f32; 3],
}

/// Partial statistics of one block's own columns.
struct BlockStats {
    lum: f64,
    valid: usize,
    missing: usize,
    lo: [f32; 3],
    hi: [f32; 3],
}

/// Aux plane that holds a block's background flags while `fill_block` fills it (the
/// luminance plane, which `level_aux` writes before any kernel reads it).
const BG_PLANE: usize = 1;

/// The colour and validity planes of one block's columns being filled.
struct ColorPlanes<'a> {
    r: &'a mut [f32],
    g: &'a mut [f32],
    b: &'a mut [f32],
    v: &'a mut [f32],
}

/// `n` albedo pixels from pixel `i0` (all channels).
fn albedo_row(a: Option<&Image>, i0: usize, n: usize) -> &[f32] {
    a.map_or(&[][..], |a| &a.data[i0 * a.channels..(i0 + n) * a.channels])
}

/// Lanes of the input conversion loops: runs of interleaved pixels are first copied into
/// this many lanes per channel, so that the arithmetic after it vectorises (on the
/// interleaved data the compiler kept it scalar: ~13 % of a 512² filter).
const LANES: usize = 16;

/// Runs `$body` with `$t0` and `$n` over `0..$len` in runs of [`LANES`] pixels and one
/// shorter run. In the whole runs `$n` is a constant, so loops over interleaved pixels in
/// `$body` compile to vector loads and permutes. (A macro rather than a function taking a
/// closure: a closure the compiler keeps out of line is not compiled with its caller's
/// target features.)
macro_rules! in_runs {
    ($len:expr, $t0:ident, $n:ident, $body:block) => {{
        let len = $len;
        let full = len / LANES * LANES;
        let mut start = 0;
        while start < full {
            let ($t0, $n) = (start, LANES);
            $body
            start += LANES;
        }
        if full < len {
            let ($t0, $n) = (full, len - full);
            $body
        }
    }};
}

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
fn color_stats(inp: &Input, i0: usize, n: usize) -> ([f32; 8], [f32; 8], usize) {
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
fn variance_run(inp: &Input, i0: usize, scale: f32, out: &mut [f32]) {
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
fn color_run(inp: &Input, i0: usize, out: ColorPlanes) {
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

/// First pass, reading only: the image-wide statistics, from each (strip, row) block's own
/// columns, summed block by block in block order (the same on any number of threads).
pub(crate) fn input_stats(inp: &Input, lay: Layout) -> Stats {
    let parts: Vec<BlockStats> = (0..lay.nch * lay.h)
        .into_par_iter()
        .map(|b| block_stats(inp, lay, b))
        .collect();
    let (mut lum, mut valid, mut missing) = (0.0f64, 0usize, 0usize);
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for st in &parts {
        lum += st.lum;
        valid += st.valid;
        missing += st.missing;
        for k in 0..3 {
            lo[k] = lo[k].min(st.lo[k]);
            hi[k] = hi[k].max(st.hi[k]);
        }
    }
    let mean = if valid > 0 {
        (lum / valid as f64) as f32
    } else {
        0.0
    };
    let d = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f32>().sqrt();
    Stats {
        mean_luminance: if mean.is_finite() && mean > 1e-12 {
            mean
        } else {
            1.0
        },
        missing,
        extent: if d.is_finite() && d > 1e-12 { d } else { 1.0 },
        position_max: hi,
    }
}

multiversion! {
    /// The statistics of block `b`'s own columns (see [`input_stats`]).
    fn block_stats(inp: &Input, lay: Layout, b: usize) -> BlockStats as block_stats_impl {
        let (c, y) = lay.strip_row(b);
        let (x0, len) = lay.strip(c);
        let i0 = y * lay.w + x0;
        let mut st = BlockStats {
            lum: 0.0,
            valid: 0,
            missing: 0,
            lo: [f32::INFINITY; 3],
            hi: [f32::NEG_INFINITY; 3],
        };
        // Mean luminance over every usable pixel (before the sparse grid, as `Prepared`).
        let (lum, valid, missing) = color_stats(inp, i0, len);
        st.missing = missing;
        let valid: f32 = valid.iter().sum();
        st.lum = lum.iter().map(|&l| l as f64).sum();
        st.valid = valid as usize;
        if let Some(p) = inp.features.position {
            let mut bg = [0.0f32; CW];
            let bgs = &mut bg[..len];
            background_row(inp.features, i0, bgs);
            let data = &p.data[i0 * p.channels..(i0 + len) * p.channels];
            match p.channels {
                3 => extent_run(3, data, bgs, &mut st.lo, &mut st.hi),
                4 => extent_run(4, data, bgs, &mut st.lo, &mut st.hi),
                c => extent_run(c, data, bgs, &mut st.lo, &mut st.hi),
            }
        }
        st
    }
}

/// Widens `lo`/`hi` to the positions (first 3 of `c` channels) of the pixels of a run that
/// `bgs` does not flag as background. Sixteen lanes of partial minima and maxima, so the loop
/// vectorises; min and max are exact, so the grouping does not change the result.
#[inline(always)]
fn extent_run(c: usize, pos: &[f32], bgs: &[f32], lo: &mut [f32; 3], hi: &mut [f32; 3]) {
    const N: usize = 16;
    let mut l = [[f32::INFINITY; N]; 3];
    let mut h = [[f32::NEG_INFINITY; N]; 3];
    let mut add = |t: usize, p: &[f32], bg: f32| {
        for k in 0..3 {
            // Background pixels (whose positions may be NaN) contribute nothing; nor does a
            // NaN coordinate (the comparisons are false). Written as compare-and-select, not
            // `f32::min`, whose NaN rule compiled to a scalar branchy loop; `vminps` is this.
            let keep = bg == 0.0;
            let vl = if keep { p[k] } else { f32::INFINITY };
            let vh = if keep { p[k] } else { f32::NEG_INFINITY };
            l[k][t] = if vl < l[k][t] { vl } else { l[k][t] };
            h[k][t] = if vh > h[k][t] { vh } else { h[k][t] };
        }
    };
    let full = bgs.len() / N * N;
    for (pc, bc) in pos[..full * c]
        .chunks_exact(N * c)
        .zip(bgs[..full].chunks_exact(N))
    {
        for t in 0..N {
            add(t, &pc[t * c..t * c + 3], bc[t]);
        }
    }
    for (t, (p, &bg)) in pos[full * c..]
        .chunks_exact(c)
        .zip(&bgs[full..])
        .enumerate()
    {
        add(t, &p[..3], bg);
    }
    for k in 0..3 {
        lo[k] = l[k].iter().fold(lo[k], |a, &b| a.min(b));
        hi[k] = h[k].iter().fold(hi[k], |a, &b| a.max(b));
    }
}

/// The number of feature coordinates the blocks will hold (normals 3, positions 3, or the
/// background coordinate 1).
pub(crate) fn feature_count(inp: &Input, s: &FillScales) -> usize {
    let f = inp.features;
    f.normal.zip(s.normal).map_or(0, |_| 3) + f.position.zip(s.position).map_or(1, |_| 3)
}

multiversion! {
    /// Fills block (strip `c`, row `y`): `blk` (K planes: colour, validity, variance) and
    /// `ab` (KA planes: the background flag in [`BG_PLANE`], the features from plane 2,
    /// scaled for the first level), margins included (0 beyond the image).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn fill_block(
        inp: &Input,
        lay: Layout,
        sparse: usize,
        s: &FillScales,
        c: usize,
        y: usize,
        blk: &mut [f32],
        ab: &mut [f32],
    ) as fill_block_impl {
        let mask = sparse - 1;
        let w = lay.w;
        let (x0, _) = lay.strip(c);
        let ja = M.saturating_sub(x0);
        let span = lay.span();
        let jb = (w + M - x0).min(span);
        // Columns beyond the image hold 0 (validity 0: taps there add nothing); the rest of
        // every plane in use is written here or per level. Columns beyond the span are not
        // read.
        for (planes, buf) in [(K, &mut *blk), (KA, &mut *ab)] {
            for k in 0..planes {
                buf[k * QW..k * QW + ja].fill(0.0);
                buf[k * QW + jb..k * QW + span].fill(0.0);
            }
        }
        if ja >= jb {
            return;
        }
        let i0 = y * w + x0 + ja - M;
        {
            let (rgb, vrest) = blk.split_at_mut(3 * QW);
            let (r, gb) = rgb.split_at_mut(QW);
            let (g, b) = gb.split_at_mut(QW);
            let planes = ColorPlanes {
                r: &mut r[ja..jb],
                g: &mut g[ja..jb],
                b: &mut b[ja..jb],
                v: &mut vrest[..QW][ja..jb],
            };
            color_run(inp, i0, planes);
        }
        if mask != 0 {
            let on_row = y & mask == 0;
            for j in ja..jb {
                let x = x0 + j - M;
                if !(on_row && x & mask == 0) {
                    for k in 0..4 {
                        blk[k * QW + j] = 0.0;
                    }
                }
            }
        }
        let (head, feat) = ab.split_at_mut(2 * QW);
        let bgs = &mut head[BG_PLANE * QW..][ja..jb];
        background_row(inp.features, i0, bgs);
        let bgs = &*bgs;
        if inp.use_variance {
            variance_run(inp, i0, s.inv_ml2, &mut blk[4 * QW + ja..4 * QW + jb]);
        } else {
            blk[4 * QW + ja..4 * QW + jb].fill(0.0);
        }
        let f = inp.features;
        let mut k = 0;
        if let Some((n, sn)) = f.normal.zip(s.normal) {
            let (n0, rest) = feat.split_at_mut(QW);
            let (n1, n2) = rest.split_at_mut(QW);
            let out = [&mut n0[ja..jb], &mut n1[ja..jb], &mut n2[ja..jb]];
            let data = &n.data[i0 * n.channels..(i0 + jb - ja) * n.channels];
            match n.channels {
                3 => normal_row(3, data, sn, out),
                4 => normal_row(4, data, sn, out),
                c => normal_row(c, data, sn, out),
            }
            k = 3;
        }
        let feat = &mut feat[k * QW..];
        match f.position.zip(s.position) {
            Some((p, sx)) => {
                let (p0, rest) = feat.split_at_mut(QW);
                let (p1, p2) = rest.split_at_mut(QW);
                let out = [&mut p0[ja..jb], &mut p1[ja..jb], &mut p2[ja..jb]];
                let data = &p.data[i0 * p.channels..(i0 + jb - ja) * p.channels];
                let scale = s.inv_extent * sx;
                let bgv = s.position_background;
                match p.channels {
                    3 => position_row(3, data, bgs, scale, bgv, out),
                    4 => position_row(4, data, bgs, scale, bgv, out),
                    c => position_row(c, data, bgs, scale, bgv, out),
                }
            }
            None => {
                for (o, &bg) in feat[ja..jb].iter_mut().zip(bgs) {
                    *o = bg * BACKGROUND_SCALE;
                }
            }
        }
    }
}

/// Fills every block of `src` and `aux` (see [`fill_block`]), rows in parallel.
pub(crate) fn fill_all(
    inp: &Input,
    lay: Layout,
    sparse: usize,
    s: &FillScales,
    src: &mut [f32],
    aux: &mut [f32],
) {
    src.par_chunks_mut(K * QW)
        .zip(aux.par_chunks_mut(KA * QW))
        .enumerate()
        .for_each(|(b, (blk, ab))| {
            let (c, y) = lay.strip_row(b);
            fill_block(inp, lay, sparse, s, c, y, blk, ab);
        });
}

#[inline(always)]
fn background_row(f: &Features, i0: usize, out: &mut [f32]) {
    let n = out.len();
    out.fill(0.0);
    if let Some(d) = f.depth {
        let data = &d.data[i0 * d.channels..(i0 + n) * d.channels];
        // Constant channel counts inlined separately, so that those loops vectorise.
        match d.channels {
            1 => depth_background(1, data, out),
            3 => depth_background(3, data, out),
            4 => depth_background(4, data, out),
            c => depth_background(c, data, out),
        }
    }
    if let Some(p) = f.position {
        let data = &p.data[i0 * p.channels..(i0 + n) * p.channels];
        match p.channels {
            3 => position_background(3, data, out),
            4 => position_background(4, data, out),
            c => position_background(c, data, out),
        }
    }
}

/// Sets `out` to 1 where the depth (first of `c` channels) is 0 or not finite.
#[inline(always)]
fn depth_background(c: usize, depth: &[f32], out: &mut [f32]) {
    for (o, d) in out.iter_mut().zip(depth.chunks_exact(c)) {
        *o = o.max(depth_is_background(d[0]) as u8 as f32);
    }
}

/// Sets `out` to 1 where a position (first 3 of `c` channels) is not finite.
#[inline(always)]
fn position_background(c: usize, pos: &[f32], out: &mut [f32]) {
    for (o, p) in out.iter_mut().zip(pos.chunks_exact(c)) {
        *o = o.max(position_is_background(p) as u8 as f32);
    }
}

/// Scaled normal planes of a run of pixels (`c` channels each, the first 3 used); 0 where
/// not finite.
#[inline(always)]
fn normal_row(c: usize, data: &[f32], scale: f32, out: [&mut [f32]; 3]) {
    let [o0, o1, o2] = out;
    in_runs!(o0.len(), t0, n, {
        // Sliced first, so the loop carries no bounds checks.
        let d = &data[t0 * c..(t0 + n) * c];
        let (a0, a1, a2) = (
            &mut o0[t0..t0 + n],
            &mut o1[t0..t0 + n],
            &mut o2[t0..t0 + n],
        );
        for t in 0..n {
            a0[t] = finite_scaled(d[t * c], scale);
            a1[t] = finite_scaled(d[t * c + 1], scale);
            a2[t] = finite_scaled(d[t * c + 2], scale);
        }
    });
}

/// `v · scale`, or 0 where `v` is not finite.
#[inline(always)]
fn finite_scaled(v: f32, scale: f32) -> f32 {
    if v.is_finite() {
        v * scale
    } else {
        0.0
    }
}

/// Scaled position planes of a run of pixels (`c` channels each, the first 3 used); the
/// background value where `bgs` flags the pixel.
#[inline(always)]
fn position_row(
    c: usize,
    data: &[f32],
    bgs: &[f32],
    scale: f32,
    bgv: [f32; 3],
    out: [&mut [f32]; 3],
) {
    let [o0, o1, o2] = out;
    in_runs!(o0.len(), t0, n, {
        // Sliced first, so the loop carries no bounds checks.
        let d = &data[t0 * c..(t0 + n) * c];
        let bg = &bgs[t0..t0 + n];
        let (a0, a1, a2) = (
            &mut o0[t0..t0 + n],
            &mut o1[t0..t0 + n],
            &mut o2[t0..t0 + n],
        );
        for t in 0..n {
            let b = bg[t] > 0.0;
            a0[t] = if b { bgv[0] } else { d[t * c] * scale };
            a1[t] = if b { bgv[1] } else { d[t * c + 1] * scale };
            a2[t] = if b { bgv[2] } else { d[t * c + 2] * scale };
        }
    });
}

/// Copies the filtered colour out of `src` into an image; with demodulation, multiplies the
/// albedo back and puts the pass-through pixels' own colour back (0 where not finite).
pub(crate) fn output(inp: &Input, lay: Layout, src: &[f32]) -> Image {
    let (w, h) = (lay.w, lay.h);
    let mut out = Image::new(w, h, 3, 0.0);
    out.data
        .par_chunks_mut(3 * w)
        .enumerate()
        .for_each(|(y, o)| {
            for c in 0..lay.nch {
                let (x0, len) = lay.strip(c);
                let blk = &src[lay.block(c, y, K)..][..K * QW];
                output_row(inp, y * w + x0, blk, &mut o[3 * x0..3 * (x0 + len)]);
            }
        });
    out
}

multiversion! {
    /// One run of output pixels from pixel `i0` (`o`: 3 floats each) from the strip columns
    /// of block `blk` (from column M), with the rules of [`output`].
    pub(crate) fn output_row(inp: &Input, i0: usize, blk: &[f32], o: &mut [f32])
        as output_row_impl
    {
        let n = o.len() / 3;
        let (r, g, b) = (&blk[M..][..n], &blk[QW + M..][..n], &blk[2 * QW + M..][..n]);
        let albedo = inp.features.albedo.filter(|_| inp.demodulate);
        let color = &inp.color.data[3 * i0..3 * (i0 + n)];
        match albedo.map(|a| a.channels) {
            None => {
                for t in 0..n {
                    o[3 * t..3 * t + 3].copy_from_slice(&[r[t], g[t], b[t]]);
                }
            }
            Some(1) => remodulate::<1>(color, albedo_row(albedo, i0, n), [r, g, b], o),
            Some(3) => remodulate::<3>(color, albedo_row(albedo, i0, n), [r, g, b], o),
            Some(4) => remodulate::<4>(color, albedo_row(albedo, i0, n), [r, g, b], o),
            Some(_) => {
                for t in 0..n {
                    let f = [r[t], g[t], b[t]];
                    let v = match albedo.and_then(|a| albedo_divisor(a, i0 + t)) {
                        Some(a) => [f[0] * a[0], f[1] * a[1], f[2] * a[2]],
                        None => {
                            let col = &color[3 * t..3 * t + 3];
                            [passed(col[0]), passed(col[1]), passed(col[2])]
                        }
                    };
                    o[3 * t..3 * t + 3].copy_from_slice(&v);
                }
            }
        }
    }
}

/// Filtered illumination times the albedo (`AC` channels), or the pass-through colour where
/// the albedo is unusable: `albedo_divisor` and `passed` written branch-free (the per-pixel
/// calls took ~8 % of a 512² filter; copying into lanes first, as the input does, was slower
/// here).
#[inline(always)]
fn remodulate<const AC: usize>(color: &[f32], albedo: &[f32], f: [&[f32]; 3], o: &mut [f32]) {
    let n = f[0].len();
    for t in 0..n {
        let a = &albedo[AC * t..AC * t + AC];
        let a = if AC == 1 {
            [a[0]; 3]
        } else {
            [a[0], a[1], a[2]]
        };
        let finite = a[0].is_finite() & a[1].is_finite() & a[2].is_finite();
        let ok = finite & (a[0].max(a[1]).max(a[2]) >= ALBEDO_EPS);
        let c = &color[3 * t..3 * t + 3];
        for k in 0..3 {
            let v = f[k][t] * a[k].max(ALBEDO_EPS);
            let p = if c[k].is_finite() { c[k] } else { 0.0 };
            o[3 * t + k] = if ok { v } else { p };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atrous_kernel::{normalise, normalise_impl, K, KA};
    use crate::synthetic::synthetic_frame;

    /// The copies `multiversion!` compiles for this CPU (AVX-512 or AVX2) give the baseline
    /// copy's results bit for bit: the claim that lets the input passes use them freely.
    #[test]
    fn simd_copies_match_the_baseline_bit_for_bit() {
        // Two strips (the second 18 columns wide: runs with a remainder).
        let (w, h) = (530, 9);
        let f = synthetic_frame(w, h, 1, 3);
        let mut color = f.noisy.clone();
        color.data[5] = f32::NAN;
        color.data[3 * 700 + 1] = f32::INFINITY;
        let mut albedo = f.albedo.clone();
        albedo.data[3 * 40] = f32::NAN;
        let features = Features {
            normal: Some(&f.normal),
            position: Some(&f.position),
            depth: Some(&f.depth),
            albedo: Some(&albedo),
            variance: Some(&f.variance),
        };
        let lay = Layout::new(w, h);
        let scales = FillScales {
            inv_ml2: 0.5,
            normal: Some(2.0),
            position: Some(1.5),
            inv_extent: 0.25,
            position_background: [9.0; 3],
        };
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for (demodulate, use_variance) in [(false, false), (true, false), (true, true)] {
            let inp = Input {
                color: &color,
                features: &features,
                demodulate,
                use_variance,
            };
            for b in 0..lay.nch * lay.h {
                let (x, y) = (block_stats(&inp, lay, b), block_stats_impl(&inp, lay, b));
                assert_eq!(x.lum.to_bits(), y.lum.to_bits(), "block {b}");
                assert_eq!((x.valid, x.missing), (y.valid, y.missing), "block {b}");
                assert_eq!(bits(&x.lo), bits(&y.lo), "block {b}");
                assert_eq!(bits(&x.hi), bits(&y.hi), "block {b}");
            }
            for c in 0..lay.nch {
                for y in 0..lay.h {
                    let (mut b1, mut a1) = (vec![0.0; K * QW], vec![0.0; KA * QW]);
                    let (mut b2, mut a2) = (vec![0.0; K * QW], vec![0.0; KA * QW]);
                    fill_block(&inp, lay, 1, &scales, c, y, &mut b1, &mut a1);
                    fill_block_impl(&inp, lay, 1, &scales, c, y, &mut b2, &mut a2);
                    assert_eq!(bits(&b1), bits(&b2), "strip {c} row {y}");
                    assert_eq!(bits(&a1), bits(&a2), "strip {c} row {y}");
                    let (x0, len) = lay.strip(c);
                    let (mut o1, mut o2) = (vec![0.0; 3 * len], vec![0.0; 3 * len]);
                    output_row(&inp, y * w + x0, &b1, &mut o1);
                    output_row_impl(&inp, y * w + x0, &b1, &mut o2);
                    assert_eq!(bits(&o1), bits(&o2), "strip {c} row {y}");
                }
            }
        }
    }

    /// The vectorised variance conversion equals `Input::variance` (times the scale, tiny
    /// values flushed) bit for bit, for every variance and albedo layout it specialises and
    /// one it does not, with missing, negative and zero values.
    #[test]
    fn variance_runs_match_the_per_pixel_rule() {
        let (w, h) = (37, 3);
        let f = synthetic_frame(w, h, 1, 9);
        let mut seed = 7u64;
        let mut rnd = || crate::synthetic::splitmix(&mut seed);
        for vc in [1usize, 2, 3, 4] {
            let mut var = Image::new(w, h, vc, 0.0);
            for v in &mut var.data {
                *v = rnd() * 2.0 - 0.2;
            }
            var.data[4] = f32::NAN;
            var.data[9] = f32::INFINITY;
            var.data[vc * 20] = 1e-20;
            for ac in [1usize, 3, 4] {
                let mut albedo = Image::new(w, h, ac, 0.0);
                for (k, a) in albedo.data.iter_mut().enumerate() {
                    *a = if k % 11 == 0 { 0.0 } else { rnd() };
                }
                albedo.data[ac * 30] = f32::NAN;
                let features = Features {
                    albedo: Some(&albedo),
                    variance: Some(&var),
                    ..Features::default()
                };
                for demodulate in [false, true] {
                    let inp = Input {
                        color: &f.noisy,
                        features: &features,
                        demodulate,
                        use_variance: true,
                    };
                    let n = w * h - 5;
                    let mut got = vec![0.0; n];
                    variance_run(&inp, 5, 0.7, &mut got);
                    for (t, g) in got.iter().enumerate() {
                        let v = inp.variance(5 + t) * 0.7;
                        let want = if v > 1e-12 { v } else { 0.0 };
                        assert_eq!(
                            g.to_bits(),
                            want.to_bits(),
                            "variance {vc} ch, albedo {ac} ch, demodulate {demodulate}, pixel {t}"
                        );
                    }
                }
            }
        }
    }

    /// The same for the normalisation of accumulated rows (with and without variance).
    #[test]
    fn normalise_copies_match_the_baseline_bit_for_bit() {
        let stride = QW;
        // Weight sums of every sign and size, including 0 (nothing contributed).
        let acc: Vec<f32> = (0..5 * stride)
            .map(|i| ((i * 2_654_435_761) % 1000) as f32 / 97.0 - 1.0)
            .collect();
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for (a0, d0, len) in [(0, M, CW), (3, M, 37), (M, M, CW)] {
            let (mut d1, mut d2) = (vec![0.5; K * QW], vec![0.5; K * QW]);
            normalise::<false>(&acc, stride, a0, &mut d1, d0, len);
            normalise_impl::<false>(&acc, stride, a0, &mut d2, d0, len);
            assert_eq!(bits(&d1), bits(&d2));
            normalise::<true>(&acc, stride, a0, &mut d1, d0, len);
            normalise_impl::<true>(&acc, stride, a0, &mut d2, d0, len);
            assert_eq!(bits(&d1), bits(&d2));
        }
    }
}
