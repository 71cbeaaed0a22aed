//! Temporal anti-aliasing of the final image (TAA; Karis 2014, variance clipping after Salvi
//! 2016), the optional last stage of SVGF: the previous output is read at pixel + motion
//! (Catmull-Rom, so repeated resampling does not blur), clipped to the current image's 3×3
//! neighbourhood (mean ± γ·σ per channel, within its min / max) and blended with the current
//! pixel. The clip is what keeps a changed pixel (a moved shadow, a disocclusion the motion
//! vectors miss) from ghosting; the blend averages the jittered 1-spp edges and lights into
//! anti-aliased ones.

use lumo_image::Image;
use rayon::prelude::*;

use crate::common::error::param;
use crate::common::gbuffer::{check_color, check_size};
use crate::FilterError;

/// Default blend weight of the current frame.
pub const DEFAULT_TAA_ALPHA: f32 = 0.2;
/// Default clip width γ in standard deviations of the 3×3 neighbourhood.
pub const DEFAULT_TAA_GAMMA: f32 = 1.0;

/// Temporal anti-aliasing with its history (the last output). Stateful like
/// [`super::TemporalFilter`]; pure otherwise.
#[derive(Debug)]
pub struct TemporalAntialias {
    alpha: f32,
    gamma: f32,
    history: Option<Image>,
}

impl TemporalAntialias {
    /// TAA blending the current frame with weight `alpha` (0 < α ≤ 1; 1 = off) after clipping
    /// the history to mean ± `gamma`·σ of the current 3×3 neighbourhood (γ ≥ 0, finite).
    pub fn new(alpha: f32, gamma: f32) -> Result<Self, FilterError> {
        if !(alpha > 0.0 && alpha <= 1.0) {
            return Err(param("taa alpha", format!("{alpha} (use 0 < α ≤ 1)")));
        }
        if !(gamma.is_finite() && gamma >= 0.0) {
            return Err(param("taa gamma", format!("{gamma} (use a finite γ ≥ 0)")));
        }
        Ok(Self {
            alpha,
            gamma,
            history: None,
        })
    }

    /// Forgets the history.
    pub fn reset(&mut self) {
        self.history = None;
    }

    /// Anti-aliases `image` (3 channels) with the history reprojected by `motion` (2
    /// channels, as [`super::TemporalFrame::motion`]; non-finite = no history; `None` = still
    /// camera) and keeps the result as the next history. Non-finite input pixels are output
    /// as 0 (and so kept). A frame of another size resets the history.
    pub fn apply(&mut self, image: &Image, motion: Option<&Image>) -> Result<Image, FilterError> {
        check_color("color", image)?;
        let (w, h) = (image.width, image.height);
        if let Some(m) = motion {
            check_size("motion", m, "color", w, h)?;
            if m.channels < 2 {
                return Err(FilterError::Channels {
                    name: "motion",
                    got: m.channels,
                    expected: "2 (dx, dy)",
                });
            }
        }
        if self
            .history
            .as_ref()
            .is_some_and(|hi| hi.width != w || hi.height != h)
        {
            self.reset();
        }
        let cur = |x: isize, y: isize| -> [f32; 3] {
            let (x, y) = (x.clamp(0, w as isize - 1), y.clamp(0, h as isize - 1));
            let i = 3 * (y as usize * w + x as usize);
            [0, 1, 2].map(|k| finite(image.data[i + k]))
        };
        let mut out = Image::new(w, h, 3, 0.0);
        let hist = self.history.as_ref();
        let (alpha, gamma) = (self.alpha, self.gamma);
        out.data
            .par_chunks_mut(3 * w)
            .enumerate()
            .for_each(|(y, row)| {
                for x in 0..w {
                    let c = cur(x as isize, y as isize);
                    let o = &mut row[3 * x..3 * x + 3];
                    let prev = hist.and_then(|hi| {
                        let (mx, my) = match motion {
                            Some(m) => {
                                let i = (y * w + x) * m.channels;
                                (m.data[i], m.data[i + 1])
                            }
                            None => (0.0, 0.0),
                        };
                        catmull_rom(hi, x as f32 + mx, y as f32 + my)
                    });
                    let Some(p) = prev else {
                        o.copy_from_slice(&c);
                        continue;
                    };
                    let (mut sum, mut sq) = ([0.0f32; 3], [0.0f32; 3]);
                    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
                    for dy in -1..=1 {
                        for dx in -1..=1 {
                            let v = cur(x as isize + dx, y as isize + dy);
                            for k in 0..3 {
                                sum[k] += v[k];
                                sq[k] += v[k] * v[k];
                                lo[k] = lo[k].min(v[k]);
                                hi[k] = hi[k].max(v[k]);
                            }
                        }
                    }
                    for k in 0..3 {
                        let mean = sum[k] / 9.0;
                        let sd = (sq[k] / 9.0 - mean * mean).max(0.0).sqrt();
                        let a = (mean - gamma * sd).max(lo[k]);
                        let b = (mean + gamma * sd).min(hi[k]);
                        let hk = p[k].clamp(a, b.max(a));
                        o[k] = finite(hk + alpha * (c[k] - hk));
                    }
                }
            });
        self.history = Some(out.clone());
        Ok(out)
    }
}

