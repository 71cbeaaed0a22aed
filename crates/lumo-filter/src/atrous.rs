//! Edge-avoiding À-Trous wavelet filter (Dammertz et al. 2010; papers/README §1), with the
//! variance-guided colour weight of SVGF as an option.

use lumo_image::{luminance, Image};
use rayon::prelude::*;

use crate::albedo::demodulate;
use crate::error::param;
use crate::fastmath::exp_neg;
use crate::gbuffer::{check_color, check_features, missing_pixels, Features, Filtered, Prepared};
use crate::FilterError;

/// The B3 spline taps (1/16, 1/4, 3/8, 1/4, 1/16); the 5×5 kernel is their outer product.
pub const B3: [f32; 5] = [1.0 / 16.0, 1.0 / 4.0, 3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0];

/// Parameters of [`atrous`]. A `None` sigma switches that edge weight off (the paper's Table 2
/// times 0–3 weights).
#[derive(Clone, Debug, PartialEq)]
pub struct AtrousParams {
    /// Number of à-trous levels; level i uses taps 2^i pixels apart (5 → 125 px footprint).
    pub iterations: usize,
    /// Colour σ when no variance plane is used: in units of the image's mean luminance, halved
    /// every iteration (paper). Off by default: on 1–4 spp heavy-tailed noise it keeps
    /// fireflies and dark speckles apart from their neighbours (see docs/filters.md).
    pub sigma_color: Option<f32>,
    /// Variance-guided colour σ (SVGF's σ_l), used instead of `sigma_color` when
    /// `features.variance` is given and `use_variance` is set: the luminance distance is divided
    /// by σ_l·sqrt(3×3 Gaussian of the variance) + ε. Not halved: the variance itself shrinks as
    /// it is filtered (with squared weights).
    pub sigma_luminance: Option<f32>,
    /// Normal σ (normals in [-1,1]); the distance is divided by stepwidth² as in the paper.
    pub sigma_normal: Option<f32>,
    /// Position σ in units of the scene's extent (diagonal of the positions' bounding box).
    pub sigma_position: Option<f32>,
    /// Sparse input: only pixels with x % n == 0 and y % n == 0 are valid (n = 1, 2 or 4); the
    /// rest is in-painted, and the colour weight is skipped for the first log2(n) iterations.
    pub sparse: usize,
    /// Filter colour / albedo and multiply back (needs `features.albedo`).
    pub demodulate: bool,
    /// Use `features.variance` (if given) to steer the colour weight, as SVGF does.
    pub use_variance: bool,
}

impl Default for AtrousParams {
    /// Defaults chosen by the sweep in docs/filters.md.
    fn default() -> Self {
        Self {
            iterations: 5,
            sigma_color: None,
            sigma_luminance: Some(DEFAULT_SIGMA_LUMINANCE),
            sigma_normal: Some(DEFAULT_SIGMA_NORMAL),
            sigma_position: Some(DEFAULT_SIGMA_POSITION),
            sparse: 1,
            demodulate: false,
            use_variance: true,
        }
    }
}

/// Default variance-guided σ_l (multiplies the local luminance standard deviation): the best
/// value with `spatial_variance` on real 1- and 4-spp renders (docs/filters.md, "Validation on
/// the renderer"); the synthetic sweep had picked 64.
pub const DEFAULT_SIGMA_LUMINANCE: f32 = 16.0;
/// Default normal σ, see docs/filters.md.
pub const DEFAULT_SIGMA_NORMAL: f32 = 0.3;
/// Default position σ (fraction of the scene extent), see docs/filters.md.
pub const DEFAULT_SIGMA_POSITION: f32 = 0.1;

/// Working-buffer planes per row: r, g, b, validity, variance.
const K: usize = 5;

/// Keeps variance-guided weights finite where the variance is 0 (relative to mean luminance).
const VARIANCE_EPS: f32 = 1e-6;

