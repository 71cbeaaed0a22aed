//! The À-Trous working layout: the image cut into vertical strips of [`CW`] columns; every
//! (strip, row) pair owns one *block* holding each plane as a sub-row of [`QW`] floats — the
//! strip's columns plus [`M`] margin columns copied from the neighbouring strips (zero beyond
//! the image).
//!
//! Why: the kernel reads ~25 planes per tap. With a compile-time stride between them every
//! plane is one constant displacement from a single pointer (a runtime stride needs a register
//! per plane, and there are not enough), and the margins let a tap up to M columns away be read
//! without clipping: outside the image the validity plane is 0, so such a tap adds nothing.

use rayon::prelude::*;

/// Columns per strip.
pub(super) const CW: usize = 512;
/// Margin columns on each side of a strip: the fused path reads taps up to 2·32 columns
/// away, the pair path sweeps 2·16 columns into a neighbour and reads 2·16 beyond, and the
/// level pipeline (pipeline.rs) reads up to 64 columns beyond the strip at every level,
/// from sweeps rounded out to whole 16-column vectors (80 = 64 + 16).
pub(super) const M: usize = 80;
/// Floats per sub-row: margin, strip, margin.
pub(super) const QW: usize = CW + 2 * M;

/// Block geometry of one image.
#[derive(Clone, Copy, Debug)]
pub(super) struct Layout {
    pub w: usize,
    pub h: usize,
    /// Number of strips.
    pub nch: usize,
    /// Columns per strip (the last may have fewer): the fewest strips of at most [`CW`]
    /// columns, of equal width rounded up to 16. Equal strips keep the threads equally busy
    /// (1920 columns: 4 × 480 rather than 3 × 512 + 384, where two threads got 1024 and 896
    /// columns).
    pub sw: usize,
}

impl Layout {
    /// The layout of a `w`×`h` image.
    pub fn new(w: usize, h: usize) -> Layout {
        let nch = w.div_ceil(CW).max(1);
        Layout {
            w,
            h,
            nch,
            sw: w.div_ceil(nch).next_multiple_of(16).min(CW),
        }
    }

    /// Floats of each sub-row in use: the strip's columns and both margins. Columns beyond
    /// (there are some where strips are narrower than [`CW`]) are never read or written, so
    /// nothing converts or zeroes them.
    pub fn span(&self) -> usize {
        self.sw + 2 * M
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
        let x0 = c * self.sw;
        (x0, (self.w - x0).min(self.sw))
    }

    /// Copies every block's margins from its neighbours' strip columns, rows in parallel.
    /// Margins beyond the image are never written, nor are a last strip's columns beyond the
    /// image (the kernels write 0 there). With strips narrower than [`CW`], a block's columns
    /// beyond its right margin are never read.
    /// `planes`: planes per block; the first `copy` of them are copied.
    pub fn fill_margins(&self, buf: &mut [f32], planes: usize, copy: usize) {
        if self.nch < 2 {
            return;
        }
        assert!(
            buf.len() >= self.size(planes),
            "buffer too small for the layout"
        );
        let base = SharedBuf(buf.as_mut_ptr());
        let lay = *self;
        assert!(
            M <= lay.sw && lay.sw + 2 * M <= QW,
            "strip width out of range"
        );
        (0..self.h).into_par_iter().for_each(|y| {
            let base = &base;
            for c in 0..lay.nch - 1 {
                for k in 0..copy.min(planes) {
                    let at = |cc: usize| lay.block(cc, y, planes) + k * QW;
                    // SAFETY: both sub-rows are inside `buf` (checked size above) and belong
                    // to different blocks of row y; only row y's task touches row y's blocks,
                    // so the two slices are the only references to these floats.
                    let (left, right) = unsafe {
                        (
                            std::slice::from_raw_parts_mut(base.0.add(at(c)), QW),
                            std::slice::from_raw_parts_mut(base.0.add(at(c + 1)), QW),
                        )
                    };
                    exchange_margins(left, right, lay.sw);
                }
            }
        });
    }
}

/// Copies the margins between one plane's sub-rows of two side-by-side blocks, `left`'s strip
/// being a full `sw` columns wide: `left`'s right margin from `right`'s first M strip columns,
/// `right`'s left margin from `left`'s last M. Only strip columns are read, only margins
/// written.
pub(super) fn exchange_margins(left: &mut [f32], right: &mut [f32], sw: usize) {
    left[M + sw..2 * M + sw].copy_from_slice(&right[M..2 * M]);
    right[..M].copy_from_slice(&left[sw..sw + M]);
}

/// Floats per cache line.
pub(super) const LINE_FLOATS: usize = 16;

/// A value aligned to a cache line. Block rows stored in one start every plane's sub-row on
/// a 64-byte boundary (`QW` floats are a whole number of lines), so the kernels' 16-float
/// loads at multiples of 16 columns do not straddle two lines, as they did in rows that
/// `malloc` placed 16 bytes past a page boundary.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
pub(super) struct Aligned<T>(pub T);

const _: () = assert!(QW.is_multiple_of(LINE_FLOATS) && 4 * LINE_FLOATS == 64);

/// Rows of [`QW`] floats, each on a cache line boundary, as one flat slice of floats.
pub(super) fn flat_rows(rows: &mut [Aligned<[f32; QW]>]) -> &mut [f32] {
    const { assert!(std::mem::size_of::<Aligned<[f32; QW]>>() == QW * 4) };
    // SAFETY: `Aligned<[f32; QW]>` is `repr(C)` with no padding (size checked above), so the
    // rows are `rows.len() · QW` contiguous, initialised floats, borrowed mutably here.
    unsafe { std::slice::from_raw_parts_mut(rows.as_mut_ptr().cast::<f32>(), rows.len() * QW) }
}

/// A float buffer shared between parallel tasks that each write their own disjoint floats
/// (`fill_margins`' row tasks; the level pipeline's output rows).
pub(super) struct SharedBuf(pub(super) *mut f32);
// SAFETY: every user hands out disjoint floats to its tasks (see `fill_margins` and
// `AtrousFilter::levels`).
unsafe impl Sync for SharedBuf {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_tile_the_image_in_equal_widths() {
        for w in [
            1, 15, 80, 255, 511, 512, 513, 600, 1023, 1024, 1025, 1920, 3840, 4097,
        ] {
            let lay = Layout::new(w, 3);
            assert_eq!(lay.nch, w.div_ceil(CW), "width {w}");
            let mut next = 0;
            for c in 0..lay.nch {
                let (x0, len) = lay.strip(c);
                assert_eq!(x0, next, "width {w}, strip {c}");
                assert!(
                    len > 0 && len <= lay.sw && lay.sw <= CW,
                    "width {w}, strip {c}"
                );
                if c + 1 < lay.nch {
                    // Interior strips are full and wide enough to fill a neighbour's margin.
                    assert!(len == lay.sw && lay.sw >= M, "width {w}, strip {c}");
                }
                next += len;
            }
            assert_eq!(next, w, "width {w}");
        }
        assert_eq!(Layout::new(1920, 1).sw, 480);
    }
}
