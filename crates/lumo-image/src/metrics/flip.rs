//! LDR-FLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating Images"):
//! a per-pixel perceptual error in [0, 1] built from a colour pipeline (contrast-sensitivity
//! filtering, then a Hunt-adjusted HyAB distance in L*a*b*) and a feature pipeline (edges and
//! points that differ between the images amplify the colour error).
//!
//! Written from the paper; `scripts/check_flip.py` records NVIDIA's `flip-evaluator` numbers
//! on the image pairs under `tests/data/flip/`, and a test holds this code to them.

use super::separable::filter_clamped;
use super::{expose, MetricError, Pair};
use crate::Image;

/// Pixels per degree of visual angle FLIP assumes by default: a 0.7 m wide, 3840-pixel
/// monitor seen from 0.7 m, as in the paper.
pub const FLIP_DEFAULT_PPD: f32 = 0.7 * (3840.0 / 0.7) * std::f32::consts::PI / 180.0;

/// Exponent compressing the colour distance (the paper's q_c).
const QC: f32 = 0.7;
/// Fraction of the maximum colour distance mapped to [`PT`] of the error range (p_c).
const PC: f32 = 0.4;
/// Error assigned at `PC · cmax` (p_t).
const PT: f32 = 0.95;
/// Width of the feature detectors in degrees (w).
const FEATURE_WIDTH: f32 = 0.082;
/// Exponent of the feature difference (q_f).
const QF: f32 = 0.5;

/// Linear sRGB → CIE XYZ (D65), derived from the sRGB primaries and white point.
const RGB_TO_XYZ: [[f32; 3]; 3] = [
    [0.412_390_8, 0.357_584_34, 0.180_480_8],
    [0.212_639, 0.715_168_7, 0.072_192_32],
    [0.019_330_82, 0.119_194_78, 0.950_532_15],
];
/// The inverse of [`RGB_TO_XYZ`].
const XYZ_TO_RGB: [[f32; 3]; 3] = [
    [3.240_97, -1.537_383_2, -0.498_610_76],
    [-0.969_243_65, 1.875_967_5, 0.041_555_06],
    [0.055_630_08, -0.203_976_96, 1.056_971_5],
];

/// Settings of [`flip`] and [`flip_map`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlipSettings {
    /// Exposure in stops: the linear images are scaled by `2^exposure` and clamped to [0, 1]
    /// before FLIP sees them (as the sRGB images a display would show).
    pub exposure: f32,
    /// Pixels per degree of visual angle.
    pub ppd: f32,
}

impl Default for FlipSettings {
    fn default() -> Self {
        Self {
            exposure: 0.0,
            ppd: FLIP_DEFAULT_PPD,
        }
    }
}

/// Mean LDR-FLIP over the valid pixels (0 = indistinguishable, 1 = maximal error).
pub fn flip(reference: &Image, test: &Image, settings: &FlipSettings) -> Result<f64, MetricError> {
    Ok(mean_of_map(&flip_map_pair(
        &Pair::new(reference, test)?,
        settings,
    )))
}

/// Per-pixel LDR-FLIP as a one-channel image; excluded (non-finite) pixels are NaN.
pub fn flip_map(
    reference: &Image,
    test: &Image,
    settings: &FlipSettings,
) -> Result<Image, MetricError> {
    Ok(flip_map_pair(&Pair::new(reference, test)?, settings))
}

/// Mean of the non-NaN values of a map (the excluded pixels are NaN).
pub(crate) fn mean_of_map(map: &Image) -> f64 {
    let (sum, n) = map
        .data
        .iter()
        .filter(|v| !v.is_nan())
        .fold((0.0f64, 0usize), |(s, n), &v| (s + v as f64, n + 1));
    sum / n as f64
}

pub(crate) fn flip_map_pair(pair: &Pair, settings: &FlipSettings) -> Image {
    let (w, h) = (pair.reference.width, pair.reference.height);
    let filters = Filters::new(settings.ppd);
    let [reference, test] = pair
        .sanitised_rgb()
        .map(|planes| planes.map(|p| p.iter().map(|&v| expose(v, settings.exposure)).collect()));
    let r = Prepared::new(&reference, w, h, &filters);
    let t = Prepared::new(&test, w, h, &filters);
    let cmax = max_colour_distance();

    let mut map = Image::new(w, h, 1, 0.0);
    for (i, out) in map.data.iter_mut().enumerate() {
        if !pair.valid[i] {
            *out = f32::NAN;
            continue;
        }
        let colour = (hyab(r.lab[i], t.lab[i])).powf(QC);
        // Redistribute so that small differences use most of the range and the top
        // (1 − PC)·cmax of distances share what is left.
        let colour = if colour < PC * cmax {
            colour * PT / (PC * cmax)
        } else {
            PT + (colour - PC * cmax) / (cmax - PC * cmax) * (1.0 - PT)
        };
        let edge = (r.edge[i] - t.edge[i]).abs();
        let point = (r.point[i] - t.point[i]).abs();
        let feature = (edge.max(point) / std::f32::consts::SQRT_2).powf(QF);
        *out = colour.powf(1.0 - feature);
    }
    map
}

