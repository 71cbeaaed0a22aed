//! The À-Trous levels run as one pipeline per group of strips and band of rows, when every level takes
//! the symmetric-pair path (pairs/): level k sweeps its rows 2·step_k behind level
//! k − 1, reading level k − 1's output from a ring of 2·step_k + 1 rows instead of a
//! full-image buffer.
//!
//! Why: level by level, every level streams the whole working set (≈ 14 planes of the
//! padded image) from memory and writes a full image back, which at 1080p (≈ 200 MB) is the
//! limit, not the arithmetic. Here a task's intermediate rows stay in the core's cache, and
//! so do its input rows: the task converts the input images row by row (`Fill`) into a ring
//! of 3 colour rows (all level 0 reads) and one of feature rows (read by every level, so it
//! spans the levels' lag, Σ 2·step + 2 rows). Only the last level's output goes to a
//! full-image buffer.
//!
//! A task runs its group's strips row by row together: after each level row, every strip's
//! margins are copied from its neighbours' rows (as `Layout::fill_margins` does level by
//! level). The price: a task cannot see other tasks' intermediate levels, so at its edges it
//! computes their halo itself — each level produces the rows and columns the later levels
//! read (2·step per later level beyond the task's own), clipped to the image. Every pixel of
//! every level is computed with the same operations in the same order as by the
//! level-by-level pair path (`Path::Pairs`), whichever task computes it, so results are
//! identical to it, bit for bit, for any band split, grouping or thread count (tested).

use std::cell::RefCell;

use rayon::prelude::*;

use super::kernel::{normalise, AuxBlock, Level, SrcBlock, CM_VARIANCE, K, KA};
use super::layout::{exchange_margins, flat_rows, Aligned, Layout, M, QW};
use super::pairs::{self, Acc, Accs, RowJob, Rows, AN, CHUNK, PAIRS, ZERO_AUX, ZERO_SRC};

/// Most levels a pipeline runs (steps 1..16: the pair path's limit).
pub(super) const MAX_LEVELS: usize = 5;

/// Converts the inputs of block (strip, row) into a source block (K planes) and an aux
/// block (KA planes).
pub(super) type Fill<'a> = dyn Fn(usize, usize, &mut [f32], &mut [f32]) + Sync + 'a;

/// Takes the finished block (strip, row) of the last level.
pub(super) type Emit<'a> = dyn Fn(usize, usize, &[f32]) + Sync + 'a;

/// What differs between the levels of a pipeline.
#[derive(Clone, Copy, Debug)]
pub(super) struct Stage {
    pub step: usize,
    pub cm: u8,
    pub color_scale: f32,
    pub normal_factor: f32,
}

/// Whether `stages` can run as a pipeline on layout `lay`: every level a pair level (without
/// the variance-guided colour weight, whose per-level σ planes the pipeline does not make), and
/// every strip's halo columns (rounded out to whole vectors) inside its block.
pub(super) fn supports(stages: &[Stage], nf: usize, lay: Layout) -> bool {
    !stages.is_empty()
        && stages.len() <= MAX_LEVELS
        && stages
            .iter()
            .all(|s| s.cm != CM_VARIANCE && pairs::supports(s.step, nf))
        && (0..lay.nch).all(|c| columns(lay, c, c..c + 1, stages).is_some())
}

/// Whether `Path::Auto` should run `stages` as a pipeline (where [`supports`] it): where one
/// band per group of strips keeps every thread busy, or where the bands that do are at least
/// as tall as the halo each recomputes ([`halo_rows`]). Level by level, each level streams the
/// whole padded image through memory; on a CPU with 512 KiB of L2 per core (AMD Zen 3) that
/// cost more than the halo (512², two threads, two bands: 37 → 28 ms), while shorter bands
/// (512×64: 32-row bands for a 62-row halo) were faster level by level
/// (docs/filter-benchmarks.md).
pub(super) fn pays_off(lay: Layout, stages: &[Stage]) -> bool {
    let (band_rows, groups) = auto_split(lay);
    groups >= rayon::current_num_threads().max(1) || band_rows >= halo_rows(stages)
}

/// Rows per task and groups of strips where the caller does not choose: a group per thread
/// (at most one per strip), and enough bands per group for every thread.
fn auto_split(lay: Layout) -> (usize, usize) {
    let threads = rayon::current_num_threads().max(1);
    let groups = threads.min(lay.nch).max(1);
    let bands = threads.div_ceil(groups);
    (lay.h.div_ceil(bands).max(1), groups)
}

/// The rows above its first kept row that a task's first level sweeps: Σ 2·step over the
/// levels (each level lags the one before by its 2·step).
fn halo_rows(stages: &[Stage]) -> usize {
    stages.iter().map(|s| 2 * s.step).sum()
}

