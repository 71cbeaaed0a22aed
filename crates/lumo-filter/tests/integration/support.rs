//! Test inputs shared by the topics: random images, a G-buffer with one geometry edge,
//! error measures.

use lumo_filter::*;
use lumo_image::Image;

/// Deterministic pseudo-random values in [0, 1).
pub fn rng(seed: u64) -> impl FnMut() -> f32 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 40) as f32) / (1u64 << 24) as f32
    }
}

pub fn noise_image(w: usize, h: usize, c: usize, seed: u64) -> Image {
    let mut r = rng(seed);
    Image::from_vec(w, h, c, (0..w * h * c).map(|_| r()).collect())
}

/// A G-buffer with a vertical geometry edge at x = w/2: left faces +z at depth 2, right faces
/// +x at depth 5; positions consistent with that.
pub struct Split {
    pub normal: Image,
    pub depth: Image,
    pub position: Image,
    pub albedo: Image,
}

pub fn split(w: usize, h: usize) -> Split {
    let mut normal = Image::new(w, h, 3, 0.0);
    let mut depth = Image::new(w, h, 1, 0.0);
    let mut position = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            let left = x < w / 2;
            normal.pixel_mut(x, y).copy_from_slice(if left {
                &[0.0, 0.0, 1.0]
            } else {
                &[1.0, 0.0, 0.0]
            });
            let d = if left { 2.0 } else { 5.0 };
            depth.pixel_mut(x, y)[0] = d;
            position
                .pixel_mut(x, y)
                .copy_from_slice(&[x as f32 * 0.01, y as f32 * 0.01, -d]);
        }
    }
    Split {
        normal,
        depth,
        position,
        albedo: Image::new(w, h, 3, 0.5),
    }
}

pub fn features(s: &Split) -> Features<'_> {
    Features {
        normal: Some(&s.normal),
        position: Some(&s.position),
        depth: Some(&s.depth),
        albedo: Some(&s.albedo),
        variance: None,
    }
}

pub fn max_abs_diff(a: &Image, b: &Image) -> f32 {
    assert_eq!(
        (a.width, a.height, a.channels),
        (b.width, b.height, b.channels)
    );
    a.data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

pub fn all_guides(s: &Split) -> Vec<Guide> {
    let f = features(s);
    [GuideKind::Grey, GuideKind::Normal, GuideKind::NormalDepth]
        .into_iter()
        .map(|k| build_guide(k, &f, DepthNorm::Range, 0.01, 0.01).unwrap())
        .collect()
}

/// Piecewise-constant colour that follows the geometry edge.
pub fn edge_color(w: usize, h: usize) -> Image {
    let mut c = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            let v = if x < w / 2 {
                [0.2, 0.3, 0.1]
            } else {
                [1.0, 0.8, 0.9]
            };
            c.pixel_mut(x, y).copy_from_slice(&v);
        }
    }
    c
}

pub fn mse(a: &Image, b: &Image) -> f64 {
    a.data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| ((x - y) as f64).powi(2))
        .sum::<f64>()
        / a.data.len() as f64
}
