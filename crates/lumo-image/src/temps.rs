//! The temporary files this process is writing, so that a handler of SIGINT or SIGTERM can
//! remove them before the process dies ([`remove_all_and_hold`]); otherwise they are only
//! swept by a later run ([`crate::sweep_stale_temps`]).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

static IN_FLIGHT: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());

/// The registry, whatever a panicking writer left it in (a set of paths stays valid).
fn registry() -> MutexGuard<'static, BTreeSet<PathBuf>> {
    IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner())
}

/// A temporary file registered while it may exist; dropping it unregisters the path (the
/// writer has renamed or removed the file by then).
#[derive(Debug)]
pub struct InFlight {
    path: PathBuf,
}

impl InFlight {
    /// Registers `path`, before the file is created.
    pub fn new(path: &Path) -> Self {
        registry().insert(path.to_path_buf());
        Self {
            path: path.to_path_buf(),
        }
    }
}

impl Drop for InFlight {
    fn drop(&mut self) {
        registry().remove(&self.path);
    }
}

/// Removes every registered temporary and returns the registry still locked: a signal
/// handler holds it until the process ends, so that no writer registers (and creates) a new
/// temporary after the sweep. Returns how many files were removed, with the guard.
pub fn remove_all_and_hold() -> (usize, MutexGuard<'static, BTreeSet<PathBuf>>) {
    let temps = registry();
    let removed = remove_listed(&temps);
    (removed, temps)
}

/// Removes the files named in `temps`; returns how many existed and were removed.
fn remove_listed(temps: &BTreeSet<PathBuf>) -> usize {
    temps
        .iter()
        .filter(|p| std::fs::remove_file(p).is_ok())
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn registered_temporaries_are_removed_and_dropped_ones_forgotten() {
        let dir = std::env::temp_dir().join(format!("lumo-temps-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (a, b) = (dir.join("a.tmp"), dir.join("b.tmp"));
        let held = InFlight::new(&a);
        std::fs::write(&a, b"x").unwrap();
        {
            let _done = InFlight::new(&b);
        }
        // b is no longer in flight: a file of that name (another writer's) is left alone.
        std::fs::write(&b, b"y").unwrap();
        // Other tests of this crate write images (and register temporaries) in parallel, so
        // only this test's part of the registry is swept: the global sweep would remove theirs.
        let ours: BTreeSet<PathBuf> = registry()
            .iter()
            .filter(|p| p.starts_with(&dir))
            .cloned()
            .collect();
        assert_eq!(ours, BTreeSet::from([a.clone()]));
        assert_eq!(remove_listed(&ours), 1);
        assert!(!a.exists() && b.exists());
        drop(held);
        assert!(!registry().iter().any(|p| p.starts_with(&dir)));
        std::fs::remove_dir_all(&dir).ok();
    }
}
