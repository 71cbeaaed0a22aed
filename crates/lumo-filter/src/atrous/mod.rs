//! Edge-avoiding À-Trous wavelet filter (Dammertz et al. 2010; papers/README §1), with the
//! variance-guided colour weight of SVGF as an option.
//!
//! The files of this folder, in the order a call runs through them: params.rs (parameters
//! and checks), input.rs (per-pixel input rules and the statistics pass), fill.rs (the working
//! layout filled from the images, with lanes.rs for the vectorised runs), layout.rs (that
//! layout), then per level kernel.rs (per tap) / fused.rs (first five levels) / pairs/ (the
//! symmetric-pair path) or pipeline.rs (all levels at once, row by row), and output.rs (the
//! result written back). Everything but the public API below is `pub(super)`.

mod fill;
mod fused;
mod input;
mod kernel;
mod lanes;
mod layout;
mod output;
mod pairs;
mod params;
mod pipeline;
#[cfg(test)]
mod tests;
mod transpose;

use std::borrow::Cow;

use lumo_image::Image;
use rayon::prelude::*;

pub use params::{
    AtrousParams, B3, DEFAULT_SIGMA_LUMINANCE, DEFAULT_SIGMA_NORMAL, DEFAULT_SIGMA_POSITION,
};

use crate::common::albedo::surface_albedo;
use crate::common::gbuffer::{Features, Filtered};
use crate::denoiser::{Denoiser, FilterInput, FilterKind};
use crate::FilterError;
use fill::{fill_all, fill_block};
use input::{feature_count, input_stats, FillScales, Input, Stats};
use kernel::{Isa, Level, Path, CM_FIXED, CM_NONE, CM_VARIANCE, K, KA};
use layout::{Layout, SharedBuf, CW, LINE_FLOATS, M, QW};
use output::{output, output_row};
use params::{validate, VARIANCE_EPS};
use pipeline::Stage;

thread_local! {
    /// Each worker's output row for the level pipeline's `emit` (zeroed once, not per row).
    static EMIT_ROW: std::cell::RefCell<Vec<f32>> = std::cell::RefCell::new(vec![0.0; 3 * CW]);
}

/// Filters `color` (3 channels). Missing (NaN/Inf) pixels get weight 0 and are in-painted.
/// To filter many frames, keep an [`AtrousFilter`]: it reuses its working memory.
pub fn atrous(
    color: &Image,
    features: &Features,
    params: &AtrousParams,
) -> Result<Filtered, FilterError> {
    AtrousFilter::new().filter(color, features, params)
}

/// The À-Trous filter with its working memory (about 18 floats per pixel where the levels
/// run one after the other; the level pipeline needs only per-thread rings of rows), kept
/// between calls: filtering frame after frame with one `AtrousFilter` skips allocating and
/// page-faulting it every time, as an interactive renderer's denoiser (or OIDN's filter
/// object) does. Results do not depend on what was filtered before.
#[derive(Debug, Default)]
pub struct AtrousFilter {
    src: Vec<f32>,
    dst: Vec<f32>,
    aux: Vec<f32>,
}

impl AtrousFilter {
    /// A filter with no working memory yet (it grows on the first call).
    pub fn new() -> Self {
        Self::default()
    }

    /// Filters `color` (3 channels), as [`atrous`].
    pub fn filter(
        &mut self,
        color: &Image,
        features: &Features,
        params: &AtrousParams,
    ) -> Result<Filtered, FilterError> {
        if transpose::pays(color.width, color.height) {
            validate(color, features, params)?;
            let t = crate::common::transpose::TransposedInput::new(color, features);
            let out = self.run(&t.color, &t.features(), params, Isa::detect(), Path::Auto)?;
            return Ok(crate::common::transpose::back(out));
        }
        self.run(color, features, params, Isa::detect(), Path::Auto)
    }