/// Filters `color` (3 channels). Missing (NaN/Inf) pixels get weight 0 and are in-painted.
pub fn atrous(
    color: &Image,
    features: &Features,
    params: &AtrousParams,
) -> Result<Filtered, FilterError> {
    check_color("color", color)?;
    check_features(features, color.width, color.height)?;
    if params.iterations == 0 || params.iterations > 16 {
        return Err(param(
            "iterations",
            format!("{} (use 1..=16)", params.iterations),
        ));
    }
    if ![1, 2, 4].contains(&params.sparse) {
        return Err(param(
            "sparse",
            format!("{} (use 1, 2 or 4)", params.sparse),
        ));
    }
    for (name, s) in [
        ("sigma_color", params.sigma_color),
        ("sigma_luminance", params.sigma_luminance),
        ("sigma_normal", params.sigma_normal),
        ("sigma_position", params.sigma_position),
    ] {
        if let Some(s) = s {
            if !(s > 0.0) {
                return Err(param(name, format!("{s} (must be > 0, or off)")));
            }
        }
    }
    if params.sigma_normal.is_some() && features.normal.is_none() {
        return Err(FilterError::MissingFeature {
            filter: "the À-Trous normal weight",
            needs: "a normal plane".into(),
        });
    }
    if params.sigma_position.is_some() && features.position.is_none() {
        return Err(FilterError::MissingFeature {
            filter: "the À-Trous position weight",
            needs: "a position plane".into(),
        });
    }
    let variance_raw = match (params.use_variance, features.variance) {
        (true, Some(v)) => Some(variance_plane(v)),
        _ => None,
    };
    if params.demodulate {
        let albedo = features.albedo.ok_or_else(|| FilterError::MissingFeature {
            filter: "albedo demodulation",
            needs: "an albedo plane".into(),
        })?;
        let d = demodulate(color, albedo)?;
        let var = variance_raw.map(|v| d.demodulate_variance(&v));
        let prep = Prepared::new(&d.illumination, features)?;
        let filtered = run(&prep, var, params);
        return Ok(Filtered {
            image: d.remodulate(&filtered, color),
            missing: missing_pixels(color),
        });
    }
    let prep = Prepared::new(color, features)?;
    let image = run(&prep, variance_raw, params);
    Ok(Filtered {
        image,
        missing: prep.missing,
    })
}

/// Luminance of a 1- or 3-channel variance image; negative or non-finite values become 0.
fn variance_plane(v: &Image) -> Vec<f32> {
    v.data
        .chunks_exact(v.channels)
        .map(|p| {
            let x = if p.len() >= 3 {
                luminance([p[0], p[1], p[2]])
            } else {
                p[0]
            };
            if x.is_finite() && x > 0.0 {
                x
            } else {
                0.0
            }
        })
        .collect()
}

/// Per-iteration constants shared by all rows.
struct Pass<'a> {
    w: usize,
    /// Padded sub-row stride (see [`stride`]).
    sw: usize,
    h: usize,
    step: usize,
    src: &'a [f32],
    /// Row-planar features: per row KF sub-rows (normal xyz, position xyz, background).
    feat: &'a [f32],
    /// 1/σ² terms (already including mean luminance and stepwidth scaling).
    inv_c: f32,
    inv_n: f32,
    inv_x: f32,
    /// Variance mode: per-pixel 1/(σ_l·sqrt(gaussian(var)) + eps).
    inv_sigma: &'a [f32],
}

/// Sub-row stride for a row of `w` pixels: a multiple of 16 floats that is not a multiple of
/// 256, so the ~30 sub-rows one tap reads do not all map to the same cache sets (a 1024-wide
/// image otherwise runs slower than a 1920-wide one).
fn stride(w: usize) -> usize {
    let s = w.next_multiple_of(16);
    if s.is_multiple_of(256) {
        s + 16
    } else {
        s
    }
}

/// Columns per chunk of a row (see `row_kernel`).
const CHUNK: usize = 256;

/// Feature sub-rows per row: normal x, y, z, position x, y, z, background flag.
const KF: usize = 7;

/// Packs the features row-planar (zeros for absent ones) so a tap reads one slice per row.
fn pack_features(prep: &Prepared) -> Vec<f32> {
    let w = prep.w;
    let sw = stride(w);
    let mut feat = vec![0.0f32; KF * sw * prep.h];
    feat.par_chunks_mut(KF * sw)
        .enumerate()
        .for_each(|(y, row)| {
            let r = y * w..(y + 1) * w;
            if let Some(n) = &prep.normal {
                for c in 0..3 {
                    row[c * sw..c * sw + w].copy_from_slice(&n[c][r.clone()]);
                }
            }
            if let Some(x) = &prep.position {
                for c in 0..3 {
                    row[(3 + c) * sw..(3 + c) * sw + w].copy_from_slice(&x[c][r.clone()]);
                }
            }
            row[6 * sw..6 * sw + w].copy_from_slice(&prep.background[r]);
        });
    feat
}

