//! Small pieces every subcommand shares: the worker pool and checks of common options.

use anyhow::{bail, Context, Result};

/// A rayon pool of `threads` workers (`None`: all cores).
pub fn worker_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")
}

/// Refuses `--max-depth 0` (Mitsuba's convention starts at 1).
pub fn check_max_depth(max_depth: Option<u32>) -> Result<()> {
    if max_depth == Some(0) {
        bail!("--max-depth must be at least 1 (1 = emitters seen directly)");
    }
    Ok(())
}
