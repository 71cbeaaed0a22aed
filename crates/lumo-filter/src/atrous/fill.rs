//! The second input pass: every block (strip × row) of the working layout filled from the
//! images — colour (demodulated), validity, variance, background flag and the scaled feature
//! coordinates — with the rules of input.rs, run by run (lanes.rs).

use rayon::prelude::*;

use super::input::{FillScales, Input};
use super::kernel::{K, KA};
use super::lanes::{color_run, variance_run, ColorPlanes, LANES};
use super::layout::{Layout, M, QW};
use super::BACKGROUND_SCALE;
use crate::common::gbuffer::{depth_is_background, position_is_background, Features};

/// Aux plane that holds a block's background flags while `fill_block` fills it (the
/// luminance plane, which `level_aux` writes before any kernel reads it).
const BG_PLANE: usize = 1;

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

multiversion! {
    /// Fills block (strip `c`, row `y`): `blk` (K planes: colour, validity, variance) and
    /// `ab` (KA planes: the background flag in [`BG_PLANE`], the features from plane 2,
    /// scaled for the first level), margins included (0 beyond the image).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn fill_block(
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
            let (head, var) = blk.split_at_mut(4 * QW);
            let var = &mut var[ja..jb];
            variance_run(inp, i0, s.inv_ml2, var);
            // No variance where there is no colour: the pair path adds w²·var without the
            // validity factor (as it adds w·colour), and a missing pixel's variance (a
            // non-finite sample's, a sparse hole's) must not reach its neighbours.
            for (v, &valid) in var.iter_mut().zip(&head[3 * QW + ja..3 * QW + jb]) {
                *v = if valid > 0.0 { *v } else { 0.0 };
            }
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
pub(super) fn fill_all(
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
pub(super) fn background_row(f: &Features, i0: usize, out: &mut [f32]) {
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
