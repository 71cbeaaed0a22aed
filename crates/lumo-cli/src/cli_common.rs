//! Small pieces every subcommand shares: the worker pool, the memory check and checks of
//! common options.

use anyhow::{bail, Context, Result};
use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set once standard output could not be written (a closed pipe: `lumo … | head`): later
/// output is dropped instead of failing again.
static STDOUT_GONE: AtomicBool = AtomicBool::new(false);

/// Writes `args` to standard output, for [`out!`] and [`outln!`]. `println!` panics (exit 101)
/// when the reader has gone (`lumo compare … --json | head`, `lumo render --list | true`); here
/// a closed pipe silently ends the output while the command finishes its work (files it
/// writes are not lost), and any other write error is reported once on stderr.
pub fn write_stdout(args: std::fmt::Arguments) {
    if STDOUT_GONE.load(Ordering::Relaxed) {
        return;
    }
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(args).and_then(|()| out.flush()) {
        STDOUT_GONE.store(true, Ordering::Relaxed);
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            // eprintln! would panic in turn if stderr is the same broken pipe.
            let _ = writeln!(
                std::io::stderr(),
                "warning: cannot write to standard output ({e}); the rest of it is dropped"
            );
        }
    }
}

/// `print!` that survives a closed standard output (see [`write_stdout`]).
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::cli_common::write_stdout(format_args!($($arg)*))
    };
}

