//! Filtering an image transposed: rows and columns of the colour and every feature plane
//! swapped, the result swapped back. Every filter here is symmetric in x and y (square
//! windows or a separable symmetric kernel, weights from pixel values only), so this changes
//! nothing but the summation order; the filters use it on degenerate shapes where their
//! working memory is laid out per row (À-Trous on narrow images, the guided filter and
//! `auto` on images a few rows tall).

use lumo_image::Image;

use crate::common::gbuffer::{Features, Filtered};

/// Images fewer rows tall than this (and wider than tall) are filtered transposed by the
/// guided filter and `auto`: their per-row sums are as wide as the image, about 740 bytes per
/// pixel of a one-row image (49 MB at 65,536×1, against 4.8 MB for 256²), which at 16 rows
/// is less than the ~1,200 bytes per pixel the rest of the filter needs.
pub(crate) const FEW_ROWS: usize = 16;

/// Whether the guided filter and `auto` filter a `w`×`h` image transposed.
pub(crate) fn few_rows(w: usize, h: usize) -> bool {
    h < FEW_ROWS && w > h
}

/// `img` with rows and columns swapped.
pub(crate) fn transposed(img: &Image) -> Image {
    let (w, h, c) = (img.width, img.height, img.channels);
    let mut out = Image::new(h, w, c, 0.0);
    for y in 0..h {
        for x in 0..w {
            let s = (y * w + x) * c;
            let d = (x * h + y) * c;
            out.data[d..d + c].copy_from_slice(&img.data[s..s + c]);
        }
    }
    out
}

/// The colour and feature planes of one call, transposed.
pub(crate) struct TransposedInput {
    pub color: Image,
    normal: Option<Image>,
    position: Option<Image>,
    depth: Option<Image>,
    albedo: Option<Image>,
    variance: Option<Image>,
}

impl TransposedInput {
    /// Transposes `color` and every feature plane present; `None` where a plane's size is not
    /// the colour's (the filter's own check then names it, in the caller's terms).
    pub fn of(color: &Image, f: &Features) -> Option<Self> {
        let planes = [f.normal, f.position, f.depth, f.albedo, f.variance];
        let fits = |p: &Option<&Image>| {
            p.is_none_or(|p| (p.width, p.height) == (color.width, color.height))
        };
        planes.iter().all(fits).then(|| Self::new(color, f))
    }

    /// Transposes `color` and every feature plane present.
    pub fn new(color: &Image, f: &Features) -> Self {
        let t = |p: Option<&Image>| p.map(transposed);
        TransposedInput {
            color: transposed(color),
            normal: t(f.normal),
            position: t(f.position),
            depth: t(f.depth),
            albedo: t(f.albedo),
            variance: t(f.variance),
        }
    }

    /// The transposed planes as filter features.
    pub fn features(&self) -> Features<'_> {
        Features {
            normal: self.normal.as_ref(),
            position: self.position.as_ref(),
            depth: self.depth.as_ref(),
            albedo: self.albedo.as_ref(),
            variance: self.variance.as_ref(),
        }
    }
}

/// A result of the transposed image, turned back.
pub(crate) fn back(f: Filtered) -> Filtered {
    Filtered {
        image: transposed(&f.image),
        missing: f.missing,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::synthetic::synthetic_frame;
    use crate::guided::{build_guide, guided, DepthNorm, GuideKind, GuidedParams, SharedInput};

    /// An image a few rows tall goes through the guided filter transposed; the result must be
    /// the direct filter's (the filter is symmetric in x and y).
    #[test]
    fn guided_filter_of_a_few_rows_is_the_direct_one() {
        let f = synthetic_frame(300, 12, 2, 5);
        assert!(few_rows(300, 12) && !few_rows(12, 300));
        let features = Features {
            normal: Some(&f.normal),
            depth: Some(&f.depth),
            ..Features::default()
        };
        let g = build_guide(
            GuideKind::NormalDepth,
            &features,
            DepthNorm::Range,
            0.003,
            0.003,
        )
        .unwrap();
        for radius in [2, 8, 24] {
            let p = GuidedParams {
                radius,
                ..GuidedParams::default()
            };
            let turned = guided(&f.noisy, &g, &p).unwrap();
            let direct = SharedInput::new(&f.noisy, &g)
                .unwrap()
                .filter(&g.eps, &p)
                .unwrap();
            assert_eq!(turned.missing, direct.missing);
            let scale = direct.image.data.iter().fold(0f32, |m, v| m.max(v.abs()));
            for (i, (a, b)) in turned.image.data.iter().zip(&direct.image.data).enumerate() {
                assert!(
                    (a - b).abs() <= 1e-4 * scale,
                    "r {radius} value {i}: {a} vs {b}"
                );
            }
        }
    }

    #[test]
    fn transposing_twice_gives_the_image_back() {
        let f = synthetic_frame(7, 3, 1, 1);
        let t = transposed(&f.noisy);
        assert_eq!((t.width, t.height, t.channels), (3, 7, 3));
        assert_eq!(
            t.data[3 * (2 * 3 + 1)..][..3],
            f.noisy.data[3 * (7 + 2)..][..3]
        );
        assert_eq!(transposed(&t), f.noisy);
    }
}