    /// [`Self::filter`] with a chosen instruction set and kernel path (tests compare them).
    fn run(
        &mut self,
        color: &Image,
        features: &Features,
        params: &AtrousParams,
        isa: Isa,
        path: Path,
    ) -> Result<Filtered, FilterError> {
        validate(color, features, params)?;
        // Only a demodulating run reads the albedo (and needs the background masked out of it).
        let albedo = if params.demodulate {
            surface_albedo(features)
        } else {
            features.albedo.map(Cow::Borrowed)
        };
        let features = &Features {
            albedo: albedo.as_deref(),
            ..*features
        };
        let inp = Input::new(color, features, params);
        let lay = Layout::new(color.width, color.height);
        let (image, missing) = self.levels(&inp, lay, params, isa, path, None);
        Ok(Filtered { image, missing })
    }

    /// [`Self::filter`] that also returns the first level's output (what SVGF feeds back as
    /// the next frame's colour history), with the same remodulation as the final output.
    /// Always runs level by level (the pipeline never materialises a level).
    /// `pub(crate)`: the temporal filter's, which feeds that level back as its history.
    pub(crate) fn filter_keeping_first_level(
        &mut self,
        color: &Image,
        features: &Features,
        params: &AtrousParams,
    ) -> Result<(Filtered, Image), FilterError> {
        validate(color, features, params)?;
        if transpose::pays(color.width, color.height) {
            let t = crate::common::transpose::TransposedInput::new(color, features);
            let (out, first) = self.filter_keeping_first_level(&t.color, &t.features(), params)?;
            return Ok((
                crate::common::transpose::back(out),
                crate::common::transpose::transposed(&first),
            ));
        }
        let inp = Input::new(color, features, params);
        let lay = Layout::new(color.width, color.height);
        let mut first = Image::new(0, 0, 3, 0.0);
        let (image, missing) = self.levels(
            &inp,
            lay,
            params,
            Isa::detect(),
            Path::Auto,
            Some(&mut first),
        );
        Ok((Filtered { image, missing }, first))
    }
}

/// The À-Trous filter behind the [`Denoiser`] interface: its parameters and its working
/// memory (an [`AtrousFilter`], kept between frames). Reads the colour and whichever of
/// normal, position, albedo and variance its parameters use.
#[derive(Debug, Default)]
pub struct AtrousDenoiser {
    /// The parameters of every call.
    pub params: AtrousParams,
    filter: AtrousFilter,
}

impl AtrousDenoiser {
    /// A denoiser with these parameters.
    pub fn new(params: AtrousParams) -> Self {
        Self {
            params,
            filter: AtrousFilter::new(),
        }
    }
}

impl Denoiser for AtrousDenoiser {
    fn name(&self) -> &'static str {
        FilterKind::Atrous.name()
    }

    /// [`AtrousFilter::filter`] on the input's colour and features.
    fn denoise(&mut self, input: &FilterInput) -> Result<Filtered, FilterError> {
        self.filter
            .filter(input.color, &input.features, &self.params)
    }
}

/// Scale of the background coordinate (used when there is no position plane to fold it
/// into): a background/geometry pair is 64² log2 units apart, far below the weight cutoff, so
/// the two never mix (the paper's shader does the same with a separate test).
const BACKGROUND_SCALE: f32 = 64.0;

/// How far (in scaled units, per coordinate) background pixels are put beyond the farthest
/// geometry when the background flag is folded into the position: 3·8² log2 units, below the
/// weight cutoff (28.9), so background and geometry never mix, as with a separate flag.
const BACKGROUND_GAP: f32 = 8.0;

/// Which weights one level uses and their scales, all in log2 units of the weight.
struct LevelWeights {
    /// Colour mode (`CM_*`) and its factor (per unit squared RGB / absolute luminance distance).
    cm: u8,
    color_scale: f32,
    /// Variance-guided σ and ε (units of the stored variance's square root).
    sigma: f32,
    eps: f32,
}