#[inline]
fn finite(v: f32) -> f32 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

/// Catmull-Rom weights of the four taps around a sample at fraction `t` past the second.
fn weights(t: f32) -> [f32; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ]
}

/// `img` at pixel coordinates (`px`, `py`) (pixel centres at integers), Catmull-Rom with
/// clamped edges; `None` outside the image or when not finite.
fn catmull_rom(img: &Image, px: f32, py: f32) -> Option<[f32; 3]> {
    let (w, h) = (img.width, img.height);
    if !(px > -0.5 && py > -0.5 && px < w as f32 - 0.5 && py < h as f32 - 0.5) {
        return None;
    }
    let (x0, y0) = (px.floor(), py.floor());
    let (wx, wy) = (weights(px - x0), weights(py - y0));
    let (x0, y0) = (x0 as isize, y0 as isize);
    let mut c = [0.0f32; 3];
    for (j, wyj) in wy.iter().enumerate() {
        let y = (y0 - 1 + j as isize).clamp(0, h as isize - 1) as usize;
        for (i, wxi) in wx.iter().enumerate() {
            let x = (x0 - 1 + i as isize).clamp(0, w as isize - 1) as usize;
            let t = 3 * (y * w + x);
            for k in 0..3 {
                c[k] += wxi * wyj * img.data[t + k];
            }
        }
    }
    c.iter().all(|v| v.is_finite()).then_some(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize, shift: f32) -> Image {
        let mut img = Image::new(w, h, 3, 0.0);
        for y in 0..h {
            for x in 0..w {
                let v = 0.1 * (x as f32 + shift) + 0.05 * y as f32;
                img.pixel_mut(x, y).copy_from_slice(&[v, 2.0 * v, 0.5]);
            }
        }
        img
    }

    #[test]
    fn catmull_rom_reproduces_a_linear_ramp_at_fractional_positions() {
        let img = ramp(16, 12, 0.0);
        let c = catmull_rom(&img, 5.3, 4.6).unwrap();
        let v = 0.1 * 5.3 + 0.05 * 4.6;
        assert!(
            (c[0] - v).abs() < 1e-5 && (c[1] - 2.0 * v).abs() < 1e-5,
            "{c:?}"
        );
        assert!(catmull_rom(&img, -0.6, 3.0).is_none());
        assert!(catmull_rom(&img, f32::NAN, 3.0).is_none());
    }

    #[test]
    fn still_image_stays_and_moving_ramp_follows_its_motion() {
        let (w, h) = (20, 16);
        let mut taa = TemporalAntialias::new(0.2, 1.0).unwrap();
        let a = ramp(w, h, 0.0);
        taa.apply(&a, None).unwrap();
        let out = taa.apply(&a, None).unwrap();
        for (o, i) in out.data.iter().zip(&a.data) {
            assert!((o - i).abs() < 1e-5);
        }
        // The ramp moves half a pixel left: the history is read half a pixel right.
        let b = ramp(w, h, 0.5);
        let motion = Image::new(w, h, 2, 0.0);
        let mut m = motion.clone();
        for v in m.data.chunks_exact_mut(2) {
            v[0] = 0.5;
        }
        let out = taa.apply(&b, Some(&m)).unwrap();
        for y in 2..h - 2 {
            for x in 2..w - 2 {
                let (o, i) = (out.pixel(x, y)[0], b.pixel(x, y)[0]);
                assert!((o - i).abs() < 1e-4, "({x}, {y}): {o} vs {i}");
            }
        }
    }

    #[test]
    fn a_changed_pixel_does_not_ghost() {
        // A bright history over a now dark, flat neighbourhood is clipped to it at once.
        let (w, h) = (8, 8);
        let mut taa = TemporalAntialias::new(0.1, 1.0).unwrap();
        taa.apply(&Image::new(w, h, 3, 5.0), None).unwrap();
        let out = taa.apply(&Image::new(w, h, 3, 0.2), None).unwrap();
        assert!(out.data.iter().all(|&v| (v - 0.2).abs() < 1e-6));
        assert!(TemporalAntialias::new(0.0, 1.0).is_err());
        assert!(TemporalAntialias::new(0.5, f32::NAN).is_err());
        let nan = Image::new(w, h, 3, f32::NAN);
        assert!(taa
            .apply(&nan, None)
            .unwrap()
            .data
            .iter()
            .all(|&v| v == 0.0));
    }
}
