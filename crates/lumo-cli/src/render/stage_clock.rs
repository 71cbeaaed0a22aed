//! The clock `lumo render --temporal` times its stages by: wall time, or with
//! `LUMO_STAGE_CLOCK=cpu` the CPU time of all the process's threads (each thread's time on a
//! CPU from `/proc/self/task/*/schedstat`, in nanoseconds). On a machine shared with other work
//! the wall clock counts the time a stage waited for a core, which differs from stage to
//! stage and run to run; the CPU time does not. With `--threads 1` a stage's CPU time is its
//! cost on one core; on more threads it is the sum over them (idle rayon workers spin a
//! little, which it counts too). Its resolution is the scheduler's: a running thread's time
//! is brought up to date at context switches and timer ticks (a few ms), so a stage shorter
//! than that reads 0 or a tick; take medians over frames.

use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// A reading of the stage clock.
#[derive(Clone, Copy, Debug)]
pub enum Mark {
    /// Wall time.
    Wall(Instant),
    /// The process's CPU time so far.
    Cpu(Duration),
}

impl Mark {
    /// Reads the clock: the CPU clock when `LUMO_STAGE_CLOCK=cpu` and `/proc` can be read,
    /// else the wall clock.
    pub fn now() -> Self {
        if cpu_clock() {
            if let Some(t) = process_cpu_time() {
                return Mark::Cpu(t);
            }
        }
        Mark::Wall(Instant::now())
    }

    /// The time since this reading, on the same clock (0 if `/proc` stopped answering).
    pub fn elapsed(&self) -> Duration {
        match self {
            Mark::Wall(t) => t.elapsed(),
            Mark::Cpu(t) => process_cpu_time().map_or(Duration::ZERO, |now| now.saturating_sub(*t)),
        }
    }
}

/// Whether the stages are timed in CPU time (`LUMO_STAGE_CLOCK=cpu`; read once).
pub fn cpu_clock() -> bool {
    static ON: OnceLock<bool> = OnceLock::new();
    *ON.get_or_init(|| std::env::var("LUMO_STAGE_CLOCK").is_ok_and(|v| v == "cpu"))
}

/// The CPU time of the process's live threads: the first field of each thread's
/// `schedstat` (time spent on a CPU, ns). `None` where `/proc` is missing (not Linux).
fn process_cpu_time() -> Option<Duration> {
    let mut ns = 0u64;
    for entry in std::fs::read_dir("/proc/self/task").ok()? {
        let Ok(entry) = entry else { continue };
        // A thread that ended between the listing and the read has no file left: skipped.
        ns += on_cpu(&entry.path().join("schedstat")).unwrap_or(0);
    }
    Some(Duration::from_nanos(ns))
}

/// The time on a CPU (ns) in the `schedstat` file at `path`.
fn on_cpu(path: &std::path::Path) -> Option<u64> {
    let stat = std::fs::read_to_string(path).ok()?;
    stat.split_whitespace().next()?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On Linux a thread's `schedstat` advances by about the CPU time a busy loop burns and
    /// not while the thread sleeps (this thread's own file: the test harness runs other tests
    /// in the process meanwhile); the process's sum is at least this thread's.
    #[test]
    fn the_cpu_clock_counts_work_not_sleep() {
        let me = std::path::Path::new("/proc/thread-self/schedstat");
        let Some(start) = on_cpu(me) else {
            return; // not Linux: no /proc (the wall clock is used)
        };
        std::thread::sleep(Duration::from_millis(60));
        let slept = on_cpu(me).expect("read again") - start;
        let t = Instant::now();
        let mut x = 1u64;
        while t.elapsed() < Duration::from_millis(60) {
            x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
        }
        let busy = on_cpu(me).expect("read again") - start - slept;
        assert!(slept < 20_000_000, "slept {slept} ns of CPU");
        assert!(busy > 5_000_000, "a 60 ms busy loop: {busy} ns of CPU");
        let all = process_cpu_time().expect("/proc/self/task");
        assert!(all.as_nanos() >= u128::from(start + slept + busy));
    }
}
