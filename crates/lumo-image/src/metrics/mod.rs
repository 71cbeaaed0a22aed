//! Image-difference metrics: how far a test image is from a reference.
//!
//! Every metric takes `(reference, test)` and returns a typed [`MetricError`] instead of
//! panicking when the two cannot be compared. The conventions, shared by `lumo compare` and the
//! benchmark tables so that their numbers agree:
//!
//! - [`mse`], [`relmse`] and [`smape`] work on the linear (HDR) values, every channel.
//! - [`psnr`] and [`ssim`] work on display values from [`tone_map`]: the sRGB transfer
//!   function of `clamp(2^exposure · x, 0, 1)`; SSIM on the tone-mapped Rec. 709 luminance.
//! - [`flip`] is NVIDIA's LDR-FLIP on the same exposed, clamped sRGB image.
//! - A pixel where either image has a NaN or infinite channel is *excluded*: it is left out of
//!   every mean, and [`compare`] reports how many there were. For the spatial metrics (SSIM,
//!   FLIP) such a pixel still sits inside its neighbours' windows, so it is first given the same
//!   finite value in both images (the other image's value, or 0 when neither is finite); that
//!   way it adds no difference of its own.

mod falsecolor;
mod flip;
mod mse;
mod psnr;
mod relmse;
mod separable;
mod smape;
mod ssim;

pub use falsecolor::{false_colour, relmse_map, DiffMetric, EXCLUDED_COLOUR};
pub use flip::{flip, flip_map, FlipSettings, FLIP_DEFAULT_PPD};
pub use mse::mse;
pub use psnr::psnr;
pub use relmse::{relmse, RELMSE_EPSILON};
pub use smape::{smape, SMAPE_EPSILON};
pub use ssim::{ssim, SSIM_K1, SSIM_K2, SSIM_SIGMA, SSIM_WINDOW};

use crate::{linear_to_srgb, luminance, Image};

/// Why two images cannot be compared.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum MetricError {
    /// Width or height differ.
    #[error("size mismatch: reference is {ref_width}x{ref_height} but test is {test_width}x{test_height}")]
    SizeMismatch {
        /// Reference width in pixels.
        ref_width: usize,
        /// Reference height in pixels.
        ref_height: usize,
        /// Test width in pixels.
        test_width: usize,
        /// Test height in pixels.
        test_height: usize,
    },
    /// Channel counts differ (e.g. a one-channel depth map against an RGB image).
    #[error("channel mismatch: reference has {reference} channels but test has {test}")]
    ChannelMismatch {
        /// Channels of the reference.
        reference: usize,
        /// Channels of the test image.
        test: usize,
    },
    /// Nothing is left to average: the images are empty or every pixel is excluded.
    #[error(
        "no pixel is finite in both images ({excluded} of {total} pixels are NaN or infinite)"
    )]
    NoValidPixels {
        /// Pixels excluded because a channel is NaN or infinite in either image.
        excluded: usize,
        /// All pixels.
        total: usize,
    },
}

/// Human-readable statement of the tone map used by PSNR, SSIM and FLIP, for reports.
pub const TONE_MAP_DESCRIPTION: &str = "sRGB OETF of clamp(2^exposure * x, 0, 1)";

/// Display value of one linear value: `linear_to_srgb(clamp(2^exposure · x, 0, 1))`.
///
/// Clamping rather than a compressive curve (Reinhard, ACES) keeps the scores those of the
/// image a viewer sees at that exposure, and keeps PSNR's peak at exactly 1.
#[inline]
pub fn tone_map(x: f32, exposure: f32) -> f32 {
    linear_to_srgb(expose(x, exposure))
}

/// `clamp(2^exposure · x, 0, 1)`: the linear value that reaches the display.
#[inline]
pub(crate) fn expose(x: f32, exposure: f32) -> f32 {
    let v = x * exposure.exp2();
    // 0 · 2^200 is 0 · inf = NaN in f32; a black pixel stays black at any exposure.
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

/// Settings shared by all metrics in [`compare`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompareSettings {
    /// Exposure in stops applied before tone mapping (PSNR, SSIM, FLIP); 0 leaves values as
    /// they are.
    pub exposure: f32,
    /// Pixels per degree of visual angle assumed by FLIP.
    pub flip_ppd: f32,
}

impl Default for CompareSettings {
    fn default() -> Self {
        Self {
            exposure: 0.0,
            flip_ppd: FLIP_DEFAULT_PPD,
        }
    }
}

/// All scores of one test image against its reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metrics {
    /// Mean squared error of the linear values.
    pub mse: f64,
    /// Relative MSE, ε = [`RELMSE_EPSILON`].
    pub relmse: f64,
    /// Symmetric mean absolute percentage error, ε = [`SMAPE_EPSILON`], in [0, 1].
    pub smape: f64,
    /// PSNR in dB of the tone-mapped values; `f64::INFINITY` when they are identical.
    pub psnr: f64,
    /// Mean SSIM of the tone-mapped luminance, at most 1.
    pub ssim: f64,
    /// Mean LDR-FLIP, in [0, 1].
    pub flip: f64,
    /// Pixels left out because a channel is NaN or infinite in either image.
    pub nonfinite_pixels: usize,
}

