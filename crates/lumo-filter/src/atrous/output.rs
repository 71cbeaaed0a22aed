//! Writing the À-Trous result back: the filtered colour out of the working layout into an
//! image, with the albedo multiplied back and pass-through pixels restored.

use lumo_image::Image;
use rayon::prelude::*;

use super::input::Input;
use super::kernel::K;
use super::lanes::albedo_row;
use super::layout::{Layout, M, QW};
use crate::common::albedo::{albedo_divisor, ALBEDO_EPS};
use crate::common::passthrough::passed;
use crate::common::zeroed::zeroed_image;

/// Copies the filtered colour out of `src` into an image; with demodulation, multiplies the
/// albedo back and puts the pass-through pixels' own colour back (0 where not finite).
pub(super) fn output(inp: &Input, lay: Layout, src: &[f32]) -> Image {
    let (w, h) = (lay.w, lay.h);
    let mut out = zeroed_image(w, h, 3);
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
    pub(super) fn output_row(inp: &Input, i0: usize, blk: &[f32], o: &mut [f32])
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
