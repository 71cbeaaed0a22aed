//! Rows in parallel: the loops that spread a whole image's pixels over rayon's threads, in
//! row-major order whatever the thread count (the image loops of `render.rs` and the direct
//! light split use them).

use std::sync::atomic::{AtomicU64, Ordering};

use rayon::prelude::*;

/// Evaluates `f(y)` (a row's results, left to right) for every row of an image of `height`
/// rows, rows in parallel, and returns the results in row-major order. `progress` gets the
/// number of rows finished.
pub fn map_rows<T, F>(height: usize, progress: &(dyn Fn(usize) + Sync), f: F) -> Vec<T>
where
    T: Send,
    F: Fn(usize) -> Vec<T> + Sync,
{
    let done = AtomicU64::new(0);
    let rows: Vec<Vec<T>> = (0..height)
        .into_par_iter()
        .map(|y| {
            let row = f(y);
            let finished = done.fetch_add(1, Ordering::Relaxed) + 1;
            progress(finished as usize);
            row
        })
        .collect();
    concat(rows)
}

/// Evaluates `f(x, y)` for every pixel of a `width`×`height` image, rows in parallel, and
/// returns the results in row-major order. `progress` gets the number of rows finished. Results
/// do not depend on how the rows are spread over threads.
pub fn map_pixels<T, F>(
    width: usize,
    height: usize,
    progress: &(dyn Fn(usize) + Sync),
    f: F,
) -> Vec<T>
where
    T: Send,
    F: Fn(usize, usize) -> T + Sync,
{
    let done = AtomicU64::new(0);
    let rows: Vec<Vec<T>> = (0..height)
        .into_par_iter()
        .map(|y| {
            let row = (0..width).map(|x| f(x, y)).collect();
            let finished = done.fetch_add(1, Ordering::Relaxed) + 1;
            progress(finished as usize);
            row
        })
        .collect();
    concat(rows)
}

/// Writes every row of `out` (rows of `width` values, row-major) with `f(y, row)`, rows in
/// parallel; `progress` gets the number of rows finished. The in-place form of [`map_rows`]:
/// a frame-sized buffer allocated once, with no row vectors and no concatenation (which
/// page-faulted a second and third copy of a frame's estimates: docs/results/temporal.md).
pub fn fill_rows<T, F>(out: &mut [T], width: usize, progress: &(dyn Fn(usize) + Sync), f: F)
where
    T: Send,
    F: Fn(usize, &mut [T]) + Sync,
{
    let done = AtomicU64::new(0);
    out.par_chunks_mut(width.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            f(y, row);
            let finished = done.fetch_add(1, Ordering::Relaxed) + 1;
            progress(finished as usize);
        });
}

/// The rows one after the other in one vector of exactly their total length: `flatten()`
/// does not know that length, so it grew the vector by doubling, copying (and page-faulting)
/// a frame's worth of values several times over.
fn concat<T>(rows: Vec<Vec<T>>) -> Vec<T> {
    let mut out = Vec::with_capacity(rows.iter().map(Vec::len).sum());
    for row in rows {
        out.extend(row);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fill_rows_writes_every_row_in_order() {
        let (w, h) = (7, 5);
        let mut out = vec![0usize; w * h];
        fill_rows(&mut out, w, &|_| {}, |y, row| {
            for (x, v) in row.iter_mut().enumerate() {
                *v = y * 100 + x;
            }
        });
        let expect: Vec<usize> = (0..h)
            .flat_map(|y| (0..w).map(move |x| y * 100 + x))
            .collect();
        assert_eq!(out, expect);
    }

    #[test]
    fn map_rows_concatenates_rows_of_any_length() {
        let out = map_rows(4, &|_| {}, |y| vec![y; y]);
        assert_eq!(out, vec![1, 2, 2, 3, 3, 3]);
        assert_eq!(out.capacity(), out.len());
    }
}
