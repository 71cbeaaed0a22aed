//! Joint bilateral upsampling (Kopf et al. 2007) of a low-resolution buffer steered by
//! full-resolution depth and normals (papers/README §3, steps 3–5).

use lumo_image::Image;
use rayon::prelude::*;

use crate::bilateral::{bilateral, BilateralParams};
use crate::common::error::param;
use crate::common::fastmath::exp_neg;
use crate::common::gbuffer::{
    background_mask, check_color, check_features, missing_pixels, plane0, planes3, Features,
    Filtered,
};
use crate::common::outliers::remove_outliers;
use crate::denoiser::{Denoiser, FilterInput, FilterKind};
use crate::FilterError;

/// Parameters of [`jbu`].
#[derive(Clone, Debug, PartialEq)]
pub struct JbuParams {
    /// Block size k: low-res pixel (i, j) holds the sample taken at full-res pixel
    /// (i·k + k/2, j·k + k/2) (clamped to the image); the paper uses 16.
    pub factor: usize,
    /// Neighbourhood radius in low-res pixels.
    pub radius: usize,
    /// Spatial σ in low-res pixels.
    pub sigma_spatial: f32,
    /// Depth range σ on the relative difference |d_p − d_q| / d_p.
    pub sigma_depth: Option<f32>,
    /// Normal range σ (normals in [-1, 1]).
    pub sigma_normal: Option<f32>,
    /// Outlier removal threshold in standard deviations (paper: 2); `None` = off.
    pub outlier_sigma: Option<f32>,
    /// Bilateral pre-filter of the low-res buffer with depth + normals (radius 2, σ 1).
    pub prefilter: bool,
}

impl Default for JbuParams {
    fn default() -> Self {
        Self {
            factor: 16,
            radius: 2,
            sigma_spatial: 1.0,
            sigma_depth: Some(0.1),
            sigma_normal: Some(0.3),
            outlier_sigma: Some(2.0),
            prefilter: false,
        }
    }
}

/// Joint bilateral upsampling behind the [`Denoiser`] interface: the input's colour is the
/// low-resolution buffer (⌈W/k⌉×⌈H/k⌉), its features the full-resolution depth and / or
/// normal planes (at least one is needed).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JbuDenoiser {
    /// The upsampling's parameters.
    pub params: JbuParams,
}

impl Denoiser for JbuDenoiser {
    fn name(&self) -> &'static str {
        FilterKind::Jbu.name()
    }

    /// [`jbu`] of the input's colour to its features' resolution.
    fn denoise(&mut self, input: &FilterInput) -> Result<Filtered, FilterError> {
        jbu(input.color, &input.features, &self.params)
    }
}

