//! Helpers every CLI test module shares.

use std::path::PathBuf;
use std::process::{Command, Output};

/// A fresh, empty folder for one test: `lumo-{module}-{name}-{pid}` under the system's
/// temporary folder (the process id keeps concurrent test runs apart).
pub fn temp_dir(module: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lumo-{module}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs the `lumo` binary under test with `args`.
pub fn lumo(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lumo"))
        .args(args)
        .output()
        .expect("run lumo")
}
