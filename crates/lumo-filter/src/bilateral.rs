//! Brute-force cross (joint) bilateral filter: O(r²) per pixel, the quality reference the fast
//! filters are compared with (papers/README §2, Table 2 "cross bilateral").

use lumo_image::Image;
use rayon::prelude::*;

use crate::common::albedo::{surface_albedo, with_demodulation};
use crate::common::error::param;
use crate::common::fastmath::exp_neg;
use crate::common::gbuffer::{Features, Filtered, Prepared};
use crate::denoiser::{require, Denoiser, FilterInput, FilterKind};
use crate::FilterError;

/// Parameters of [`bilateral`]. A range σ of `None` switches that term off; `Some(f32::INFINITY)`
/// gives the same result.
#[derive(Clone, Debug, PartialEq)]
pub struct BilateralParams {
    /// Window radius in pixels (window (2r+1)²).
    pub radius: usize,
    /// Spatial Gaussian σ in pixels.
    pub sigma_spatial: f32,
    /// Normal range σ (normals in [-1, 1]).
    pub sigma_normal: Option<f32>,
    /// Depth range σ on the relative difference |d_p − d_q| / d_p (scale free).
    pub sigma_depth: Option<f32>,
    /// Position range σ in units of the scene's extent.
    pub sigma_position: Option<f32>,
    /// Colour range σ in units of the image's mean luminance.
    pub sigma_color: Option<f32>,
}

impl Default for BilateralParams {
    /// Defaults chosen by the sweep in docs/filters.md.
    fn default() -> Self {
        Self {
            radius: 16,
            sigma_spatial: 8.0,
            sigma_normal: Some(0.3),
            sigma_depth: Some(0.2),
            sigma_position: None,
            sigma_color: None,
        }
    }
}

/// Filters `color` (3 channels) with a Gaussian spatial kernel times Gaussian range kernels on
/// whichever features are given and enabled. Range terms whose feature is absent are ignored;
/// background pixels never mix with geometry; missing colour pixels get weight 0.
pub fn bilateral(
    color: &Image,
    features: &Features,
    params: &BilateralParams,
) -> Result<Filtered, FilterError> {
    if !(params.sigma_spatial > 0.0) {
        return Err(param(
            "sigma_spatial",
            format!("{} (must be > 0)", params.sigma_spatial),
        ));
    }
    if params.radius > 256 {
        return Err(param("radius", format!("{} (use ≤ 256)", params.radius)));
    }
    for (name, s) in [
        ("sigma_normal", params.sigma_normal),
        ("sigma_depth", params.sigma_depth),
        ("sigma_position", params.sigma_position),
        ("sigma_color", params.sigma_color),
    ] {
        if let Some(s) = s {
            if !(s > 0.0) {
                return Err(param(name, format!("{s} (must be > 0)")));
            }
        }
    }
    let prep = Prepared::new(color, features)?;
    let image = run(&prep, params);
    Ok(Filtered {
        image,
        missing: prep.missing,
    })
}

/// The cross bilateral filter behind the [`Denoiser`] interface. Reads the colour and
/// whichever of normal, depth and position are given (with none it is a Gaussian blur), and
/// the albedo when demodulating.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BilateralDenoiser {
    /// The filter's parameters.
    pub params: BilateralParams,
    /// Filter colour / albedo and multiply back ([`with_demodulation`]; needs an albedo).
    pub demodulate: bool,
}

impl Denoiser for BilateralDenoiser {
    fn name(&self) -> &'static str {
        FilterKind::Bilateral.name()
    }

    /// [`bilateral`] on the input, demodulated when asked.
    fn denoise(&mut self, input: &FilterInput) -> Result<Filtered, FilterError> {
        let features = &input.features;
        if self.demodulate {
            let albedo = surface_albedo(features);
            let albedo = require(albedo.as_deref(), "albedo demodulation", "an albedo plane")?;
            with_demodulation(input.color, albedo, |c| {
                bilateral(c, features, &self.params)
            })
        } else {
            bilateral(input.color, features, &self.params)
        }
    }
}