/// The columns (block coordinates) one level of one strip keeps and sweeps.
#[derive(Clone, Copy, Debug, Default)]
struct Cols {
    /// Output columns: what later levels read (or the strip itself, for the last level),
    /// clipped to the image.
    o_lo: usize,
    o_hi: usize,
    /// Swept columns: 2·step beyond the output (their pairs reach into it), rounded out to
    /// whole [`CHUNK`]s.
    j_lo: usize,
    j_hi: usize,
}

/// Each level's columns for strip `c` of the group of strips `group`, or `None` if some sweep
/// would read outside the block's span (more levels or wider steps than the margins hold).
/// Only at the group's edges does a level keep a halo for the later levels; inside the group
/// each strip keeps its own columns and its margins are copied from its neighbours' rows.
fn columns(
    lay: Layout,
    c: usize,
    group: std::ops::Range<usize>,
    stages: &[Stage],
) -> Option<[Cols; MAX_LEVELS]> {
    let (x0, len) = lay.strip(c);
    // The image's columns in block coordinates (may start before the block).
    let img_lo = M as isize - x0 as isize;
    let img_hi = img_lo + lay.w as isize;
    let mut cols = [Cols::default(); MAX_LEVELS];
    let (mut lo, mut hi) = (M as isize, (M + len) as isize);
    for k in (0..stages.len()).rev() {
        if k + 1 < stages.len() {
            let s = 2 * stages[k + 1].step as isize;
            if c == group.start {
                lo = (lo - s).max(img_lo);
            }
            if c + 1 == group.end {
                hi = (hi + s).min(img_hi);
            }
        }
        let s = 2 * stages[k].step as isize;
        let ch = CHUNK as isize;
        let j_lo = (lo - s).div_euclid(ch) * ch;
        let j_hi = (hi + s + ch - 1).div_euclid(ch) * ch;
        // The kernel reads 2·step either side of the sweep; the scatter writes the output
        // columns rounded up to a whole vector and reads 2·step beyond.
        let span = lay.span() as isize;
        if j_lo < s || j_hi + s > span || hi + ch + s > span {
            return None;
        }
        cols[k] = Cols {
            o_lo: lo as usize,
            o_hi: hi as usize,
            j_lo: j_lo as usize,
            j_hi: j_hi as usize,
        };
    }
    Some(cols)
}

thread_local! {
    /// Each worker's rings, kept between tasks and calls (allocating and page-faulting them
    /// per task would cost more than their rows' arithmetic).
    static SCRATCH: RefCell<Scratch> = const {
        RefCell::new(Scratch {
            strips: Vec::new(),
            weights: Vec::new(),
        })
    };
}

/// A worker's buffers.
struct Scratch {
    /// Per strip of the task's group, its rings.
    strips: Vec<Rings>,
    /// One row of the 12 pair weights (see pairs/).
    weights: Vec<Aligned<[f32; QW]>>,
}

/// The rings of one strip.
#[derive(Default)]
struct Rings {
    /// Per level, its accumulator ring (2·step + 1 rows; never cleared, see
    /// `RowJob::first_writer`).
    acc: Vec<Vec<Aligned<Acc>>>,
    /// Per level, the ring of input rows it reads (2·step + 1 rows): for the first, the
    /// input colour; for the others, the previous level's output. One more: the last level's
    /// output row, handed to `emit`.
    rows: Vec<Vec<Aligned<SrcBlock>>>,
    /// The ring of feature rows (all levels read them).
    feat: Vec<Aligned<AuxBlock>>,
}

impl Rings {
    /// Grows the rings to `fr` feature rows and, per level, 2·step + 1 rows.
    fn grow(&mut self, stages: &[Stage], fr: usize) {
        let n = stages.len();
        if self.feat.len() < fr {
            self.feat.resize(fr, Aligned([0.0; KA * QW]));
        }
        self.acc.resize_with(self.acc.len().max(n), Vec::new);
        self.rows.resize_with(self.rows.len().max(n + 1), Vec::new);
        if self.rows[n].is_empty() {
            self.rows[n].push(Aligned([0.0; K * QW]));
        }
        for (k, st) in stages.iter().enumerate() {
            let rn = 2 * st.step + 1;
            // Never cleared: each kept row's first writer stores (`RowJob::first_writer`).
            if self.acc[k].len() < rn {
                self.acc[k].resize(rn, Aligned([0.0; AN * QW]));
            }
            if self.rows[k].len() < rn {
                self.rows[k].resize(rn, Aligned([0.0; K * QW]));
            }
        }
    }
}

