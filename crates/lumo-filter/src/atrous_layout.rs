//! The À-Trous working layout: the image cut into vertical strips of [`CW`] columns; every
//! (strip, row) pair owns one *block* holding each plane as a sub-row of [`QW`] floats — the
//! strip's columns plus [`M`] margin columns copied from the neighbouring strips (zero beyond
//! the image).
//!
//! Why: the kernel reads ~25 planes per tap. With a compile-time stride between them every
//! plane is one constant displacement from a single pointer (a runtime stride needs a register
//! per plane, and there are not enough), and the margins let a tap up to M columns away be read
//! without clipping: outside the image the validity plane is 0, so such a tap adds nothing.

/// Columns per strip.
pub(crate) const CW: usize = 512;
/// Margin columns on each side of a strip: the fused path reads taps up to 2·32 columns
/// away, the pair path sweeps 2·16 columns into a neighbour and reads 2·16 beyond.
pub(crate) const M: usize = 64;
/// Floats per sub-row: margin, strip, margin.
pub(crate) const QW: usize = CW + 2 * M;

/// Block geometry of one image.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Layout {
    pub w: usize,
    pub h: usize,
    /// Number of strips.
    pub nch: usize,
}

impl Layout {
    /// The layout of a `w`×`h` image.
    pub fn new(w: usize, h: usize) -> Layout {
        Layout {
            w,
            h,
            nch: w.div_ceil(CW),
        }
    }

    /// Floats in a buffer of `planes` planes.
    pub fn size(&self, planes: usize) -> usize {
        self.nch * self.h * planes * QW
    }

    /// (strip, row) of block number `b` (blocks are strip-major).
    pub fn strip_row(&self, b: usize) -> (usize, usize) {
        (b / self.h, b % self.h)
    }

    /// Start of block (strip `c`, row `y`) in a buffer of `planes` planes.
    pub fn block(&self, c: usize, y: usize, planes: usize) -> usize {
        (c * self.h + y) * planes * QW
    }

    /// Image columns of strip `c` (its first column and how many).
    pub fn strip(&self, c: usize) -> (usize, usize) {
        let x0 = c * CW;
        (x0, (self.w - x0).min(CW))
    }

    /// Copies every block's margins from its neighbours' strip columns. Margins beyond the
    /// image are never written and stay 0, as do a last strip's columns beyond the image.
    pub fn fill_margins(&self, buf: &mut [f32], planes: usize) {
        for c in 0..self.nch {
            for y in 0..self.h {
                for k in 0..planes {
                    let at = |cc: usize| self.block(cc, y, planes) + k * QW;
                    if c > 0 {
                        // Left margin: the last M columns of the previous strip.
                        buf.copy_within(at(c - 1) + CW..at(c - 1) + CW + M, at(c));
                    }
                    if c + 1 < self.nch {
                        // Right margin: the first M columns of the next strip.
                        buf.copy_within(at(c + 1) + M..at(c + 1) + 2 * M, at(c) + M + CW);
                    }
                }
            }
        }
    }
}