fn inv_sq(s: Option<f32>) -> f32 {
    s.map_or(0.0, |s| 1.0 / (s * s))
}

/// Per-row scratch: exponent, and accumulators r, g, b, weight.
struct Scratch {
    e: Vec<f32>,
    acc: [Vec<f32>; 4],
}

fn run(prep: &Prepared, params: &BilateralParams) -> Image {
    let (w, h) = (prep.w, prep.h);
    let r = params.radius as isize;
    let inv_n = inv_sq(params.sigma_normal);
    let inv_d = inv_sq(params.sigma_depth);
    let inv_x = inv_sq(params.sigma_position);
    let ml = prep.mean_luminance;
    let inv_c = inv_sq(params.sigma_color.map(|s| s * ml));
    let normal = prep.normal.as_ref().filter(|_| inv_n > 0.0);
    let position = prep.position.as_ref().filter(|_| inv_x > 0.0);
    // Relative depth: (d_p − d_q)² / d_p²; store 1/d_p (0 on background).
    let inv_depth: Option<Vec<f32>> = prep.depth.as_ref().filter(|_| inv_d > 0.0).map(|d| {
        d.iter()
            .map(|&v| if v > 0.0 { 1.0 / v } else { 0.0 })
            .collect()
    });
    let inv_2s2 = 1.0 / (2.0 * params.sigma_spatial * params.sigma_spatial);
    let mut out = Image::new(w, h, 3, 0.0);
    out.data.par_chunks_mut(3 * w).enumerate().for_each_init(
        || Scratch {
            e: vec![0.0; w],
            acc: [vec![0.0; w], vec![0.0; w], vec![0.0; w], vec![0.0; w]],
        },
        |s, (y, orow)| {
            for a in s.acc.iter_mut() {
                a.fill(0.0);
            }
            let pr = y * w;
            for dy in -r..=r {
                let yy = y as isize + dy;
                if yy < 0 || yy >= h as isize {
                    continue;
                }
                let qr = yy as usize * w;
                for dx in -r..=r {
                    let x0 = (-dx).max(0) as usize;
                    let x1 = (w as isize - dx.max(0)).max(0) as usize;
                    if x0 >= x1 {
                        continue;
                    }
                    let len = x1 - x0;
                    let (p0, q0) = (pr + x0, (qr as isize + x0 as isize + dx) as usize);
                    let e = &mut s.e[..len];
                    e.fill(0.0);
                    // One vectorised pass per enabled feature, accumulating the exponent.
                    if let Some(n) = normal {
                        add_dist3(e, n, p0, q0, inv_n, None);
                    }
                    if let Some(x) = position {
                        add_dist3(e, x, p0, q0, inv_x, None);
                    }
                    if let (Some(d), Some(id)) = (prep.depth.as_ref(), inv_depth.as_ref()) {
                        let (dp, dq, ip) = (&d[p0..p0 + len], &d[q0..q0 + len], &id[p0..p0 + len]);
                        add_rel_depth(e, dp, dq, ip, inv_d);
                    }
                    if inv_c > 0.0 {
                        // Missing centre pixels have no colour to compare: scale by validity.
                        add_dist3(
                            e,
                            &prep.color,
                            p0,
                            q0,
                            inv_c,
                            Some(&prep.valid[p0..p0 + len]),
                        );
                    }
                    let ws = exp_neg(-((dx * dx + dy * dy) as f32) * inv_2s2);
                    let (qv, pbg, qbg) = (
                        &prep.valid[q0..q0 + len],
                        &prep.background[p0..p0 + len],
                        &prep.background[q0..q0 + len],
                    );
                    let (cr, cg, cb) = (
                        &prep.color[0][q0..q0 + len],
                        &prep.color[1][q0..q0 + len],
                        &prep.color[2][q0..q0 + len],
                    );
                    let [ar, ag, ab, aw] = &mut s.acc;
                    accumulate(
                        ws,
                        e,
                        [qv, pbg, qbg],
                        [cr, cg, cb],
                        [
                            &mut ar[x0..x1],
                            &mut ag[x0..x1],
                            &mut ab[x0..x1],
                            &mut aw[x0..x1],
                        ],
                    );
                }
            }
            for x in 0..w {
                let k = s.acc[3][x];
                let inv = 1.0 / k.max(1e-30);
                for c in 0..3 {
                    orow[3 * x + c] = s.acc[c][x] * inv;
                }
            }
        },
    );
    out
}