fn run(prep: &Prepared, variance: Option<Vec<f32>>, params: &AtrousParams) -> Image {
    let (w, h) = (prep.w, prep.h);
    let inv_ml2 = 1.0 / (prep.mean_luminance * prep.mean_luminance);
    let sw = stride(w);
    let mut src = vec![0.0f32; K * sw * h];
    // Row-planar layout: row y holds K sub-rows (r, g, b, valid, var) so one parallel chunk per
    // row owns all its outputs, and every inner loop runs over contiguous slices.
    src.par_chunks_mut(K * sw).enumerate().for_each(|(y, row)| {
        for x in 0..w {
            let i = y * w + x;
            let on_grid = (x % params.sparse == 0 && y % params.sparse == 0) as u8 as f32;
            for c in 0..3 {
                row[c * sw + x] = prep.color[c][i];
            }
            row[3 * sw + x] = prep.valid[i] * on_grid;
            // Variance in units of mean luminance², tiny values flushed to 0, so Σ w²·var
            // never reaches the (slow) denormal range.
            let v = variance.as_ref().map_or(0.0, |v| v[i]) * inv_ml2;
            row[4 * sw + x] = if v > 1e-12 { v } else { 0.0 };
        }
    });
    let feat = pack_features(prep);
    let mut dst = vec![0.0f32; K * sw * h];
    let mut inv_sigma = vec![0.0f32; w * h];
    let var_mode = variance.is_some() && params.sigma_luminance.is_some();
    // log2(sparse) iterations in-paint from geometry alone (paper §4: colour is meaningless
    // at pixels that were never traced).
    let skip_color = params.sparse.trailing_zeros() as usize;
    let ml = prep.mean_luminance;
    let has_n = prep.normal.is_some() && params.sigma_normal.is_some();
    let has_x = prep.position.is_some() && params.sigma_position.is_some();
    for it in 0..params.iterations {
        let step = 1usize << it;
        let cm = if it < skip_color {
            0u8
        } else if var_mode {
            2
        } else if params.sigma_color.is_some() {
            1
        } else {
            0
        };
        let inv_c = params.sigma_color.map_or(0.0, |s| {
            let si = s * ml / (1u32 << it) as f32;
            1.0 / (si * si)
        });
        if cm == 2 {
            let sigma = params.sigma_luminance.unwrap_or(DEFAULT_SIGMA_LUMINANCE);
            // The variance is stored in units of ml², so its square root is in units of ml.
            inv_sigma = inverse_sigma(&src, w, sw, h, sigma * ml, VARIANCE_EPS * ml);
        }
        let inv_n = params
            .sigma_normal
            .map_or(0.0, |s| 1.0 / (s * s * (step * step) as f32));
        let inv_x = params.sigma_position.map_or(0.0, |s| 1.0 / (s * s));
        let pass = Pass {
            w,
            sw,
            h,
            step,
            src: &src,
            feat: &feat,
            inv_c,
            inv_n,
            inv_x,
            inv_sigma: &inv_sigma,
        };
        dst.par_chunks_mut(K * sw)
            .enumerate()
            .for_each(|(y, row)| dispatch(&pass, has_n, has_x, cm, y, row));
        std::mem::swap(&mut src, &mut dst);
    }
    let mut out = Image::new(w, h, 3, 0.0);
    out.data
        .par_chunks_mut(3 * w)
        .zip(src.par_chunks(K * sw))
        .for_each(|(o, s)| {
            for x in 0..w {
                for c in 0..3 {
                    o[3 * x + c] = s[c * sw + x];
                }
            }
        });
    out
}

/// 1/(σ·sqrt(G3×3 ∗ var) + eps) per pixel (SVGF's prefiltered variance), from the var sub-rows.
fn inverse_sigma(src: &[f32], w: usize, sw: usize, h: usize, sigma: f32, eps: f32) -> Vec<f32> {
    const G: [f32; 3] = [0.25, 0.5, 0.25];
    let mut out = vec![0.0f32; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, o)| {
        for (x, ov) in o.iter_mut().enumerate() {
            let (mut s, mut k) = (0.0f32, 0.0f32);
            for (dy, gy) in G.iter().enumerate() {
                let yy = y + dy;
                if yy < 1 || yy > h {
                    continue;
                }
                let row = &src[(yy - 1) * K * sw..];
                for (dx, gx) in G.iter().enumerate() {
                    let xx = x + dx;
                    if xx < 1 || xx > w {
                        continue;
                    }
                    s += gx * gy * row[4 * sw + xx - 1];
                    k += gx * gy;
                }
            }
            *ov = 1.0 / (sigma * (s / k).max(0.0).sqrt() + eps);
        }
    });
    out
}