/// Sets the per-level planes of every block's aux buffer: the colour factor and the
/// luminance; multiplies the normal coordinates by `rescale` (their σ scales with the
/// stepwidth).
///
/// The colour factor: for the fixed colour σ, `color_scale` × validity (0 at missing centre
/// pixels, which have no colour to compare), written only when `color_plane` (the per-tap
/// path reads it; the pair path derives it from the validity, the fused one per block). For
/// the variance-guided weight, g = color_scale / σ × validity for every pixel of every
/// path, margins included: SVGF's σ belongs to the centre pixel, so a pair's weight differs
/// seen from its two pixels, and the pair path, which computes each pair's feature distance
/// once for both, needs both pixels' g.
fn level_aux(
    aux: &mut [f32],
    src: &[f32],
    lay: Layout,
    lw: &LevelWeights,
    color_plane: bool,
    rescale: Option<f32>,
) {
    if !color_plane && lw.cm != CM_VARIANCE && rescale.is_none() {
        return;
    }
    aux.par_chunks_mut(KA * QW).enumerate().for_each(|(b, a)| {
        let (c, y) = lay.strip_row(b);
        let (x0, len) = lay.strip(c);
        let s = &src[lay.block(c, y, K)..][..K * QW];
        let ja = M.saturating_sub(x0);
        let jb = (lay.w + M - x0).min(lay.span());
        let (cp, rest) = a.split_at_mut(QW);
        let (lum, fa) = rest.split_at_mut(QW);
        let valid = &s[3 * QW..4 * QW];
        match lw.cm {
            CM_FIXED if color_plane => {
                for j in M..M + len {
                    cp[j] = lw.color_scale * valid[j];
                }
            }
            CM_VARIANCE => {
                variance_color_factor(src, lay, c, y, lw, valid, &mut cp[M..M + len]);
                for j in ja..jb {
                    lum[j] = 0.2126 * s[j] + 0.7152 * s[QW + j] + 0.0722 * s[2 * QW + j];
                }
            }
            _ => {}
        }
        if let Some(r) = rescale {
            for k in 0..3 {
                for v in &mut fa[k * QW..k * QW + lay.span()] {
                    *v *= r;
                }
            }
        }
    });
    if lw.cm == CM_VARIANCE {
        // The fused and pair paths read g of neighbours in the margins.
        lay.fill_margins(aux, KA, 1);
    }
}

/// The variance-guided colour factor g = color_scale / σ × validity of block (c, y)'s strip
/// columns (see [`level_aux`]), with the operations the fused path used to form it per block.
fn variance_color_factor(
    src: &[f32],
    lay: Layout,
    c: usize,
    y: usize,
    lw: &LevelWeights,
    valid: &[f32],
    out: &mut [f32],
) {
    inverse_sigma_row(src, lay, c, y, lw.sigma, lw.eps, out);
    for (o, &v) in out.iter_mut().zip(&valid[M..]) {
        *o = lw.color_scale * *o * v;
    }
}

/// What every level of one call reads: the input, its layout, the kernel choice and the
/// scales the input statistics give.
struct Plan<'a, 'b> {
    inp: &'a Input<'b>,
    lay: Layout,
    params: &'a AtrousParams,
    scales: FillScales,
    /// Feature planes in use.
    nf: usize,
    isa: Isa,
    path: Path,
    /// Mean luminance of the input.
    ml: f32,
    /// The colour weight is guided by the variance.
    var_mode: bool,
    /// The normal weight is on.
    has_n: bool,
}

/// The first level's scales: squared distances are divided by σ² (normals also by
/// stepwidth², as in the paper); scaling the coordinates by sqrt(log2 e)/σ makes them log2
/// exponents directly.
fn fill_scales(params: &AtrousParams, stats: &Stats, has_n: bool, has_x: bool) -> FillScales {
    let log2e = std::f32::consts::LOG2_E;
    let ml = stats.mean_luminance;
    let sx = params
        .sigma_position
        .filter(|_| has_x)
        .map(|s| log2e.sqrt() / s);
    let inv_extent = 1.0 / stats.extent;
    FillScales {
        inv_ml2: 1.0 / (ml * ml),
        normal: params
            .sigma_normal
            .filter(|_| has_n)
            .map(|s| log2e.sqrt() / s),
        position: sx,
        inv_extent,
        position_background: stats.position_max.map(|hi| {
            let v = hi * inv_extent * sx.unwrap_or(0.0) + BACKGROUND_GAP;
            if v.is_finite() {
                v
            } else {
                0.0
            }
        }),
    }
}