multiversion! {
    /// e[i] += scale · ‖f(p0+i) − f(q0+i)‖² (· mask[i] when given).
    fn add_dist3(
        e: &mut [f32],
        f: &[Vec<f32>; 3],
        p0: usize,
        q0: usize,
        scale: f32,
        mask: Option<&[f32]>,
    ) as add_dist3_impl {
        let len = e.len();
        let (a0, a1, a2) = (
            &f[0][p0..p0 + len],
            &f[1][p0..p0 + len],
            &f[2][p0..p0 + len],
        );
        let (b0, b1, b2) = (
            &f[0][q0..q0 + len],
            &f[1][q0..q0 + len],
            &f[2][q0..q0 + len],
        );
        match mask {
            None => {
                for i in 0..len {
                    let (x, y, z) = (a0[i] - b0[i], a1[i] - b1[i], a2[i] - b2[i]);
                    e[i] += (x * x + y * y + z * z) * scale;
                }
            }
            Some(m) => {
                let m = &m[..len];
                for i in 0..len {
                    let (x, y, z) = (a0[i] - b0[i], a1[i] - b1[i], a2[i] - b2[i]);
                    e[i] += (x * x + y * y + z * z) * scale * m[i];
                }
            }
        }
    }
}

multiversion! {
    /// e[i] += inv_d · ((dp[i] − dq[i]) · ip[i])²: the relative depth term.
    fn add_rel_depth(e: &mut [f32], dp: &[f32], dq: &[f32], ip: &[f32], inv_d: f32)
        as add_rel_depth_impl {
        let len = e.len();
        let (dp, dq, ip) = (&dp[..len], &dq[..len], &ip[..len]);
        for i in 0..len {
            let t = (dp[i] - dq[i]) * ip[i];
            e[i] += t * t * inv_d;
        }
    }
}

multiversion! {
    /// acc += w·colour and w for one tap, w = ws·exp(−e)·valid_q·[same class]. A separate
    /// function whose slice arguments cannot alias, so the loop vectorises (16 lanes in the
    /// AVX-512 copy, 8 in the AVX2 one; the baseline's SSE loop had 4).
    fn accumulate(
        ws: f32,
        e: &[f32],
        masks: [&[f32]; 3],
        colour: [&[f32]; 3],
        acc: [&mut [f32]; 4],
    ) as accumulate_impl {
        let len = e.len();
        let ([qv, pbg, qbg], [cr, cg, cb]) = (masks, colour);
        let [ar, ag, ab, aw] = acc;
        let (ar, ag, ab, aw) = (
            &mut ar[..len],
            &mut ag[..len],
            &mut ab[..len],
            &mut aw[..len],
        );
        let (qv, pbg, qbg, cr, cg, cb) = (
            &qv[..len],
            &pbg[..len],
            &qbg[..len],
            &cr[..len],
            &cg[..len],
            &cb[..len],
        );
        for i in 0..len {
            let same = 1.0 - (pbg[i] - qbg[i]).abs();
            let wgt = ws * exp_neg(-e[i]) * qv[i] * same;
            ar[i] += wgt * cr[i];
            ag[i] += wgt * cg[i];
            ab[i] += wgt * cb[i];
            aw[i] += wgt;
        }
    }
}