/// Picks the monomorphised row kernel for the weights in use, so the inner loop carries no
/// per-pixel branches on configuration.
fn dispatch(p: &Pass, has_n: bool, has_x: bool, cm: u8, y: usize, row: &mut [f32]) {
    match (has_n, has_x, cm) {
        (false, false, 0) => row_kernel::<false, false, 0>(p, y, row),
        (false, false, 1) => row_kernel::<false, false, 1>(p, y, row),
        (false, false, _) => row_kernel::<false, false, 2>(p, y, row),
        (true, false, 0) => row_kernel::<true, false, 0>(p, y, row),
        (true, false, 1) => row_kernel::<true, false, 1>(p, y, row),
        (true, false, _) => row_kernel::<true, false, 2>(p, y, row),
        (false, true, 0) => row_kernel::<false, true, 0>(p, y, row),
        (false, true, 1) => row_kernel::<false, true, 1>(p, y, row),
        (false, true, _) => row_kernel::<false, true, 2>(p, y, row),
        (true, true, 0) => row_kernel::<true, true, 0>(p, y, row),
        (true, true, 1) => row_kernel::<true, true, 1>(p, y, row),
        (true, true, _) => row_kernel::<true, true, 2>(p, y, row),
    }
}

/// Constants of one tap.
#[derive(Clone, Copy)]
struct TapConst {
    w: usize,
    x0: usize,
    q0: usize,
    len: usize,
    hk: f32,
    inv_c: f32,
    inv_n: f32,
    inv_x: f32,
}

/// One output row of one à-trous level. Taps are visited one at a time over the whole row
/// (tap-major), so each inner loop is a straight pass over equal-length slices that the
/// compiler vectorises. Taps outside the image are skipped (the kernel renormalises).
/// `CM`: 0 = no colour weight, 1 = fixed σ, 2 = variance-guided.
fn row_kernel<const HN: bool, const HX: bool, const CM: u8>(p: &Pass, y: usize, dst: &mut [f32]) {
    let w = p.w;
    dst.fill(0.0);
    let sw = p.sw;
    let prow = &p.src[y * K * sw..(y + 1) * K * sw];
    let pfeat = &p.feat[y * KF * sw..(y + 1) * KF * sw];
    let isig: &[f32] = if CM == 2 {
        &p.inv_sigma[y * w..(y + 1) * w]
    } else {
        &[]
    };
    let step = p.step as isize;
    // Column chunks keep one tap's working set (≈ 30 sub-rows × CHUNK floats) in L1.
    for cx0 in (0..w).step_by(CHUNK) {
        let cx1 = (cx0 + CHUNK).min(w);
        for (ky, hy) in B3.iter().enumerate() {
            let yy = y as isize + (ky as isize - 2) * step;
            if yy < 0 || yy >= p.h as isize {
                continue;
            }
            let yy = yy as usize;
            let qrow = &p.src[yy * K * sw..(yy + 1) * K * sw];
            let qfeat = &p.feat[yy * KF * sw..(yy + 1) * KF * sw];
            for (kx, hx) in B3.iter().enumerate() {
                let off = (kx as isize - 2) * step;
                // x range inside the chunk whose tap x + off is inside the row.
                let x0 = ((-off).max(0) as usize).max(cx0);
                let x1 = ((w as isize - off.max(0)).max(0) as usize).min(cx1);
                if x0 >= x1 {
                    continue;
                }
                let c = TapConst {
                    w: sw,
                    x0,
                    q0: (x0 as isize + off) as usize,
                    len: x1 - x0,
                    hk: hy * hx,
                    inv_c: p.inv_c,
                    inv_n: p.inv_n,
                    inv_x: p.inv_x,
                };
                tap::<HN, HX, CM>(prow, qrow, pfeat, qfeat, isig, dst, c);
            }
        }
    }
    let (acc, rest) = dst.split_at_mut(3 * sw);
    let (acc_w, acc_v) = rest.split_at_mut(sw);
    for x in 0..w {
        let k = acc_w[x];
        let has = (k > 0.0) as u8 as f32;
        let inv = has / k.max(1e-30);
        acc[x] *= inv;
        acc[sw + x] *= inv;
        acc[2 * sw + x] *= inv;
        acc_w[x] = has;
        // SVGF: variance of a weighted mean = Σ w² var / (Σ w)².
        acc_v[x] *= inv * inv;
    }
}

