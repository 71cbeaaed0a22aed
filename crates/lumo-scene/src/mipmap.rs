//! Mip-maps: a bitmap and its successively halved box averages, for lookups whose footprint
//! covers many texels (glTF's `*_MIPMAP_*` minification filters).

use std::sync::Arc;

use lumo_image::Image;

/// How a lookup whose footprint falls between two levels combines them (the second half of
/// glTF's minification filter names).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MipFilter {
    /// The nearest level (`*_MIPMAP_NEAREST`).
    Nearest,
    /// Both levels, weighted by where the footprint lies between them (`*_MIPMAP_LINEAR`,
    /// "trilinear" with bilinear lookups in each level).
    Linear,
}

/// A bitmap and its reductions: level 0 is the image itself, level k + 1 has half the texels
/// of level k on each axis (rounded down, at least one) down to a single texel.
#[derive(Clone, Debug)]
pub struct MipMap {
    levels: Vec<Arc<Image>>,
}

impl MipMap {
    /// The chain of `image` (its colour channels; level 0 shares the image). Each texel of a
    /// reduced level is the exact area average of the texels of the level above that it
    /// covers, so every level keeps the image's mean, odd sizes included.
    pub fn new(image: Arc<Image>) -> Self {
        let mut levels = vec![image];
        loop {
            let last = &levels[levels.len() - 1];
            if last.width <= 1 && last.height <= 1 {
                break;
            }
            let next = reduce(last, (last.width / 2).max(1), (last.height / 2).max(1));
            levels.push(Arc::new(next));
        }
        Self { levels }
    }

    /// The levels, finest first.
    pub fn levels(&self) -> &[Arc<Image>] {
        &self.levels
    }

    /// The (fractional) level whose texels are as wide as `footprint` (in uv units, where the
    /// image spans 1): log₂ of the footprint in level-0 texels (the geometric mean of the two
    /// axes' counts), clamped to the chain. Zero or a non-finite footprint gives level 0.
    pub fn level_for(&self, footprint: f32) -> f32 {
        let base = &self.levels[0];
        let texels = footprint * ((base.width * base.height) as f32).sqrt();
        if texels.is_finite() && texels > 1.0 {
            texels.log2().min((self.levels.len() - 1) as f32)
        } else {
            0.0
        }
    }
}

/// `image` area-averaged onto `w`×`h` texels (colour channels only).
fn reduce(image: &Image, w: usize, h: usize) -> Image {
    let cols = coverage(image.width, w);
    let rows = coverage(image.height, h);
    let mut out = Image::new(w, h, 3, 0.0);
    for (y, row_weights) in rows.iter().enumerate() {
        for (x, col_weights) in cols.iter().enumerate() {
            let mut sum = [0.0f64; 3];
            for &(sy, wy) in row_weights {
                for &(sx, wx) in col_weights {
                    let c = image.rgb(sx, sy);
                    let wgt = wy * wx;
                    for k in 0..3 {
                        sum[k] += wgt * c[k] as f64;
                    }
                }
            }
            out.pixel_mut(x, y).copy_from_slice(&sum.map(|s| s as f32));
        }
    }
    out
}

/// For each of `m` output texels spanning the same extent as `n` input texels, the input
/// texels it overlaps and the fraction of the output texel each covers (summing to 1).
fn coverage(n: usize, m: usize) -> Vec<Vec<(usize, f64)>> {
    let scale = n as f64 / m as f64;
    (0..m)
        .map(|i| {
            let (lo, hi) = (i as f64 * scale, (i + 1) as f64 * scale);
            let first = lo.floor() as usize;
            let last = (hi.ceil() as usize).min(n);
            (first..last)
                .filter_map(|j| {
                    let overlap = hi.min(j as f64 + 1.0) - lo.max(j as f64);
                    (overlap > 0.0).then_some((j, overlap / scale))
                })
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: usize, h: usize, f: impl Fn(usize, usize) -> f32) -> Arc<Image> {
        let data = (0..h)
            .flat_map(|y| (0..w).flat_map(move |x| [x, y]).collect::<Vec<_>>())
            .collect::<Vec<_>>();
        let data = data
            .chunks_exact(2)
            .flat_map(|p| {
                let v = f(p[0], p[1]);
                [v, 2.0 * v, 3.0 * v]
            })
            .collect();
        Arc::new(Image::from_vec(w, h, 3, data))
    }

    #[test]
    fn every_level_keeps_the_mean_and_halves_the_size() {
        // Odd and even sizes, non-square, with an irregular pattern.
        for (w, h) in [(8, 8), (7, 5), (13, 2), (1, 9), (6, 1)] {
            let img = image(w, h, |x, y| ((x * 7 + y * 3) % 5) as f32 + 0.25 * y as f32);
            let mean = img.channel_means();
            let mip = MipMap::new(img);
            let levels = mip.levels();
            assert_eq!(levels.last().map(|l| (l.width, l.height)), Some((1, 1)));
            for pair in levels.windows(2) {
                assert_eq!(pair[1].width, (pair[0].width / 2).max(1));
                assert_eq!(pair[1].height, (pair[0].height / 2).max(1));
            }
            for level in levels {
                let m = level.channel_means();
                for k in 0..3 {
                    assert!(
                        (m[k] - mean[k]).abs() < 1e-5 * (1.0 + mean[k].abs()),
                        "{w}x{h}: level {}x{} mean {} against {}",
                        level.width,
                        level.height,
                        m[k],
                        mean[k]
                    );
                }
            }
        }
    }

    #[test]
    fn a_checker_reduces_to_its_grey_and_a_constant_stays_constant() {
        let checker = MipMap::new(image(4, 4, |x, y| ((x + y) % 2) as f32));
        let level1 = &checker.levels()[1];
        for y in 0..2 {
            for x in 0..2 {
                assert_eq!(level1.rgb(x, y), [0.5, 1.0, 1.5]);
            }
        }
        let constant = MipMap::new(image(5, 3, |_, _| 0.7));
        for level in constant.levels() {
            for px in level.data.chunks_exact(3) {
                assert!((px[0] - 0.7).abs() < 1e-6 && (px[2] - 2.1).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn the_level_grows_with_the_footprint_in_texels() {
        let mip = MipMap::new(image(64, 16, |_, _| 1.0));
        // √(64·16) = 32 texels per unit of uv.
        assert_eq!(mip.level_for(0.0), 0.0);
        assert_eq!(mip.level_for(1.0 / 64.0), 0.0);
        assert!((mip.level_for(4.0 / 32.0) - 2.0).abs() < 1e-6);
        assert_eq!(mip.level_for(100.0), (mip.levels().len() - 1) as f32);
        assert_eq!(mip.level_for(f32::NAN), 0.0);
    }
}
