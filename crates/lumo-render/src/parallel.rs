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
    rows.into_iter().flatten().collect()
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
    rows.into_iter().flatten().collect()
}
