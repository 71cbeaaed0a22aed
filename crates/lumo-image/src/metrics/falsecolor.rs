//! False-colour error images: a per-pixel error map rendered through a dark-to-bright ramp,
//! for looking at *where* two images differ.

use super::relmse::relmse_value;
use super::{flip::flip_map_pair, CompareSettings, FlipSettings, MetricError, Pair};
use crate::{srgb_to_linear, Image};

/// sRGB colour of excluded (non-finite) pixels in a false-colour image: cyan, which the ramp
/// never produces.
pub const EXCLUDED_COLOUR: [f32; 3] = [0.0, 1.0, 1.0];

/// Ramp stops (position, sRGB colour): black through purple, red and orange to pale yellow,
/// monotonic in lightness so that brighter always means larger error, also in greyscale print.
const RAMP: [(f32, [f32; 3]); 5] = [
    (0.0, [0.0, 0.0, 0.02]),
    (0.25, [0.23, 0.06, 0.45]),
    (0.5, [0.75, 0.15, 0.45]),
    (0.75, [0.98, 0.5, 0.22]),
    (1.0, [0.99, 0.95, 0.7]),
];

/// Which per-pixel error a false-colour image shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DiffMetric {
    /// Per-pixel LDR-FLIP, in [0, 1], shown linearly.
    Flip,
    /// Per-pixel relMSE (mean over channels), shown on a log scale from 1e-4 (black) to 1
    /// (pale yellow) and clamped outside.
    RelMse,
}

impl DiffMetric {
    /// The per-pixel error map (one channel; excluded pixels NaN).
    pub fn map(
        self,
        reference: &Image,
        test: &Image,
        settings: &CompareSettings,
    ) -> Result<Image, MetricError> {
        match self {
            DiffMetric::Flip => Ok(flip_map_pair(
                &Pair::new(reference, test)?,
                &FlipSettings {
                    exposure: settings.exposure,
                    ppd: settings.flip_ppd,
                },
            )),
            DiffMetric::RelMse => relmse_map(reference, test),
        }
    }

    /// Position in [0, 1] on the colour ramp of an error value.
    pub fn ramp_position(self, value: f32) -> f32 {
        match self {
            DiffMetric::Flip => value.clamp(0.0, 1.0),
            DiffMetric::RelMse => {
                if value <= 0.0 {
                    0.0
                } else {
                    ((value.log10() + 4.0) / 4.0).clamp(0.0, 1.0)
                }
            }
        }
    }

    /// How the ramp maps values, for legends.
    pub fn scale_description(self) -> &'static str {
        match self {
            DiffMetric::Flip => "per-pixel FLIP, 0 (black) to 1 (pale yellow), linear",
            DiffMetric::RelMse => {
                "per-pixel relMSE, 1e-4 (black) to 1 (pale yellow), log scale, clamped"
            }
        }
    }
}

/// Per-pixel relMSE, averaged over channels, as a one-channel image; excluded pixels are NaN.
pub fn relmse_map(reference: &Image, test: &Image) -> Result<Image, MetricError> {
    let pair = Pair::new(reference, test)?;
    let c = reference.channels;
    let data = reference
        .data
        .chunks_exact(c)
        .zip(test.data.chunks_exact(c))
        .zip(&pair.valid)
        .map(|((r, t), ok)| {
            if *ok {
                let s: f64 = r
                    .iter()
                    .zip(t)
                    .map(|(&r, &t)| relmse_value(r as f64, t as f64))
                    .sum();
                (s / c as f64) as f32
            } else {
                f32::NAN
            }
        })
        .collect();
    Ok(Image::from_vec(reference.width, reference.height, 1, data))
}

/// Renders a one-channel error map through the ramp as a linear RGB image (ready for
/// [`write_image`](crate::write_image), which encodes it back to the ramp's sRGB colours).
/// NaN pixels get [`EXCLUDED_COLOUR`].
pub fn false_colour(map: &Image, metric: DiffMetric) -> Image {
    let mut out = Image::new(map.width, map.height, 3, 0.0);
    for (dst, v) in out
        .data
        .chunks_exact_mut(3)
        .zip(map.data.chunks_exact(map.channels.max(1)))
    {
        let srgb = if v[0].is_nan() {
            EXCLUDED_COLOUR
        } else {
            ramp(metric.ramp_position(v[0]))
        };
        for (d, s) in dst.iter_mut().zip(srgb) {
            *d = srgb_to_linear(s);
        }
    }
    out
}

/// sRGB colour at position `t` in [0, 1] of the ramp, linear between stops.
fn ramp(t: f32) -> [f32; 3] {
    for pair in RAMP.windows(2) {
        let ((t0, c0), (t1, c1)) = (pair[0], pair[1]);
        if t <= t1 {
            let f = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
            return [0, 1, 2].map(|i| c0[i] + f * (c1[i] - c0[i]));
        }
    }
    RAMP[RAMP.len() - 1].1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{linear_to_srgb, luminance};

    #[test]
    fn ramp_hits_its_stops_and_brightens_monotonically() {
        for (t, c) in RAMP {
            assert_eq!(ramp(t), c);
        }
        let mut last = -1.0;
        for i in 0..=100 {
            let c = ramp(i as f32 / 100.0).map(srgb_to_linear);
            let y = luminance(c);
            assert!(y > last, "lightness must grow with error at {i}");
            last = y;
        }
    }

    #[test]
    fn relmse_map_and_colours() {
        let r = Image::from_vec(3, 1, 1, vec![0.0, 1.0, 1.0]);
        let t = Image::from_vec(3, 1, 1, vec![0.1, 1.0, f32::NAN]);
        let m = relmse_map(&r, &t).unwrap();
        // 0.01 / (0 + 0.01) = 1 → top of the log scale.
        assert!((m.data[0] - 1.0).abs() < 1e-6);
        assert_eq!(m.data[1], 0.0);
        assert!(m.data[2].is_nan());
        let img = false_colour(&m, DiffMetric::RelMse);
        let srgb = |x: usize| {
            img.pixel(x, 0)
                .iter()
                .map(|&v| linear_to_srgb(v))
                .collect::<Vec<_>>()
        };
        for (a, b) in srgb(0).iter().zip(RAMP[4].1) {
            assert!((a - b).abs() < 1e-4);
        }
        for (a, b) in srgb(1).iter().zip(RAMP[0].1) {
            assert!((a - b).abs() < 1e-4);
        }
        for (a, b) in srgb(2).iter().zip(EXCLUDED_COLOUR) {
            assert!((a - b).abs() < 1e-4);
        }
        assert_eq!(DiffMetric::RelMse.ramp_position(1e-2), 0.5);
    }
}