/// Every level over the whole image; each row of the last level's result (a source block:
/// colour and validity of the strip's own columns) is handed to `emit` with its strip and row.
/// `l` gives the layout, feature count and instruction set (its per-level fields are replaced
/// by `stages`; its buffers are not read), `fill` converts the inputs of one block (strip,
/// row) into a source block and an aux block. `split`: rows per task and groups of strips
/// (`None`: chosen here). A task runs a band of rows of a group of adjacent strips together,
/// so that inside the group no strip recomputes its neighbours' columns (1080p, two threads,
/// two groups of two 480-column strips: 60 of the first level's 600 swept columns per side
/// are halo instead of 60 of every 480-column strip's).
pub(super) fn run(
    l: &Level,
    stages: &[Stage],
    split: Option<(usize, usize)>,
    fill: &Fill,
    emit: &Emit,
) {
    let lay = l.lay;
    let (band_rows, groups) = split.unwrap_or_else(|| auto_split(lay));
    let (band_rows, groups) = (band_rows.max(1), groups.clamp(1, lay.nch));
    (0..groups).into_par_iter().for_each(|g| {
        let strips = g * lay.nch / groups..(g + 1) * lay.nch / groups;
        let cols: Vec<[Cols; MAX_LEVELS]> = strips
            .clone()
            .map(|c| columns(lay, c, strips.clone(), stages).expect("checked by `supports`"))
            .collect();
        (0..lay.h.div_ceil(band_rows))
            .into_par_iter()
            .for_each(|bi| {
                let a = bi * band_rows;
                let b = (a + band_rows).min(lay.h);
                SCRATCH.with(|s| {
                    Task {
                        l,
                        stages,
                        strips: strips.clone(),
                        cols: &cols,
                        fill,
                        emit,
                    }
                    .run(a..b, &mut s.borrow_mut());
                });
            });
    });
}

/// What every task of one group of strips shares.
struct Task<'a> {
    l: &'a Level<'a>,
    stages: &'a [Stage],
    /// The group's strips.
    strips: std::ops::Range<usize>,
    /// Per strip of the group, its levels' columns.
    cols: &'a [[Cols; MAX_LEVELS]],
    fill: &'a Fill<'a>,
    emit: &'a Emit<'a>,
}