impl Plan<'_, '_> {
    /// Level `it`'s colour mode and colour scale. log2(sparse) iterations in-paint from
    /// geometry alone (paper §4: colour is meaningless at pixels that were never traced).
    fn level_color(&self, it: usize) -> (u8, f32) {
        let (params, log2e) = (self.params, std::f32::consts::LOG2_E);
        let skip_color = params.sparse.trailing_zeros() as usize;
        let cm = if it < skip_color {
            CM_NONE
        } else if self.var_mode {
            CM_VARIANCE
        } else if params.sigma_color.is_some() {
            CM_FIXED
        } else {
            CM_NONE
        };
        let color_scale = match cm {
            CM_FIXED => params.sigma_color.map_or(0.0, |s| {
                // σ in units of mean luminance, halved every level (paper).
                let si = s * self.ml / (1u32 << it) as f32;
                log2e / (si * si)
            }),
            CM_VARIANCE => log2e,
            _ => 0.0,
        };
        (cm, color_scale)
    }

    /// Every level as one pipeline of `stages` (pipeline.rs), bands split as `split`: it
    /// reads the inputs row by row and writes the output image row by row itself, with no
    /// full-image working buffers.
    fn pipelined(&self, stages: &[Stage], split: Option<(usize, usize)>) -> Image {
        let (inp, lay) = (self.inp, self.lay);
        let level = Level {
            lay,
            step: 1,
            src: &[],
            aux: &[],
            nf: self.nf,
            normal_factor: 1.0,
            cm: CM_NONE,
            color_scale: 0.0,
            var: false,
            isa: self.isa,
            path: self.path,
        };
        let fill = |c: usize, y: usize, blk: &mut [f32], ab: &mut [f32]| {
            fill_block(inp, lay, self.params.sparse, &self.scales, c, y, blk, ab);
        };
        // The output is written once, row by row, by `emit`: not zeroed first (that was a
        // full-image memset per call, 25 MB at 1080p).
        let n = 3 * lay.w * lay.h;
        let mut data: Vec<f32> = Vec::with_capacity(n);
        let base = SharedBuf(data.as_mut_ptr());
        let written = std::sync::atomic::AtomicUsize::new(0);
        let emit = |c: usize, y: usize, blk: &[f32]| {
            let base = &base;
            let (x0, len) = lay.strip(c);
            let i0 = y * lay.w + x0;
            // Formed in the worker's (cached) row buffer, then copied: no reference to the
            // uninitialised output is ever made.
            EMIT_ROW.with(|row| {
                let mut row = row.borrow_mut();
                let o = &mut row[..3 * len];
                output_row(inp, i0, blk, o);
                // SAFETY: pixels i0 .. i0 + len of row y lie inside the allocation (n floats),
                // and the pipeline emits each (strip, row) once, so no two calls write the
                // same pixel and nothing reads the buffer meanwhile.
                unsafe { std::ptr::copy_nonoverlapping(o.as_ptr(), base.0.add(3 * i0), 3 * len) };
            });
            written.fetch_add(3 * len, std::sync::atomic::Ordering::Relaxed);
        };
        pipeline::run(&level, stages, split, &fill, &emit);
        // Every (strip, row) was emitted once: the strips tile each row.
        assert_eq!(
            written.into_inner(),
            n,
            "pipeline left output pixels unwritten"
        );
        // SAFETY: all n floats were written (counted above) and the capacity is n.
        unsafe { data.set_len(n) };
        Image::from_vec(lay.w, lay.h, 3, data)
    }
}