/// Upsamples `low` (3 channels, ⌈W/k⌉×⌈H/k⌉) to the W×H of `full`'s depth / normal planes.
/// Where every range weight vanishes (no low-res sample on the same surface nearby) the pixel
/// falls back to spatial weights alone. Missing low-res pixels get weight 0; the result is
/// finite.
pub fn jbu(low: &Image, full: &Features, params: &JbuParams) -> Result<Filtered, FilterError> {
    check_color("low-res buffer", low)?;
    let k = params.factor;
    if k == 0 || k > 256 {
        return Err(param("factor", format!("{k} (use 1..=256)")));
    }
    if params.radius == 0 || params.radius > 16 {
        return Err(param("radius", format!("{} (use 1..=16)", params.radius)));
    }
    if !(params.sigma_spatial > 0.0) {
        return Err(param(
            "sigma_spatial",
            format!("{} (must be > 0)", params.sigma_spatial),
        ));
    }
    let reference = full
        .depth
        .or(full.normal)
        .ok_or_else(|| FilterError::MissingFeature {
            filter: "joint bilateral upsampling",
            needs: "a full-resolution depth or normal plane".into(),
        })?;
    let (w, h) = (reference.width, reference.height);
    check_features(full, w, h)?;
    let (lw, lh) = (w.div_ceil(k), h.div_ceil(k));
    if low.width != lw || low.height != lh {
        return Err(FilterError::SizeMismatch {
            name: "low-res buffer",
            width: low.width,
            height: low.height,
            reference: "full-res guide / factor",
            ref_width: lw,
            ref_height: lh,
        });
    }
    let missing = missing_pixels(low);
    let sample_xy = |i: usize, j: usize| ((i * k + k / 2).min(w - 1), (j * k + k / 2).min(h - 1));

    // Full-res guide planes, and the low-res guide sampled from them.
    let npix = w * h;
    let bg = background_mask(full, npix);
    let depth = full.depth.map(plane0);
    let normal = full.normal.map(planes3);
    let low_guide = |src: &dyn Fn(usize) -> Vec<f32>, ch: usize| -> Image {
        let mut img = Image::new(lw, lh, ch, 0.0);
        for j in 0..lh {
            for i in 0..lw {
                let (x, y) = sample_xy(i, j);
                img.pixel_mut(i, j).copy_from_slice(&src(y * w + x));
            }
        }
        img
    };
    let low_depth = depth.as_ref().map(|d| low_guide(&|p| vec![d[p]], 1));
    let low_normal = normal
        .as_ref()
        .map(|n| low_guide(&|p| vec![n[0][p], n[1][p], n[2][p]], 3));

    let mut buf = low.clone();
    if let Some(ks) = params.outlier_sigma {
        buf = remove_outliers(&buf, ks)?.0;
    }
    if params.prefilter {
        let f = Features {
            depth: low_depth.as_ref(),
            normal: low_normal.as_ref(),
            ..Features::default()
        };
        let bp = BilateralParams {
            radius: 2,
            sigma_spatial: 1.0,
            sigma_normal: params.sigma_normal,
            sigma_depth: params.sigma_depth,
            sigma_position: None,
            sigma_color: None,
        };
        // The pre-filter output is finite; remember which pixels were missing.
        let valid: Vec<bool> = buf
            .data
            .chunks_exact(3)
            .map(|p| p.iter().all(|v| v.is_finite()))
            .collect();
        let mut pre = bilateral(&buf, &f, &bp)?.image;
        for (i, ok) in valid.iter().enumerate() {
            if !ok {
                pre.data[i * 3..i * 3 + 3].fill(f32::NAN);
            }
        }
        buf = pre;
    }

    // Low-res planes: colour (0 where missing), validity, background class, depth, normal.
    let lvalid: Vec<f32> = buf
        .data
        .chunks_exact(3)
        .map(|p| p.iter().all(|v| v.is_finite()) as u8 as f32)
        .collect();
    let lcol: Vec<f32> = buf
        .data
        .iter()
        .map(|v| if v.is_finite() { *v } else { 0.0 })
        .collect();
    let mut lbg = vec![0.0f32; lw * lh];
    for j in 0..lh {
        for i in 0..lw {
            let (x, y) = sample_xy(i, j);
            lbg[j * lw + i] = bg[y * w + x];
        }
    }
    let inv_d = params.sigma_depth.map_or(0.0, |s| 1.0 / (s * s));
    let inv_n = params.sigma_normal.map_or(0.0, |s| 1.0 / (s * s));
    let inv_2s2 = 1.0 / (2.0 * params.sigma_spatial * params.sigma_spatial);
    let r = params.radius as isize;
    let kf = k as f32;

    let mut out = Image::new(w, h, 3, 0.0);
    out.data
        .par_chunks_mut(3 * w)
        .enumerate()
        .for_each(|(y, row)| {
            for x in 0..w {
                let p = y * w + x;
                // Nearest low-res cell, then its (2r+1)² neighbourhood.
                let ci = ((x / k) as isize).min(lw as isize - 1);
                let cj = ((y / k) as isize).min(lh as isize - 1);
                let dp = depth.as_ref().map_or(0.0, |d| d[p]);
                let inv_dp = if dp.is_finite() && dp > 0.0 {
                    1.0 / dp
                } else {
                    0.0
                };
                let mut acc = [0.0f32; 4];
                let mut acc_s = [0.0f32; 4];
                for j in (cj - r).max(0)..=(cj + r).min(lh as isize - 1) {
                    for i in (ci - r).max(0)..=(ci + r).min(lw as isize - 1) {
                        let q = j as usize * lw + i as usize;
                        let (sx, sy) = sample_xy(i as usize, j as usize);
                        let (ddx, ddy) = ((sx as f32 - x as f32) / kf, (sy as f32 - y as f32) / kf);
                        let ws = exp_neg(-(ddx * ddx + ddy * ddy) * inv_2s2) * lvalid[q];
                        let mut e = 0.0f32;
                        if let Some(ld) = low_depth.as_ref() {
                            let dq = ld.data[q];
                            let t = if dq.is_finite() {
                                (dp - dq) * inv_dp
                            } else {
                                0.0
                            };
                            e += t * t * inv_d;
                        }
                        if let (Some(ln), Some(n)) = (low_normal.as_ref(), normal.as_ref()) {
                            let nq = &ln.data[q * 3..q * 3 + 3];
                            let fin = |v: f32| if v.is_finite() { v } else { 0.0 };
                            let d2: f32 = (0..3).map(|c| (n[c][p] - fin(nq[c])).powi(2)).sum();
                            e += d2 * inv_n;
                        }
                        let same = 1.0 - (bg[p] - lbg[q]).abs();
                        let wr = ws * exp_neg(-e) * same;
                        let c = &lcol[q * 3..q * 3 + 3];
                        for t in 0..3 {
                            acc[t] += wr * c[t];
                            acc_s[t] += ws * c[t];
                        }
                        acc[3] += wr;
                        acc_s[3] += ws;
                    }
                }
                // Graceful fallback: no sample on this surface nearby → spatial weights alone.
                let use_range = acc[3] > 1e-6 * acc_s[3] && acc[3] > 0.0;
                let a = if use_range { acc } else { acc_s };
                let inv = if a[3] > 0.0 { 1.0 / a[3] } else { 0.0 };
                for t in 0..3 {
                    row[x * 3 + t] = a[t] * inv;
                }
            }
        });
    Ok(Filtered {
        image: out,
        missing,
    })
}
