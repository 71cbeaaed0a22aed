//! Edge-avoiding À-Trous wavelet filter (Dammertz et al. 2010; papers/README §1), with the
//! variance-guided colour weight of SVGF as an option.

use lumo_image::{luminance, Image};
use rayon::prelude::*;

use crate::albedo::demodulate;
use crate::atrous_kernel::{self, Isa, Level, Path, CM_FIXED, CM_NONE, CM_VARIANCE, K, KA, MAX_NF};
use crate::atrous_layout::{Layout, CW, M, QW};
use crate::atrous_pairs;
use crate::error::param;
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

/// Keeps variance-guided weights finite where the variance is 0 (relative to mean luminance).
pub(crate) const VARIANCE_EPS: f32 = 1e-6;

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
    let t0 = std::time::Instant::now();
    let prep = Prepared::new(color, features)?;
    if std::env::var("LUMO_T").is_ok() {
        eprintln!("prep {:?}", t0.elapsed());
    }
    let image = run(&prep, variance_raw, params);
    if std::env::var("LUMO_T").is_ok() {
        eprintln!("total {:?}", t0.elapsed());
    }
    Ok(Filtered {
        image,
        missing: prep.missing,
    })
}

/// Luminance of a 1- or 3-channel variance image; negative or non-finite values become 0.
pub(crate) fn variance_plane(v: &Image) -> Vec<f32> {
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
    /// Feature scales (multiply the coordinates), `None` when the weight is off.
    normal: Option<f32>,
    position: Option<f32>,
}

/// Per coordinate, the position value background pixels get (scaled units): the background
/// flag folded into the position, which saves the kernels one coordinate.
fn background_positions(x: &[Vec<f32>; 3], background: &[f32], scale: f32) -> [f32; 3] {
    std::array::from_fn(|k| {
        let hi = x[k]
            .par_iter()
            .zip(background)
            .filter(|(_, &b)| b == 0.0)
            .map(|(&v, _)| v)
            .reduce(|| f32::NEG_INFINITY, f32::max);
        if hi.is_finite() {
            hi * scale + BACKGROUND_GAP
        } else {
            0.0
        }
    })
}

/// Fills the aux planes of every block for one level: colour factor (0 at missing centre
/// pixels, which have no colour to compare), luminance and the scaled feature coordinates,
/// margins included (0 beyond the image). Returns the number of feature coordinates.
/// After the first level (`first` false) only the planes that change per level are rebuilt:
/// the colour factor, the luminance and the normals (their σ scales with the stepwidth).
fn build_aux(
    aux: &mut [f32],
    src: &[f32],
    prep: &Prepared,
    lay: Layout,
    lw: &LevelWeights,
    first: bool,
) -> usize {
    // (plane, scale, value on background) of every feature coordinate in use; the
    // background flag is one unless it is folded into the position.
    let mut dims: Vec<(&[f32], f32, f32)> = Vec::with_capacity(MAX_NF);
    if let (Some(s), Some(n)) = (lw.normal, &prep.normal) {
        dims.extend(n.iter().map(|p| (&p[..], s, 0.0)));
    }
    let rebuild = if first { MAX_NF } else { dims.len() };
    match (lw.position, &prep.position) {
        (Some(s), Some(x)) => {
            let bg = if first {
                background_positions(x, &prep.background, s)
            } else {
                [0.0; 3]
            };
            dims.extend(x.iter().zip(bg).map(|(p, b)| (&p[..], s, b)));
        }
        _ => dims.push((&prep.background[..], BACKGROUND_SCALE, 0.0)),
    }
    let w = lay.w;
    aux.par_chunks_mut(KA * QW).enumerate().for_each(|(b, a)| {
        let (c, y) = lay.strip_row(b);
        let (x0, len) = lay.strip(c);
        let s = &src[lay.block(c, y, K)..][..K * QW];
        // Block columns j ↔ image columns x0 + j − M; those inside the image:
        let ja = M.saturating_sub(x0);
        let jb = (w + M - x0).min(QW);
        let (cp, rest) = a.split_at_mut(QW);
        let (lum, fa) = rest.split_at_mut(QW);
        let valid = &s[3 * QW..4 * QW];
        match lw.cm {
            CM_FIXED => {
                for j in M..M + len {
                    cp[j] = lw.color_scale * valid[j];
                }
            }
            CM_VARIANCE => {
                for j in M..M + len {
                    let isig = inverse_sigma(src, lay, c, y, j, lw.sigma, lw.eps);
                    cp[j] = lw.color_scale * isig * valid[j];
                }
                for j in ja..jb {
                    lum[j] = 0.2126 * s[j] + 0.7152 * s[QW + j] + 0.0722 * s[2 * QW + j];
                }
            }
            _ => {}
        }
        let rows = y * w + x0 + ja - M..y * w + x0 + jb - M;
        let bg = &prep.background[rows.clone()];
        for (k, &(plane, scale, on_bg)) in dims.iter().enumerate().take(rebuild) {
            let from = &plane[rows.clone()];
            for ((o, v), b) in fa[k * QW + ja..k * QW + jb].iter_mut().zip(from).zip(bg) {
                *o = v * scale + b * on_bg;
            }
        }
    });
    dims.len()
}

