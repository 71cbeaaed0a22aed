//! Reading the À-Trous inputs: the per-pixel rules (colour, demodulation, variance) and the
//! first, read-only pass over the images for the image-wide statistics (mean luminance, scene
//! extent). The second pass, which fills the working layout, is in fill.rs; the run-wise,
//! vectorised forms of the per-pixel rules in lanes.rs; writing the result back in output.rs.
//!
//! Why not `Prepared` + `demodulate` as the other filters do: at 512² the kernel itself takes
//! a few milliseconds, and building a dozen intermediate full-image planes (serially, in fresh
//! page-faulted memory) took longer than that. Here two parallel passes read each input
//! pixel where it lies: one for the image-wide statistics (mean luminance, scene extent), one
//! that fills every block. The per-pixel rules are those of `Prepared::new` and
//! `demodulate`, which the tests use as the reference.

use lumo_image::{luminance, Image};
use rayon::prelude::*;

use super::fill::background_row;
use super::lanes::color_stats;
use super::layout::{Layout, CW};
use super::params::AtrousParams;
use crate::common::albedo::{albedo_divisor, illumination_variance};
use crate::common::gbuffer::{flush, Features};

/// The input images of one call, and whether colour is demodulated by the albedo.
pub(super) struct Input<'a> {
    pub color: &'a Image,
    pub features: &'a Features<'a>,
    /// Divide colour by the albedo (`features.albedo` is then present).
    pub demodulate: bool,
    /// Use `features.variance` (SVGF's variance-guided colour weight).
    pub use_variance: bool,
}

impl<'a> Input<'a> {
    /// The input of one call: demodulation as `params` asks, the variance-guided weight only
    /// where a variance plane is given.
    pub(super) fn new(color: &'a Image, features: &'a Features<'a>, params: &AtrousParams) -> Self {
        Self {
            color,
            features,
            demodulate: params.demodulate,
            use_variance: params.use_variance && features.variance.is_some(),
        }
    }
}

/// One input pixel as the filter sees it.
pub(super) struct Pixel {
    /// Colour (or illumination), denormals flushed; 0 where not `valid`.
    pub(super) rgb: [f32; 3],
    /// Colour usable (finite, and with a usable albedo when demodulating).
    pub(super) valid: bool,
}

/// Image-wide values the scales depend on.
pub(super) struct Stats {
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
    pub(super) fn pixel(&self, i: usize) -> Pixel {
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
    pub(super) fn variance(&self, i: usize) -> f32 {
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
pub(super) struct FillScales {
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
pub(super) struct BlockStats {
    pub(super) lum: f64,
    pub(super) valid: usize,
    pub(super) missing: usize,
    pub(super) lo: [f32; 3],
    pub(super) hi: [f32; 3],
}

/// First pass, reading only: the image-wide statistics, from each (strip, row) block's own
/// columns, summed block by block in block order (the same on any number of threads).
pub(super) fn input_stats(inp: &Input, lay: Layout) -> Stats {
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
    pub(super) fn block_stats(inp: &Input, lay: Layout, b: usize) -> BlockStats as block_stats_impl {
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
pub(super) fn feature_count(inp: &Input, s: &FillScales) -> usize {
    let f = inp.features;
    f.normal.zip(s.normal).map_or(0, |_| 3) + f.position.zip(s.position).map_or(1, |_| 3)
}