impl Task<'_> {
    /// Rows `rows` of the group's strips through every level, each finished row to `emit`.
    fn run(&self, rows: std::ops::Range<usize>, scratch: &mut Scratch) {
        let Task {
            l,
            stages,
            ref strips,
            cols,
            fill,
            emit,
        } = *self;
        let lay = l.lay;
        let n = stages.len();
        let h = lay.h;
        let m = strips.len();
        let step = |k: usize| stages[k].step;
        let rn = |k: usize| 2 * step(k) + 1;
        // Feature rows live from the last level's next row to 2·step_0 below the first level's:
        // the levels lag each other by at most 2·step (see the scheduling below).
        let fr = halo_rows(stages) + 2;
        let Scratch {
            strips: rings,
            weights,
        } = scratch;
        rings.resize_with(rings.len().max(m), Rings::default);
        for r in &mut rings[..m] {
            r.grow(stages, fr);
        }
        // Zeroed once; only ever overwritten with weights in [0, 1] (see pairs/).
        if weights.len() < PAIRS.len() {
            weights.resize(PAIRS.len(), Aligned([0.0; QW]));
        }
        // Output rows of each level: what the next level reads, clipped to the image.
        let mut o_lo = [0usize; MAX_LEVELS];
        let mut o_hi = [0usize; MAX_LEVELS];
        (o_lo[n - 1], o_hi[n - 1]) = (rows.start, rows.end);
        for k in (0..n - 1).rev() {
            o_lo[k] = o_lo[k + 1].saturating_sub(2 * step(k + 1));
            o_hi[k] = (o_hi[k + 1] + 2 * step(k + 1)).min(h);
        }
        // Next row each level sweeps: from 2·step above its output (for their scatter alone).
        let mut next: [usize; MAX_LEVELS] = std::array::from_fn(|k| {
            if k < n {
                o_lo[k].saturating_sub(2 * step(k))
            } else {
                0
            }
        });
        let levels: Vec<Level> = stages
            .iter()
            .map(|s| Level {
                step: s.step,
                cm: s.cm,
                color_scale: s.color_scale,
                normal_factor: s.normal_factor,
                ..*l
            })
            .collect();
        // The deepest level whose input rows are ready sweeps its next row: this keeps the rings
        // at 2·step + 1 rows (a level is only advanced while the one after it waits).
        let ready = |next: &[usize; MAX_LEVELS]| {
            (0..n).rev().find(|&k| {
                next[k] < o_hi[k]
                    && (k == 0 || next[k - 1] > (next[k] + 2 * step(k)).min(o_hi[k - 1] - 1))
            })
        };
        // Next input row to convert.
        let mut filled = next[0];
        while let Some(k) = ready(&next) {
            let y = next[k];
            let s = step(k);
            if k == 0 {
                // Level 0 reads input rows y .. y + 2·step_0.
                while filled <= (y + 2 * s).min(h - 1) {
                    // The slots' previous rows must have been read for the last time.
                    let low = (0..n).filter(|&j| next[j] < o_hi[j]).map(|j| next[j]).min();
                    assert!(
                        filled < low.unwrap_or(0) + fr && filled < y + rn(0),
                        "pipeline input ring overrun"
                    );
                    for (c, r) in strips.clone().zip(rings.iter_mut()) {
                        fill(
                            c,
                            filled,
                            &mut r.rows[0][filled % rn(0)].0,
                            &mut r.feat[filled % fr].0,
                        );
                    }
                    filled += 1;
                }
            }
            let kept = |yq: usize| yq >= o_lo[k] && yq < o_hi[k];
            // The slot's previous row must have been read for the last time.
            assert!(
                k + 1 == n || !kept(y) || y < next[k + 1] + rn(k + 1),
                "pipeline ring overrun"
            );
            for (i, c) in strips.clone().enumerate() {
                let Rings { acc, rows, feat } = &mut rings[i];
                let (inp, outp) = rows.split_at_mut(k + 1);
                let src = |yq: usize| -> &SrcBlock {
                    if yq >= h {
                        &ZERO_SRC.0
                    } else {
                        &inp[k][yq % rn(k)].0
                    }
                };
                let aux = |yq: usize| {
                    if yq >= h {
                        &ZERO_AUX.0
                    } else {
                        &feat[yq % fr].0
                    }
                };
                let cl = cols[i][k];
                let job = RowJob {
                    scatter: [kept(y), kept(y + s), kept(y + 2 * s)],
                    j_lo: cl.j_lo,
                    j_hi: cl.j_hi,
                    o_lo: cl.o_lo,
                    o_hi: cl.o_hi,
                    step: s,
                    color_scale: stages[k].color_scale,
                    normal_factor: stages[k].normal_factor,
                    top: y < s,
                };
                let [a0, a1, a2] = acc[k]
                    .get_disjoint_mut([y % rn(k), (y + s) % rn(k), (y + 2 * s) % rn(k)])
                    .expect("ring rows are distinct");
                let r = Rows {
                    p: src(y),
                    pa: aux(y),
                    q1: src(y + s),
                    qa1: aux(y + s),
                    q2: src(y + 2 * s),
                    qa2: aux(y + 2 * s),
                };
                let mut accs = Accs {
                    a0: &mut a0.0,
                    a1: &mut a1.0,
                    a2: &mut a2.0,
                    w: flat_rows(weights),
                };
                pairs::row(&levels[k], &r, &mut accs, job);
                if !kept(y) {
                    continue;
                }
                let len = cl.o_hi - cl.o_lo;
                if k + 1 == n {
                    let d = &mut outp[0][0].0;
                    normalise::<false>(&accs.a0[..], QW, cl.o_lo, d, cl.o_lo, len);
                    emit(c, y, d);
                } else {
                    let d = &mut outp[0][y % rn(k + 1)].0;
                    normalise::<false>(&accs.a0[..], QW, cl.o_lo, d, cl.o_lo, len);
                    // Columns beyond the output: 0, so that those beyond the image have no
                    // colour or validity (the rest are read only for sums nobody keeps, or
                    // are margins copied from a neighbour below).
                    for p in 0..4 {
                        d[p * QW..p * QW + cl.o_lo].fill(0.0);
                        d[p * QW + cl.o_hi..p * QW + lay.span()].fill(0.0);
                    }
                }
            }
            if k + 1 < n && kept(y) {
                // Inside the group, each strip's margins of the row are its neighbours'
                // columns, as `Layout::fill_margins` copies them level by level.
                let slot = y % rn(k + 1);
                for i in 0..m.saturating_sub(1) {
                    let (left, right) = rings.split_at_mut(i + 1);
                    let a = &mut left[i].rows[k + 1][slot].0;
                    let b = &mut right[0].rows[k + 1][slot].0;
                    for p in 0..4 {
                        let (pa, pb) = (&mut a[p * QW..][..QW], &mut b[p * QW..][..QW]);
                        exchange_margins(pa, pb, lay.sw);
                    }
                }
            }
            next[k] += 1;
        }
    }
}
