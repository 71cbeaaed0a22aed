//! Feature planes (the G-buffer) and their preparation into the plain, finite,
//! structure-of-arrays planes that the filters' inner loops read.

use lumo_image::{luminance, Image};
use rayon::prelude::*;

use crate::FilterError;

/// Optional full-resolution feature planes that steer the filters. All must have the colour
/// image's width and height.
///
/// Conventions: world-space normals in [-1, 1] (3 channels); world-space positions (3 channels);
/// depth = distance to the camera (1 channel, or 3 equal ones: the first is used), 0 or ±Inf
/// where nothing was hit; albedo (3 channels, or 1 broadcast); variance of the pixel estimate's
/// luminance (1 channel, or 3: their luminance is used).
///
/// A pixel is *background* when its depth is 0 or not finite, or its position is not finite.
/// Filters never mix background and geometry pixels.
#[derive(Clone, Copy, Debug, Default)]
pub struct Features<'a> {
    /// World-space unit normals.
    pub normal: Option<&'a Image>,
    /// World-space positions.
    pub position: Option<&'a Image>,
    /// Camera distance.
    pub depth: Option<&'a Image>,
    /// Surface albedo (diffuse reflectance), for demodulation.
    pub albedo: Option<&'a Image>,
    /// Per-pixel variance of the colour estimate (luminance).
    pub variance: Option<&'a Image>,
}

/// A filter's result.
#[derive(Clone, Debug, PartialEq)]
pub struct Filtered {
    /// The filtered image (3 channels, all values finite).
    pub image: Image,
    /// How many input colour pixels were NaN or infinite and were treated as missing.
    pub missing: usize,
}

/// Colour and features of one image as finite SoA planes.
pub(crate) struct Prepared {
    pub w: usize,
    pub h: usize,
    /// Colour channels, missing pixels set to 0.
    pub color: [Vec<f32>; 3],
    /// 1 where the colour is usable, 0 where missing; multiplies every weight.
    pub valid: Vec<f32>,
    /// Count of non-finite colour pixels.
    pub missing: usize,
    /// Normals, non-finite components set to 0.
    pub normal: Option<[Vec<f32>; 3]>,
    /// Positions divided by the scene extent (so sigmas are scene-scale free); 0 on background.
    pub position: Option<[Vec<f32>; 3]>,
    /// Depth, 0 on background.
    pub depth: Option<Vec<f32>>,
    /// 1 on background pixels, else 0.
    pub background: Vec<f32>,
    /// Mean luminance of the valid colour pixels (> 0), the unit of colour distances.
    pub mean_luminance: f32,
}

/// Error unless `img` is `w`×`h`.
pub(crate) fn check_size(
    name: &'static str,
    img: &Image,
    reference: &'static str,
    w: usize,
    h: usize,
) -> Result<(), FilterError> {
    if img.width == w && img.height == h {
        Ok(())
    } else {
        Err(FilterError::SizeMismatch {
            name,
            width: img.width,
            height: img.height,
            reference,
            ref_width: w,
            ref_height: h,
        })
    }
}

/// Error unless the colour image is non-empty with 3 channels.
pub(crate) fn check_color(name: &'static str, color: &Image) -> Result<(), FilterError> {
    if color.width == 0 || color.height == 0 {
        return Err(FilterError::Empty {
            name,
            width: color.width,
            height: color.height,
        });
    }
    if color.channels != 3 {
        return Err(FilterError::Channels {
            name,
            got: color.channels,
            expected: "3 (RGB)",
        });
    }
    if color.data.len() != color.width * color.height * 3 {
        return Err(FilterError::Parameter {
            name,
            reason: "data length does not match width*height*channels".into(),
        });
    }
    Ok(())
}

fn check_feature(
    name: &'static str,
    img: &Image,
    w: usize,
    h: usize,
    min_channels: usize,
    expected: &'static str,
) -> Result<(), FilterError> {
    check_size(name, img, "color", w, h)?;
    if img.channels < min_channels || img.data.len() != w * h * img.channels {
        return Err(FilterError::Channels {
            name,
            got: img.channels,
            expected,
        });
    }
    Ok(())
}

/// First three channels of `img` as planes, non-finite values replaced by 0.
pub(crate) fn planes3(img: &Image) -> [Vec<f32>; 3] {
    let c = img.channels;
    let get = |k: usize| -> Vec<f32> {
        img.data
            .chunks_exact(c)
            .map(|p| {
                let v = p[k];
                if v.is_finite() {
                    v
                } else {
                    0.0
                }
            })
            .collect()
    };
    [get(0), get(1), get(2)]
}

/// First channel of `img` as a plane (raw, may hold non-finite values).
pub(crate) fn plane0(img: &Image) -> Vec<f32> {
    img.data.chunks_exact(img.channels).map(|p| p[0]).collect()
}

/// Validates `features` against the `w`×`h` colour image.
pub(crate) fn check_features(f: &Features, w: usize, h: usize) -> Result<(), FilterError> {
    if let Some(n) = f.normal {
        check_feature("normal", n, w, h, 3, "3 (x, y, z)")?;
    }
    if let Some(p) = f.position {
        check_feature("position", p, w, h, 3, "3 (x, y, z)")?;
    }
    if let Some(d) = f.depth {
        check_feature("depth", d, w, h, 1, "1 (or 3 equal ones)")?;
        check_depth_plane(d)?;
    }
    if let Some(a) = f.albedo {
        if a.channels == 2 {
            return Err(FilterError::Channels {
                name: "albedo",
                got: 2,
                expected: "1 or 3",
            });
        }
        check_feature("albedo", a, w, h, 1, "1 or 3")?;
    }
    if let Some(v) = f.variance {
        if v.channels == 2 {
            return Err(FilterError::Channels {
                name: "variance",
                got: 2,
                expected: "1 or 3",
            });
        }
        check_feature("variance", v, w, h, 1, "1 or 3")?;
    }
    Ok(())
}

