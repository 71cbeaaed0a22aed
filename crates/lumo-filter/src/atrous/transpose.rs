//! Narrow, tall images are filtered transposed. The working layout (layout.rs) gives every
//! (strip, row) pair a block of [`QW`] floats per plane whatever the strip's width, so a 1×N
//! image would hold 672 floats per pixel and plane (3.2 GB for 1×65,536, against 13 MB for
//! 256²); its transpose, N×1, holds about 1.3. The filter is the same either way: the kernel
//! is a separable, symmetric B-spline and every edge weight is a function of two pixels'
//! values, not of the direction between them (a test compares the two).

use lumo_image::Image;

use super::layout::{CW, QW};
use crate::common::gbuffer::{Features, Filtered};

/// Floats per plane that the working layout holds for a `w`×`h` image.
fn layout_floats(w: usize, h: usize) -> usize {
    w.div_ceil(CW).max(1) * QW * h
}

/// Whether a `w`×`h` image costs more than twice as much memory as its transpose; square and
/// wide images (every frame of a renderer) never qualify and keep their exact bits.
pub(super) fn pays(w: usize, h: usize) -> bool {
    layout_floats(w, h) > 2 * layout_floats(h, w)
}

/// `img` with rows and columns swapped.
pub(super) fn transposed(img: &Image) -> Image {
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
pub(super) struct TransposedInput {
    pub color: Image,
    normal: Option<Image>,
    position: Option<Image>,
    depth: Option<Image>,
    albedo: Option<Image>,
    variance: Option<Image>,
}

impl TransposedInput {
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
pub(super) fn back(f: Filtered) -> Filtered {
    Filtered {
        image: transposed(&f.image),
        missing: f.missing,
    }
}