/// 1/(σ·sqrt(G3×3 ∗ var) + eps) at block column `j` of block (c, y): SVGF's prefiltered
/// variance, from the variance planes (margins hold the neighbouring strips' values).
fn inverse_sigma(
    src: &[f32],
    lay: Layout,
    c: usize,
    y: usize,
    j: usize,
    sigma: f32,
    eps: f32,
) -> f32 {
    const G: [f32; 3] = [0.25, 0.5, 0.25];
    let x = (c * CW + j) as isize - M as isize;
    let (mut s, mut k) = (0.0f32, 0.0f32);
    for (dy, gy) in G.iter().enumerate() {
        let yy = y as isize + dy as isize - 1;
        if yy < 0 || yy >= lay.h as isize {
            continue;
        }
        let row = &src[lay.block(c, yy as usize, K) + 4 * QW..][..QW];
        for (dx, gx) in G.iter().enumerate() {
            let xx = x + dx as isize - 1;
            if xx < 0 || xx >= lay.w as isize {
                continue;
            }
            s += gx * gy * row[j + dx - 1];
            k += gx * gy;
        }
    }
    1.0 / (sigma * (s / k).max(0.0).sqrt() + eps)
}

fn run(prep: &Prepared, variance: Option<Vec<f32>>, params: &AtrousParams) -> Image {
    run_with(prep, variance, params, Isa::detect(), Path::Auto)
}

/// [`run`] with a chosen instruction set and kernel path (tests compare their results).
pub(crate) fn run_with(
    prep: &Prepared,
    variance: Option<Vec<f32>>,
    params: &AtrousParams,
    isa: Isa,
    path: Path,
) -> Image {
    let (w, h) = (prep.w, prep.h);
    let lay = Layout::new(w, h);
    let inv_ml2 = 1.0 / (prep.mean_luminance * prep.mean_luminance);
    let mut src = vec![0.0f32; lay.size(K)];
    // `sparse` is a power of two.
    let mask = params.sparse - 1;
    src.par_chunks_mut(K * QW).enumerate().for_each(|(b, blk)| {
        let (c, y) = lay.strip_row(b);
        let (x0, _) = lay.strip(c);
        let on_row = y & mask == 0;
        let ja = M.saturating_sub(x0);
        let jb = (w + M - x0).min(QW);
        for j in ja..jb {
            let x = x0 + j - M;
            let i = y * w + x;
            let on_grid = (on_row && x & mask == 0) as u8 as f32;
            for ch in 0..3 {
                blk[ch * QW + j] = prep.color[ch][i];
            }
            blk[3 * QW + j] = prep.valid[i] * on_grid;
            // Variance in units of mean luminance², tiny values flushed to 0, so Σ w²·var
            // never reaches the (slow) denormal range.
            let v = variance.as_ref().map_or(0.0, |v| v[i]) * inv_ml2;
            blk[4 * QW + j] = if v > 1e-12 { v } else { 0.0 };
        }
    });
    let mut dst = vec![0.0f32; lay.size(K)];
    let mut aux = vec![0.0f32; lay.size(KA)];
    let var_mode = variance.is_some() && params.sigma_luminance.is_some();
    // log2(sparse) iterations in-paint from geometry alone (paper §4: colour is meaningless
    // at pixels that were never traced).
    let skip_color = params.sparse.trailing_zeros() as usize;
    let ml = prep.mean_luminance;
    let log2e = std::f32::consts::LOG2_E;
    let has_n = prep.normal.is_some() && params.sigma_normal.is_some();
    let has_x = prep.position.is_some() && params.sigma_position.is_some();
    let sigma_l = params.sigma_luminance.unwrap_or(DEFAULT_SIGMA_LUMINANCE);
    for it in 0..params.iterations {
        let step = 1usize << it;
        let cm = if it < skip_color {
            CM_NONE
        } else if var_mode {
            CM_VARIANCE
        } else if params.sigma_color.is_some() {
            CM_FIXED
        } else {
            CM_NONE
        };
        let color_scale = match cm {
            CM_FIXED => params.sigma_color.map_or(0.0, |s| {
                // σ in units of mean luminance, halved every level (paper).
                let si = s * ml / (1u32 << it) as f32;
                log2e / (si * si)
            }),
            CM_VARIANCE => log2e,
            _ => 0.0,
        };
        // Squared distances are divided by σ² (normals also by stepwidth², as in the paper);
        // scaling the coordinates by sqrt(log2 e)/σ makes them log2 exponents directly.
        let lw = LevelWeights {
            cm,
            color_scale,
            // The variance is stored in units of ml², so its square root is in units of ml.
            sigma: sigma_l * ml,
            eps: VARIANCE_EPS * ml,
            normal: params
                .sigma_normal
                .filter(|_| has_n)
                .map(|s| log2e.sqrt() / (s * step as f32)),
            position: params
                .sigma_position
                .filter(|_| has_x)
                .map(|s| log2e.sqrt() / s),
        };
        let nf = build_aux(&mut aux, &src, prep, lay, &lw, it == 0);
        let level = Level {
            lay,
            step,
            src: &src,
            aux: &aux,
            nf,
            cm,
            color_scale: lw.color_scale,
            var: var_mode,
            isa,
            path,
        };
        if path == Path::Auto && atrous_pairs::supports(&level) {
            atrous_pairs::level(&level, &mut dst);
        } else {
            dst.par_chunks_mut(K * QW)
                .enumerate()
                .for_each(|(b, blk)| atrous_kernel::block(&level, b, blk));
        }
        lay.fill_margins(&mut dst, K);
        std::mem::swap(&mut src, &mut dst);
    }
    let mut out = Image::new(w, h, 3, 0.0);
    out.data
        .par_chunks_mut(3 * w)
        .enumerate()
        .for_each(|(y, o)| {
            for c in 0..lay.nch {
                let (x0, len) = lay.strip(c);
                let blk = &src[lay.block(c, y, K)..][..K * QW];
                for i in 0..len {
                    for ch in 0..3 {
                        o[3 * (x0 + i) + ch] = blk[ch * QW + M + i];
                    }
                }
            }
        });
    out
}