/// A depth plane with more than one channel must hold the same value in its first three
/// (the filters read the first): a normal or position plane given as depth would otherwise
/// steer them with one coordinate (a light once lost 90 % of its value that way). NaN
/// pixels (background) are not compared. (Every filter checks this; callers that know the
/// plane's file check it first to name the file.)
pub fn check_depth_plane(d: &Image) -> Result<(), FilterError> {
    if d.channels < 2 {
        return Ok(());
    }
    let k = d.channels.min(3);
    let differs = |p: &[f32]| {
        p[1..k]
            .iter()
            .any(|&v| v != p[0] && !(v.is_nan() && p[0].is_nan()))
    };
    match d.data.chunks_exact(d.channels).position(differs) {
        None => Ok(()),
        Some(i) => {
            let p = &d.data[i * d.channels..][..k];
            let mut values = [p[0]; 3];
            values[..k].copy_from_slice(p);
            Err(FilterError::DepthChannelsDiffer {
                channels: d.channels,
                x: i % d.width,
                y: i / d.width,
                values,
            })
        }
    }
}

/// Whether pixel `i` is background: depth 0 or not finite, or position not finite.
pub(crate) fn is_background(f: &Features, i: usize) -> bool {
    let d = f
        .depth
        .is_some_and(|d| depth_is_background(d.data[i * d.channels]));
    let p = f
        .position
        .is_some_and(|p| position_is_background(&p.data[i * p.channels..][..3]));
    d || p
}

/// The depth half of [`is_background`]: 0, negative or not finite.
#[inline(always)]
pub(crate) fn depth_is_background(d: f32) -> bool {
    !(d.is_finite() && d > 0.0)
}

/// The position half of [`is_background`]: a coordinate not finite (`p` holds ≥ 3).
#[inline(always)]
pub(crate) fn position_is_background(p: &[f32]) -> bool {
    !(p[0].is_finite() & p[1].is_finite() & p[2].is_finite())
}

/// Background mask from depth and position (1 = nothing hit).
pub(crate) fn background_mask(f: &Features, n: usize) -> Vec<f32> {
    (0..n).map(|i| is_background(f, i) as u8 as f32).collect()
}

/// Number of colour pixels with any non-finite channel.
pub fn missing_pixels(color: &Image) -> usize {
    if color.channels == 0 {
        return 0;
    }
    color
        .data
        .par_chunks_exact(color.channels)
        .filter(|p| p.iter().any(|v| !v.is_finite()))
        .count()
}

impl Prepared {
    /// Checks and converts colour + features. `color` must have 3 channels.
    pub fn new(color: &Image, f: &Features) -> Result<Self, FilterError> {
        check_color("color", color)?;
        let (w, h) = (color.width, color.height);
        check_features(f, w, h)?;
        let n = w * h;
        let mut planes = [vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]];
        let mut valid = vec![0.0f32; n];
        let mut missing = 0usize;
        let mut lum_sum = 0.0f64;
        for (i, p) in color.data.chunks_exact(3).enumerate() {
            if p.iter().all(|v| v.is_finite()) {
                planes[0][i] = flush(p[0]);
                planes[1][i] = flush(p[1]);
                planes[2][i] = flush(p[2]);
                valid[i] = 1.0;
                lum_sum += luminance([p[0], p[1], p[2]]).abs() as f64;
            } else {
                missing += 1;
            }
        }
        let n_valid = n - missing;
        let mean = if n_valid > 0 {
            (lum_sum / n_valid as f64) as f32
        } else {
            0.0
        };
        let mean_luminance = if mean.is_finite() && mean > 1e-12 {
            mean
        } else {
            1.0
        };
        let background = background_mask(f, n);
        let normal = f.normal.map(planes3);
        let depth = f.depth.map(|d| {
            plane0(d)
                .into_iter()
                .zip(&background)
                .map(|(v, &b)| if b > 0.0 { 0.0 } else { v })
                .collect()
        });
        let position = f.position.map(|p| {
            let mut pl = planes3(p);
            let extent = scene_extent(&pl, &background);
            let inv = 1.0 / extent;
            for c in pl.iter_mut() {
                for (v, &b) in c.iter_mut().zip(&background) {
                    *v = if b > 0.0 { 0.0 } else { *v * inv };
                }
            }
            pl
        });
        Ok(Self {
            w,
            h,
            color: planes,
            valid,
            missing,
            normal,
            position,
            depth,
            background,
            mean_luminance,
        })
    }
}

/// `v`, or 0 where |v| < 1e-30: denormal inputs would slow every product they enter.
#[inline(always)]
pub(crate) fn flush(v: f32) -> f32 {
    if v.abs() < 1e-30 {
        0.0
    } else {
        v
    }
}

/// Diagonal of the bounding box of the non-background positions (1 if degenerate).
pub(crate) fn scene_extent(p: &[Vec<f32>; 3], background: &[f32]) -> f32 {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for i in 0..background.len() {
        if background[i] == 0.0 {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c][i]);
                hi[c] = hi[c].max(p[c][i]);
            }
        }
    }
    let d2: f32 = (0..3).map(|c| (hi[c] - lo[c]).powi(2)).sum();
    let d = d2.sqrt();
    if d.is_finite() && d > 1e-12 {
        d
    } else {
        1.0
    }
}