impl Metrics {
    /// The linear values differ but the tone-mapped ones are identical: every differing pixel
    /// clips to white (or black) at the exposure, so PSNR (∞), SSIM (1) and FLIP (0) cannot
    /// see the difference (`--exposure 64` scored two different images a perfect match).
    pub fn clipped_alike(&self) -> bool {
        self.mse > 0.0 && self.psnr == f64::INFINITY
    }
}

/// Every metric of `test` against `reference`, sharing one validity mask.
pub fn compare(
    reference: &Image,
    test: &Image,
    settings: &CompareSettings,
) -> Result<Metrics, MetricError> {
    let pair = Pair::new(reference, test)?;
    Ok(Metrics {
        mse: mse::mse_pair(&pair),
        relmse: relmse::relmse_pair(&pair),
        smape: smape::smape_pair(&pair),
        psnr: psnr::psnr_pair(&pair, settings.exposure),
        ssim: ssim::ssim_pair(&pair, settings.exposure),
        flip: flip::mean_of_map(&flip::flip_map_pair(
            &pair,
            &FlipSettings {
                exposure: settings.exposure,
                ppd: settings.flip_ppd,
            },
        )),
        nonfinite_pixels: pair.excluded,
    })
}

/// Number of pixels that any metric leaves out: those with a NaN or infinite channel in either
/// image. Errors as the metrics do when the images cannot be compared.
pub fn nonfinite_pixels(reference: &Image, test: &Image) -> Result<usize, MetricError> {
    match Pair::new(reference, test) {
        Ok(pair) => Ok(pair.excluded),
        Err(MetricError::NoValidPixels { excluded, .. }) => Ok(excluded),
        Err(e) => Err(e),
    }
}

/// Two images checked for comparability, with the per-pixel validity mask.
pub(crate) struct Pair<'a> {
    pub reference: &'a Image,
    pub test: &'a Image,
    /// `valid[p]`: every channel of pixel `p` is finite in both images.
    pub valid: Vec<bool>,
    /// Count of `false` in `valid`.
    pub excluded: usize,
}

impl<'a> Pair<'a> {
    pub fn new(reference: &'a Image, test: &'a Image) -> Result<Self, MetricError> {
        if reference.width != test.width || reference.height != test.height {
            return Err(MetricError::SizeMismatch {
                ref_width: reference.width,
                ref_height: reference.height,
                test_width: test.width,
                test_height: test.height,
            });
        }
        if reference.channels != test.channels {
            return Err(MetricError::ChannelMismatch {
                reference: reference.channels,
                test: test.channels,
            });
        }
        let c = reference.channels.max(1);
        let valid: Vec<bool> = reference
            .data
            .chunks_exact(c)
            .zip(test.data.chunks_exact(c))
            .map(|(r, t)| r.iter().chain(t).all(|v| v.is_finite()))
            .collect();
        let total = reference.pixel_count();
        let excluded = valid.iter().filter(|v| !**v).count();
        if excluded == total || reference.channels == 0 {
            return Err(MetricError::NoValidPixels { excluded, total });
        }
        Ok(Self {
            reference,
            test,
            valid,
            excluded,
        })
    }

    /// Number of pixels that enter the means.
    pub fn valid_count(&self) -> usize {
        self.valid.len() - self.excluded
    }

    /// Mean over valid pixels and all channels of `f(reference value, test value)`, in f64.
    pub fn channel_mean(&self, f: impl Fn(f64, f64) -> f64) -> f64 {
        let c = self.reference.channels;
        let mut sum = 0.0f64;
        for ((r, t), ok) in self
            .reference
            .data
            .chunks_exact(c)
            .zip(self.test.data.chunks_exact(c))
            .zip(&self.valid)
        {
            if *ok {
                sum += r
                    .iter()
                    .zip(t)
                    .map(|(&r, &t)| f(r as f64, t as f64))
                    .sum::<f64>();
            }
        }
        sum / (self.valid_count() * c) as f64
    }