/// One-dimensional taps of FLIP's filters at a given ppd.
struct Filters {
    /// Contrast-sensitivity filters: per opponent channel (achromatic, red-green,
    /// blue-yellow), a list of (weight, 1-D Gaussian) whose separable products are summed.
    csf: [Vec<(f32, Vec<f32>)>; 3],
    /// Gaussian normalised to sum 1.
    gauss: Vec<f32>,
    /// First derivative of the Gaussian, positive and negative lobes each summing to ±1.
    edge: Vec<f32>,
    /// Second derivative of the Gaussian, lobes normalised the same way.
    point: Vec<f32>,
}

impl Filters {
    fn new(ppd: f32) -> Self {
        // Each channel's CSF in the paper is a sum of Gaussians a·sqrt(π/b)·exp(−π²x²/b)
        // (x in degrees); (a, b) pairs for the achromatic, red-green and blue-yellow channel.
        let params: [&[(f32, f32)]; 3] = [
            &[(1.0, 0.0047)],
            &[(1.0, 0.0053)],
            &[(34.1, 0.04), (13.5, 0.025)],
        ];
        let widest = 0.04f32;
        // 3 standard deviations of the widest Gaussian, shared by all channels.
        let radius =
            (3.0 * (widest / (2.0 * std::f32::consts::PI.powi(2))).sqrt() * ppd).ceil() as i32;
        let pi2 = std::f32::consts::PI.powi(2);
        let csf = params.map(|terms| {
            let taps: Vec<(f32, Vec<f32>)> = terms
                .iter()
                .map(|&(a, b)| {
                    let g: Vec<f32> = (-radius..=radius)
                        .map(|x| {
                            let d = x as f32 / ppd;
                            (-pi2 * d * d / b).exp()
                        })
                        .collect();
                    (a * (std::f32::consts::PI / b).sqrt(), g)
                })
                .collect();
            // The 2-D kernel Σ wᵢ gᵢ⊗gᵢ must sum to 1: divide every weight by Σ wᵢ (Σgᵢ)².
            let total: f32 = taps
                .iter()
                .map(|(wt, g)| wt * g.iter().sum::<f32>().powi(2))
                .sum();
            taps.into_iter().map(|(wt, g)| (wt / total, g)).collect()
        });

        let sd = 0.5 * FEATURE_WIDTH * ppd;
        let r = (3.0 * sd).ceil() as i32;
        let xs: Vec<f32> = (-r..=r).map(|x| x as f32).collect();
        let g: Vec<f32> = xs
            .iter()
            .map(|x| (-x * x / (2.0 * sd * sd)).exp())
            .collect();
        let g_sum: f32 = g.iter().sum();
        let gauss = g.iter().map(|v| v / g_sum).collect();
        let edge = balance(xs.iter().zip(&g).map(|(x, g)| -x * g).collect());
        let point = balance(
            xs.iter()
                .zip(&g)
                .map(|(x, g)| (x * x / (sd * sd) - 1.0) * g)
                .collect(),
        );
        Self {
            csf,
            gauss,
            edge,
            point,
        }
    }
}

/// Scales the positive taps to sum to 1 and the negative ones to −1, so a feature detector
/// answers 0 on flat regions and its response is bounded by the contrast.
fn balance(mut taps: Vec<f32>) -> Vec<f32> {
    let pos: f32 = taps.iter().filter(|v| **v > 0.0).sum();
    let neg: f32 = -taps.iter().filter(|v| **v < 0.0).sum::<f32>();
    for v in &mut taps {
        if *v > 0.0 {
            *v /= pos;
        } else if *v < 0.0 {
            *v /= neg;
        }
    }
    taps
}

