//! Narrow, tall images are filtered transposed. The working layout (layout.rs) gives every
//! (strip, row) pair a block of [`QW`] floats per plane whatever the strip's width, so a 1×N
//! image would hold 672 floats per pixel and plane (3.2 GB for 1×65,536, against 13 MB for
//! 256²); its transpose, N×1, holds about 1.3. The filter is the same either way: the kernel
//! is a separable, symmetric B-spline and every edge weight is a function of two pixels'
//! values, not of the direction between them (a test compares the two).

use super::layout::{CW, QW};

/// Floats per plane that the working layout holds for a `w`×`h` image.
fn layout_floats(w: usize, h: usize) -> usize {
    w.div_ceil(CW).max(1) * QW * h
}

/// Whether a `w`×`h` image costs more than twice as much memory as its transpose; square and
/// wide images (every frame of a renderer) never qualify and keep their exact bits.
pub(super) fn pays(w: usize, h: usize) -> bool {
    layout_floats(w, h) > 2 * layout_floats(h, w)
}