/// `println!` that survives a closed standard output (see [`write_stdout`]).
macro_rules! outln {
    () => {
        $crate::cli_common::write_stdout(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::cli_common::write_stdout(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// Writes `args` to standard error, for [`errln!`]: `eprintln!` panics when stderr is a closed
/// pipe (`lumo … 2>&1 | head`); a message nobody can read is dropped instead.
pub fn write_stderr(args: std::fmt::Arguments) {
    let _ = std::io::stderr().lock().write_fmt(args);
}

/// `eprint!` that survives a closed standard error (see [`write_stderr`]).
macro_rules! err {
    ($($arg:tt)*) => {
        $crate::cli_common::write_stderr(format_args!($($arg)*))
    };
}

/// `eprintln!` that survives a closed standard error (see [`write_stderr`]).
macro_rules! errln {
    ($($arg:tt)*) => {
        $crate::cli_common::write_stderr(format_args!("{}\n", format_args!($($arg)*)))
    };
}
pub(crate) use {err, errln, out, outln};

/// Most worker threads per core `--threads` may ask for: the renderer keeps every thread
/// busy, so more than a few per core only adds switching and per-thread memory (100,000
/// threads exhausted the machine).
pub const MAX_THREADS_PER_CORE: usize = 4;

/// The cores this process may use (1 when unknown).
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// The worker-thread count for `--threads` (`None`: all cores): warns about and corrects
/// `--threads 0` (all cores) and counts over [`MAX_THREADS_PER_CORE`] per core (capped).
pub fn thread_count(threads: Option<usize>) -> Option<usize> {
    let max = MAX_THREADS_PER_CORE * cores();
    match threads {
        Some(0) => {
            errln!(
                "warning: --threads 0: using all {} cores (omit --threads for that)",
                cores()
            );
            None
        }
        Some(n) if n > max => {
            errln!("warning: --threads {n}: at most {MAX_THREADS_PER_CORE} per core; using {max}");
            Some(max)
        }
        t => t,
    }
}

/// A rayon pool of `threads` workers (`None`: all cores), corrected by [`thread_count`].
pub fn worker_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(thread_count(threads).unwrap_or(0))
        .build()
        .context("cannot start worker threads")
}

/// Memory this process may still allocate, in bytes (`LUMO_MEMORY_LIMIT` if set, else the
/// least of MemAvailable, the cgroup's and RLIMIT_AS's room: [`lumo_image::memory_available`]);
/// `None` where nothing is known (then nothing is refused).
pub fn memory_available() -> Option<u64> {
    lumo_image::memory_available()
}

/// Refuses, before anything is allocated, work that needs about `need` bytes when less
/// memory than that is available: `what` says what needs it, `advice` how to ask for less.
pub fn check_memory(need: u64, what: &str, advice: &str) -> Result<()> {
    if let Some(available) = memory_available() {
        if need > available {
            bail!(
                "{what} needs about {} of memory, but only {} is available; {advice}",
                bytes(need),
                bytes(available),
            );
        }
    }
    Ok(())
}

/// `n` bytes in binary units for messages ("79.00 GiB").
pub fn bytes(n: u64) -> String {
    lumo_image::format_bytes(n)
}

/// Refuses `--max-depth 0` (Mitsuba's convention starts at 1) and depths beyond what a scene
/// file may ask for ([`lumo_scene::DEPTH_LIMIT`]: a closed mirror box would trace for hours).
pub fn check_max_depth(max_depth: Option<u32>) -> Result<()> {
    let limit = lumo_scene::DEPTH_LIMIT;
    match max_depth {
        Some(0) => bail!("--max-depth must be at least 1 (1 = emitters seen directly)"),
        Some(d) if d > limit => bail!(
            "--max-depth {d} is beyond the limit {limit} (Mitsuba's unbounded depth; Russian \
             roulette ends long paths: use --max-depth {limit} for 'unbounded')"
        ),
        _ => Ok(()),
    }
}

/// Refuses `--rr-depth` outside 1..=[`lumo_scene::DEPTH_LIMIT`], the range a scene file's
/// `rr_depth` has.
pub fn check_rr_depth(rr_depth: Option<u32>) -> Result<()> {
    let limit = lumo_scene::DEPTH_LIMIT;
    match rr_depth {
        Some(d) if d == 0 || d > limit => bail!(
            "--rr-depth {d} must be 1..={limit} (the depth from which Russian roulette may end \
             paths; 1 = from the first bounce)"
        ),
        _ => Ok(()),
    }
}

/// Parses a samples-per-pixel option: 1..=[`crate::arguments::MAX_SPP`] (a typo such as
/// 4294967295 once made the benchmarks ask for a terabyte and abort).
pub fn parse_spp(s: &str) -> std::result::Result<u32, String> {
    let max = crate::arguments::MAX_SPP;
    match s.trim().parse::<u64>() {
        Ok(n) if (1..=max as u64).contains(&n) => Ok(n as u32),
        _ => Err(format!(
            "invalid sample count {s:?}: expected 1..={max} samples per pixel"
        )),
    }
}

/// [`parse_spp`] where 0 means "none" (a reference that is not rendered).
pub fn parse_spp_or_zero(s: &str) -> std::result::Result<u32, String> {
    match s.trim() {
        "0" => Ok(0),
        _ => parse_spp(s),
    }
}

/// Parses a positive, finite number of seconds.
pub fn parse_seconds(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(t) if t.is_finite() && t > 0.0 && t <= 1e7 => Ok(t),
        _ => Err(format!(
            "invalid time {s:?}: expected a number of seconds > 0 (at most 1e7)"
        )),
    }
}

/// Parses `--seed`: 0..=4294967295, with a message that gives the range (clap's own says
/// only "number too large to fit in target type").
pub fn parse_seed(s: &str) -> std::result::Result<u32, String> {
    s.trim().parse::<u32>().map_err(|_| {
        format!(
            "invalid seed {s:?}: expected a whole number in 0..={}",
            u32::MAX
        )
    })
}

/// Parses `--threads`: a whole number (0 = all cores, with a warning; more than the cores
/// allow is capped by [`worker_pool`]), with a message that says so.
pub fn parse_threads(s: &str) -> std::result::Result<usize, String> {
    s.trim().parse::<usize>().map_err(|_| {
        format!("invalid thread count {s:?}: expected a whole number ≥ 0 (0 = all cores)")
    })
}

/// Whether `a` and `b` name the same file (compared as canonical paths when both exist, else
/// as written).
pub fn same_file(a: &std::path::Path, b: &std::path::Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

/// On SIGINT or SIGTERM, removes the temporaries of the writes in flight
/// ([`lumo_image::temps`]) and then dies of the signal as it would have without the handler
/// (exit status 130 or 143 in a shell). Until now an interrupted write left its `.lumo-tmp-*`
/// file for the next run to sweep. The handler is a thread (signal-hook's iterator), so the
/// clean-up may take locks and remove files.
pub fn remove_temps_on_signal() {
    use signal_hook::consts::{SIGINT, SIGTERM};
    // Without the handler the signal still kills the process; the next run sweeps then.
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            // Held until the process ends: no writer creates a temporary after the sweep.
            let (_, _held) = lumo_image::temps::remove_all_and_hold();
            // Restores the default action and raises the signal again.
            let _ = signal_hook::low_level::emulate_default_handler(signal);
            std::process::exit(128 + signal);
        }
    });
}