impl AtrousFilter {
    /// Every level, ping-ponging between the two colour buffers; returns the output image
    /// and the number of non-finite input pixels.
    fn levels(
        &mut self,
        inp: &Input,
        lay: Layout,
        params: &AtrousParams,
        isa: Isa,
        path: Path,
        first: Option<&mut Image>,
    ) -> (Image, usize) {
        let stats = input_stats(inp, lay);
        let var_mode = inp.use_variance && params.sigma_luminance.is_some();
        let has_n = inp.features.normal.is_some() && params.sigma_normal.is_some();
        let has_x = inp.features.position.is_some() && params.sigma_position.is_some();
        let scales = fill_scales(params, &stats, has_n, has_x);
        let plan = Plan {
            inp,
            lay,
            params,
            nf: feature_count(inp, &scales),
            scales,
            isa,
            path,
            ml: stats.mean_luminance,
            var_mode,
            has_n,
        };
        // All levels pair levels: run them as one pipeline (see pipeline.rs). The
        // normal planes stay at level 0's scale; each level's factor is 1/step².
        let stages: Vec<Stage> = (0..params.iterations)
            .map(|it| {
                let (cm, color_scale) = plan.level_color(it);
                let step = 1usize << it;
                Stage {
                    step,
                    cm,
                    color_scale,
                    normal_factor: 1.0 / (step * step) as f32,
                }
            })
            .collect();
        let piped = match path {
            _ if first.is_some() => None,
            Path::Auto if pipeline::pays_off(lay, &stages) => Some(None),
            Path::Bands(rows, groups) => Some(Some((rows, groups))),
            _ => None,
        };
        if let Some(split) = piped {
            if !var_mode && pipeline::supports(&stages, plan.nf, lay) {
                return (plan.pipelined(&stages, split), stats.missing);
            }
        }
        (self.level_by_level(&plan, first), stats.missing)
    }

    /// The levels one after the other over the whole image, in this filter's buffers;
    /// `first` gets level 0's output.
    fn level_by_level(&mut self, plan: &Plan, mut first: Option<&mut Image>) -> Image {
        let (inp, lay, params) = (plan.inp, plan.lay, plan.params);
        // Each buffer is used from its first cache-line boundary (`malloc` places large
        // buffers 16 bytes past one), so that blocks and their planes start on cache lines:
        // 512² default filter, two threads, 16.9 → 15.8 ms.
        let aligned = |buf: &mut Vec<f32>, planes: usize| -> usize {
            let len = lay.size(planes) + LINE_FLOATS;
            // Contents are overwritten (by the input passes and the kernels); only growth
            // allocates (zeroed by the OS: no pass over the memory until it is used).
            if buf.len() < len {
                *buf = vec![0.0; len];
            }
            buf.as_ptr().align_offset(4 * LINE_FLOATS).min(LINE_FLOATS)
        };
        let (os, od, oa) = (
            aligned(&mut self.src, K),
            aligned(&mut self.dst, K),
            aligned(&mut self.aux, KA),
        );
        let mut src = &mut self.src[os..os + lay.size(K)];
        let mut dst = &mut self.dst[od..od + lay.size(K)];
        let aux = &mut self.aux[oa..oa + lay.size(KA)];
        fill_all(inp, lay, params.sparse, &plan.scales, src, aux);
        let sigma_l = params.sigma_luminance.unwrap_or(DEFAULT_SIGMA_LUMINANCE);
        let (ml, var_mode, nf) = (plan.ml, plan.var_mode, plan.nf);
        let mut normal_held = 1.0f32;
        for it in 0..params.iterations {
            let step = 1usize << it;
            let (cm, color_scale) = plan.level_color(it);
            let lw = LevelWeights {
                cm,
                color_scale,
                // The variance is stored in units of ml², so its square root is in units of ml.
                sigma: sigma_l * ml,
                eps: VARIANCE_EPS * ml,
            };
            let pairs = matches!(plan.path, Path::Auto | Path::Pairs | Path::Bands(..))
                && pairs::supports(step, nf);
            let fused = !pairs && kernel::takes_fused(plan.path, step);
            // The normal coordinates' scale relative to level 0 should be 1/step. The pair
            // and fused paths apply the factor in the kernel instead of rescaling the planes;
            // before the per-tap path, the planes are rescaled (by powers of 2: exact).
            let want = 1.0 / step as f32;
            let rescale = if plan.has_n && !pairs && !fused && normal_held != want {
                let r = want / normal_held;
                normal_held = want;
                Some(r)
            } else {
                None
            };
            let normal_factor = (want / normal_held) * (want / normal_held);
            // Only the per-tap path reads the fixed colour factor from the aux plane (the
            // pair path derives it from the validity, the fused one forms it per block).
            level_aux(aux, src, lay, &lw, !pairs && !fused, rescale);
            let level = Level {
                lay,
                step,
                src,
                aux,
                nf,
                normal_factor,
                cm,
                color_scale,
                var: var_mode,
                isa: plan.isa,
                path: plan.path,
            };
            if pairs {
                pairs::level(&level, dst);
            } else {
                dst.par_chunks_mut(K * QW)
                    .enumerate()
                    .for_each(|(b, blk)| kernel::block(&level, b, blk));
            }
            // The variance plane only matters where it is carried.
            lay.fill_margins(dst, K, if var_mode { K } else { K - 1 });
            std::mem::swap(&mut src, &mut dst);
            if it == 0 {
                if let Some(f) = first.as_deref_mut() {
                    *f = output(inp, lay, src);
                }
            }
        }
        output(inp, lay, src)
    }
}