/// The per-pixel quantities FLIP compares, for one image.
struct Prepared {
    /// Filtered colour as Hunt-adjusted L*a*b*.
    lab: Vec<[f32; 3]>,
    /// Edge strength: magnitude of the (x, y) first-derivative responses of luminance.
    edge: Vec<f32>,
    /// Point strength: magnitude of the (x, y) second-derivative responses.
    point: Vec<f32>,
}

impl Prepared {
    /// `rgb`: linear RGB planes in [0, 1].
    fn new(rgb: &[Vec<f32>; 3], w: usize, h: usize, f: &Filters) -> Self {
        let n = w * h;
        // Opponent space YCxCz: linear in XYZ, so a linear filter can model the eye's
        // contrast sensitivity per channel.
        let white = white_xyz();
        let mut ycc: [Vec<f32>; 3] = Default::default();
        for c in &mut ycc {
            *c = vec![0.0; n];
        }
        let mut lum = vec![0.0f32; n];
        for i in 0..n {
            let xyz = mul(&RGB_TO_XYZ, [rgb[0][i], rgb[1][i], rgb[2][i]]);
            let (x, y, z) = (xyz[0] / white[0], xyz[1] / white[1], xyz[2] / white[2]);
            ycc[0][i] = 116.0 * y - 16.0;
            ycc[1][i] = 500.0 * (x - y);
            ycc[2][i] = 200.0 * (y - z);
            lum[i] = y;
        }
        let filtered: Vec<Vec<f32>> = ycc
            .iter()
            .zip(&f.csf)
            .map(|(plane, terms)| {
                let mut acc = vec![0.0f32; n];
                for (weight, g) in terms {
                    for (a, v) in acc.iter_mut().zip(filter_clamped(plane, w, h, g, g)) {
                        *a += weight * v;
                    }
                }
                acc
            })
            .collect();
        let lab = (0..n)
            .map(|i| {
                let y = (filtered[0][i] + 16.0) / 116.0;
                let x = filtered[1][i] / 500.0 + y;
                let z = y - filtered[2][i] / 200.0;
                let rgb = mul(&XYZ_TO_RGB, [x * white[0], y * white[1], z * white[2]])
                    .map(|v| v.clamp(0.0, 1.0));
                hunt(lab_of(rgb))
            })
            .collect();

        let magnitude = |d: &[f32]| -> Vec<f32> {
            let dx = filter_clamped(&lum, w, h, d, &f.gauss);
            let dy = filter_clamped(&lum, w, h, &f.gauss, d);
            dx.iter().zip(&dy).map(|(a, b)| a.hypot(*b)).collect()
        };
        Self {
            lab,
            edge: magnitude(&f.edge),
            point: magnitude(&f.point),
        }
    }
}

fn mul(m: &[[f32; 3]; 3], v: [f32; 3]) -> [f32; 3] {
    m.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
}

/// XYZ of RGB white, the reference white of YCxCz and L*a*b*.
fn white_xyz() -> [f32; 3] {
    mul(&RGB_TO_XYZ, [1.0; 3])
}

/// CIE L*a*b* of a linear RGB colour.
fn lab_of(rgb: [f32; 3]) -> [f32; 3] {
    let white = white_xyz();
    let xyz = mul(&RGB_TO_XYZ, rgb);
    let delta = 6.0f32 / 29.0;
    let f = |t: f32| {
        if t > delta.powi(3) {
            t.cbrt()
        } else {
            t / (3.0 * delta * delta) + 4.0 / 29.0
        }
    };
    let (fx, fy, fz) = (
        f(xyz[0] / white[0]),
        f(xyz[1] / white[1]),
        f(xyz[2] / white[2]),
    );
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// Hunt effect: chroma is perceived weaker at low lightness, so a*, b* are scaled by L*/100.
fn hunt(lab: [f32; 3]) -> [f32; 3] {
    [lab[0], 0.01 * lab[0] * lab[1], 0.01 * lab[0] * lab[2]]
}

/// HyAB distance: city-block in lightness, Euclidean in chroma (better for large differences
/// than ΔE).
fn hyab(a: [f32; 3], b: [f32; 3]) -> f32 {
    (a[0] - b[0]).abs() + (a[1] - b[1]).hypot(a[2] - b[2])
}

/// The largest colour distance FLIP expects: between pure green and pure blue, compressed.
fn max_colour_distance() -> f32 {
    hyab(hunt(lab_of([0.0, 1.0, 0.0])), hunt(lab_of([0.0, 0.0, 1.0]))).powf(QC)
}
