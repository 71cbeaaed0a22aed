//! What the 4- and 8-wide traversals share: their stack (on the machine stack when the tree
//! is shallow enough, never zeroed), the ordering of hit children, and the choice of the
//! nearest triangle in a leaf.

use std::mem::MaybeUninit;

use crate::accel::wide::TriHit;

/// Entries kept on the machine stack; deeper trees use a heap stack.
const INLINE: usize = 64;

/// A traversal stack over uninitialised memory: zeroing 512 bytes for every ray cost ~4 % of a
/// render's instructions, and a traversal only reads entries it pushed.
pub(crate) struct TraversalStack<'a, T: Copy> {
    buf: &'a mut [MaybeUninit<T>],
    len: usize,
}

impl<T: Copy> TraversalStack<'_, T> {
    /// Pushes `v` (panics past the capacity the tree's depth promised).
    #[inline(always)]
    pub fn push(&mut self, v: T) {
        self.buf[self.len] = MaybeUninit::new(v);
        self.len += 1;
    }

    /// The most recently pushed entry, if any.
    #[inline(always)]
    pub fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: entries below `len` were written by `push`.
        Some(unsafe { self.buf[self.len].assume_init() })
    }
}

/// Runs `f` with a stack of at least `need` entries.
#[inline(always)]
pub(crate) fn with_stack<T: Copy, R>(need: usize, f: impl FnOnce(TraversalStack<T>) -> R) -> R {
    if need <= INLINE {
        let mut inline = [MaybeUninit::<T>::uninit(); INLINE];
        f(TraversalStack {
            buf: &mut inline,
            len: 0,
        })
    } else {
        let mut heap = vec![MaybeUninit::<T>::uninit(); need];
        f(TraversalStack {
            buf: &mut heap,
            len: 0,
        })
    }
}

/// Closest-hit descent at a node whose lanes `bits` (at least two) were hit at entry
/// distances `tnear`: pushes all hit children but the nearest, farthest first, with their
/// distances, and returns the nearest.
#[inline(always)]
pub(crate) fn descend_nearest<const W: usize>(
    child: &[u32; W],
    tnear: &[f32; W],
    mut bits: u32,
    stack: &mut TraversalStack<(u32, f32)>,
) -> u32 {
    let mut hits = [(0u32, 0f32); W];
    let mut n = 0;
    while bits != 0 {
        let lane = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        hits[n] = (child[lane], tnear[lane]);
        n += 1;
    }
    let hits = &mut hits[..n];
    sort_farthest_first(hits, |h| h.1);
    for &h in &hits[..n - 1] {
        stack.push(h);
    }
    hits[n - 1].0
}

/// Closest-hit traversals cull boxes against the nearest hit so far times this factor, not the
/// hit itself: a box's entry distance and a triangle's hit distance are rounded differently, so
/// a box holding a triangle exactly as near as the best hit (a shared edge) may enter a few ulps
/// late. Visiting it keeps the tie rule of [`keep_nearest`] independent of the visiting order.
/// (16 bits of slack: far above the rounding, far below any culling that matters.)
pub(crate) const CULL_SLACK: f32 = 1.0 + 1.0 / 65_536.0;

/// Sorts a node's hit children by entry distance `key`, farthest first (insertion sort: at
/// most eight items, so cheaper than a general sort).
#[inline(always)]
pub(crate) fn sort_farthest_first<T>(items: &mut [T], key: impl Fn(&T) -> f32) {
    for i in 1..items.len() {
        let mut j = i;
        while j > 0 && key(&items[j - 1]) < key(&items[j]) {
            items.swap(j - 1, j);
            j -= 1;
        }
    }
}

/// The next pushed subtree whose entry distance does not exceed `cull` (the nearest hit so far
/// times [`CULL_SLACK`]; the others cannot hold a hit as near), or `None` when the stack is
/// empty.
#[inline(always)]
pub(crate) fn pop_closer(stack: &mut TraversalStack<(u32, f32)>, cull: f32) -> Option<u32> {
    while let Some((child, t)) = stack.pop() {
        if t <= cull {
            return Some(child);
        }
    }
    None
}

/// Any-hit descent at a node whose lanes `bits` (at least one) were hit: pushes all hit
/// children but the first and returns it.
#[inline(always)]
pub(crate) fn descend_any<const W: usize>(
    child: &[u32; W],
    mut bits: u32,
    stack: &mut TraversalStack<u32>,
) -> u32 {
    let first = bits.trailing_zeros() as usize;
    bits &= bits - 1;
    while bits != 0 {
        stack.push(child[bits.trailing_zeros() as usize]);
        bits &= bits - 1;
    }
    child[first]
}

/// Closest-hit bookkeeping at a leaf whose lanes `bits` were hit at `tuv` = (t, u, v): keeps
/// the nearest hit so far in `best` and shrinks `tmax` to it. Of equally distant triangles the
/// one with the lower index wins, so the result does not depend on the order leaves are
/// visited in (the packet traversal of [`crate::accel::packet`] visits them in another).
#[inline(always)]
pub(crate) fn keep_nearest<const W: usize>(
    mut bits: u32,
    [t, u, v]: [&[f32; W]; 3],
    ids: &[u32; W],
    tmax: &mut f32,
    best: &mut Option<TriHit>,
) {
    while bits != 0 {
        let lane = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let nearer =
            t[lane] < *tmax || (t[lane] == *tmax && best.is_none_or(|b| ids[lane] < b.triangle));
        if nearer {
            *tmax = t[lane];
            *best = Some(TriHit {
                t: t[lane],
                triangle: ids[lane],
                u: u[lane],
                v: v[lane],
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The children order is a stable descending sort by entry distance, ties and signed zeros
    /// included.
    #[test]
    fn sort_farthest_first_is_a_stable_descending_sort() {
        let pool = [
            3.0f32,
            -1.0,
            0.0,
            2.5,
            3.0,
            f32::INFINITY,
            -7.0,
            2.5,
            1e-30,
            -0.0,
        ];
        let mut state = 1u32;
        for trial in 0..2000 {
            let n = 1 + trial % 8;
            let mut items: Vec<(usize, f32)> = (0..n)
                .map(|i| {
                    state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                    (i, pool[(state >> 24) as usize % pool.len()])
                })
                .collect();
            let mut want = items.clone();
            want.sort_by(|a, b| b.1.partial_cmp(&a.1).unwrap());
            sort_farthest_first(&mut items, |h| h.1);
            assert_eq!(items, want, "trial {trial}");
        }
    }
}