multiversion! {
    /// 1/(σ·sqrt(G3×3 ∗ var) + eps) for the strip columns of block (c, y) into `out`: SVGF's
    /// prefiltered variance, from the variance planes (margins hold the neighbouring strips'
    /// values, and 0 beyond the image). Terms outside the image are left out of the sum and of
    /// its normalisation.
    ///
    /// Row by row, so the loops vectorise (it was a scalar per-pixel function with a bounds
    /// check per tap: a third of the default variance-guided filter's time). Each pixel's sum
    /// adds its terms in the same order as that function did (kept in the tests as the
    /// reference), and a term beyond the image adds an exact 0, so the result is the same bit
    /// for bit.
    fn inverse_sigma_row(
        src: &[f32],
        lay: Layout,
        c: usize,
        y: usize,
        sigma: f32,
        eps: f32,
        out: &mut [f32],
    ) as inverse_sigma_row_impl {
        const G: [f32; 3] = [0.25, 0.5, 0.25];
        let (x0, len) = lay.strip(c);
        assert_eq!(out.len(), len, "one value per strip column");
        let s = &mut out[..];
        s.fill(0.0);
        let mut ky = 0.0f32;
        for (dy, gy) in G.iter().enumerate() {
            let Some(yy) = (y + dy).checked_sub(1).filter(|&yy| yy < lay.h) else {
                continue;
            };
            ky += gy;
            let row = &src[lay.block(c, yy, K) + 4 * QW..][..QW];
            for (dx, gx) in G.iter().enumerate() {
                let w = gx * gy;
                for (st, &v) in s.iter_mut().zip(&row[M + dx - 1..M + dx - 1 + len]) {
                    *st += w * v;
                }
            }
        }
        // The weights are dyadic fractions, so their sums are exact in any order: the
        // normalisation of a pixel is ky times the sum of its columns' gx.
        let kx = |t: usize| {
            let x = x0 + t;
            let left = if x > 0 { G[0] } else { 0.0 };
            let right = if x + 1 < lay.w { G[2] } else { 0.0 };
            left + G[1] + right
        };
        let interior = ky * (G[0] + G[1] + G[2]);
        for (t, st) in s.iter_mut().enumerate() {
            let k = if t == 0 || t + 1 == len { ky * kx(t) } else { interior };
            *st = 1.0 / (sigma * (*st / k).max(0.0).sqrt() + eps);
        }
    }
}