/// Accumulates one tap into the row's accumulators. A separate non-inlined function whose
/// slice arguments the compiler knows do not alias, so the loop vectorises without runtime
/// overlap checks.
#[inline(never)]
fn tap<const HN: bool, const HX: bool, const CM: u8>(
    prow: &[f32],
    qrow: &[f32],
    pfeat: &[f32],
    qfeat: &[f32],
    isig: &[f32],
    acc: &mut [f32],
    c: TapConst,
) {
    let (w, len) = (c.w, c.len);
    let ps = |row, k| sub_row(row, k * w + c.x0, len);
    let qs = |row, k| sub_row(row, k * w + c.q0, len);
    let (pr, pg, pb, pv) = (ps(prow, 0), ps(prow, 1), ps(prow, 2), ps(prow, 3));
    let (qr, qg, qb, qv, qvar) = (
        qs(qrow, 0),
        qs(qrow, 1),
        qs(qrow, 2),
        qs(qrow, 3),
        qs(qrow, 4),
    );
    let (pn0, pn1, pn2) = (ps(pfeat, 0), ps(pfeat, 1), ps(pfeat, 2));
    let (qn0, qn1, qn2) = (qs(qfeat, 0), qs(qfeat, 1), qs(qfeat, 2));
    let (px0, px1, px2) = (ps(pfeat, 3), ps(pfeat, 4), ps(pfeat, 5));
    let (qx0, qx1, qx2) = (qs(qfeat, 3), qs(qfeat, 4), qs(qfeat, 5));
    let (pbg, qbg) = (ps(pfeat, 6), qs(qfeat, 6));
    let isig = if CM == 2 {
        &isig[c.x0..c.x0 + len]
    } else {
        &[]
    };
    let (ar, rest) = acc.split_at_mut(w);
    let (ag, rest) = rest.split_at_mut(w);
    let (ab, rest) = rest.split_at_mut(w);
    let (aw, av) = rest.split_at_mut(w);
    let ar = &mut ar[c.x0..c.x0 + len];
    let ag = &mut ag[c.x0..c.x0 + len];
    let ab = &mut ab[c.x0..c.x0 + len];
    let aw = &mut aw[c.x0..c.x0 + len];
    let av = &mut av[c.x0..c.x0 + len];
    for i in 0..len {
        let mut e = 0.0f32;
        if CM == 1 {
            let (dr, dg, db) = (pr[i] - qr[i], pg[i] - qg[i], pb[i] - qb[i]);
            // pv: a missing centre pixel has no colour to compare with.
            e += (dr * dr + dg * dg + db * db) * c.inv_c * pv[i];
        }
        if CM == 2 {
            let lp = 0.2126 * pr[i] + 0.7152 * pg[i] + 0.0722 * pb[i];
            let lq = 0.2126 * qr[i] + 0.7152 * qg[i] + 0.0722 * qb[i];
            e += (lp - lq).abs() * isig[i] * pv[i];
        }
        if HN {
            let (a, b, d) = (pn0[i] - qn0[i], pn1[i] - qn1[i], pn2[i] - qn2[i]);
            e += (a * a + b * b + d * d) * c.inv_n;
        }
        if HX {
            let (a, b, d) = (px0[i] - qx0[i], px1[i] - qx1[i], px2[i] - qx2[i]);
            e += (a * a + b * b + d * d) * c.inv_x;
        }
        // exp_neg clamps to ≤ 1, i.e. the product of the per-feature weights each clamped ≤ 1
        // as in the paper's shader. Background never mixes with geometry.
        let same = 1.0 - (pbg[i] - qbg[i]).abs();
        let wgt = c.hk * exp_neg(-e) * qv[i] * same;
        ar[i] += wgt * qr[i];
        ag[i] += wgt * qg[i];
        ab[i] += wgt * qb[i];
        aw[i] += wgt;
        // Always carried (cheap), so sparse levels without colour keep it too.
        av[i] += wgt * wgt * qvar[i];
    }
}

/// `len` values of `row` from `start`.
#[inline(always)]
fn sub_row(row: &[f32], start: usize, len: usize) -> &[f32] {
    &row[start..start + len]
}