    /// Both images as linear RGB planes (grey broadcast), with excluded pixels given one
    /// shared finite value: the finite image's value, or 0 if neither is finite. Returned as
    /// `[reference, test]`, each `[r, g, b]` planes of `width * height` values.
    pub fn sanitised_rgb(&self) -> [[Vec<f32>; 3]; 2] {
        let (w, h) = (self.reference.width, self.reference.height);
        let mut out: [[Vec<f32>; 3]; 2] = Default::default();
        for planes in out.iter_mut() {
            for p in planes.iter_mut() {
                *p = vec![0.0; w * h];
            }
        }
        let finite = |v: [f32; 3]| v.iter().all(|x| x.is_finite());
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let mut r = self.reference.rgb(x, y);
                let mut t = self.test.rgb(x, y);
                if !self.valid[i] {
                    let shared = if finite(r) {
                        r
                    } else if finite(t) {
                        t
                    } else {
                        [0.0; 3]
                    };
                    r = shared;
                    t = shared;
                }
                for c in 0..3 {
                    out[0][c][i] = r[c];
                    out[1][c][i] = t[c];
                }
            }
        }
        out
    }

    /// Tone-mapped luminance planes `[reference, test]` (see [`tone_map`]), sanitised as in
    /// [`Pair::sanitised_rgb`].
    pub fn tone_mapped_luminance(&self, exposure: f32) -> [Vec<f64>; 2] {
        self.sanitised_rgb().map(|[r, g, b]| {
            r.iter()
                .zip(&g)
                .zip(&b)
                .map(|((&r, &g), &b)| tone_map(luminance([r, g, b]), exposure) as f64)
                .collect()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mismatches_are_typed_errors() {
        let a = Image::new(4, 3, 3, 0.5);
        let b = Image::new(3, 4, 3, 0.5);
        assert_eq!(
            mse(&a, &b),
            Err(MetricError::SizeMismatch {
                ref_width: 4,
                ref_height: 3,
                test_width: 3,
                test_height: 4
            })
        );
        let c = Image::new(4, 3, 1, 0.5);
        assert_eq!(
            compare(&a, &c, &CompareSettings::default()),
            Err(MetricError::ChannelMismatch {
                reference: 3,
                test: 1
            })
        );
        let empty = Image::new(0, 0, 3, 0.0);
        assert!(matches!(
            ssim(&empty, &empty, 0.0),
            Err(MetricError::NoValidPixels { total: 0, .. })
        ));
        let nan = Image::new(4, 3, 3, f32::NAN);
        assert_eq!(
            flip(&a, &nan, &FlipSettings::default()),
            Err(MetricError::NoValidPixels {
                excluded: 12,
                total: 12
            })
        );
        assert_eq!(nonfinite_pixels(&a, &nan), Ok(12));
    }

    #[test]
    fn identical_images_score_perfectly() {
        let mut img = Image::new(16, 13, 3, 0.0);
        for (i, v) in img.data.iter_mut().enumerate() {
            *v = ((i * 37) % 101) as f32 / 40.0;
        }
        let m = compare(&img, &img, &CompareSettings::default()).unwrap();
        assert_eq!(m.mse, 0.0);
        assert_eq!(m.relmse, 0.0);
        assert_eq!(m.smape, 0.0);
        assert_eq!(m.psnr, f64::INFINITY);
        assert!((m.ssim - 1.0).abs() < 1e-12, "{}", m.ssim);
        assert_eq!(m.flip, 0.0);
        assert_eq!(m.nonfinite_pixels, 0);
    }

    #[test]
    fn nonfinite_pixels_are_counted_and_excluded() {
        let mut r = Image::new(8, 8, 3, 0.25);
        let mut t = Image::new(8, 8, 3, 0.5);
        // Two bad pixels in the test image, one in the reference, one overlapping: 3 excluded.
        t.pixel_mut(1, 1)[0] = f32::NAN;
        t.pixel_mut(2, 5)[2] = f32::INFINITY;
        r.pixel_mut(2, 5)[1] = f32::NEG_INFINITY;
        r.pixel_mut(7, 0)[0] = f32::NAN;
        let m = compare(&r, &t, &CompareSettings::default()).unwrap();
        assert_eq!(m.nonfinite_pixels, 3);
        // The remaining pixels all differ by 0.25, so the mean is unaffected by the bad ones.
        assert!((m.mse - 0.0625).abs() < 1e-12);
        for v in [m.mse, m.relmse, m.smape, m.psnr, m.ssim, m.flip] {
            assert!(v.is_finite(), "{m:?}");
        }
    }

    #[test]
    fn tone_map_clamps_and_encodes() {
        assert_eq!(tone_map(-1.0, 0.0), 0.0);
        // The sRGB curve at 1 is 1.055 − 0.055, which f32 rounds to 1 − 6e-8.
        assert!((tone_map(5.0, 0.0) - 1.0).abs() < 1e-7);
        assert_eq!(tone_map(5.0, 0.0), tone_map(1.0, 0.0));
        assert!((tone_map(0.25, 1.0) - linear_to_srgb(0.5)).abs() < 1e-7);
        assert!((tone_map(0.214_041_14, 0.0) - 0.5).abs() < 1e-5);
        assert_eq!(tone_map(0.0, 1000.0), 0.0);
        assert_eq!(tone_map(1e-30, 1000.0), tone_map(1.0, 0.0));
    }
}
