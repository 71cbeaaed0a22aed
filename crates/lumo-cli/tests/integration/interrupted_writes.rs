//! A write interrupted by SIGINT or SIGTERM removes its temporary (issue 49: the
//! `.lumo-tmp-*` file stayed until a later run swept it), and lumo dies of the signal as a
//! process without a handler would (a shell reports 130 or 143).

#![cfg(unix)]

use std::os::unix::process::ExitStatusExt;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The `.lumo-tmp-*` files in `dirs` and their sizes.
fn temporaries(dirs: &[PathBuf]) -> Vec<(PathBuf, u64)> {
    dirs.iter()
        .filter_map(|d| std::fs::read_dir(d).ok())
        .flat_map(|entries| entries.flatten())
        .filter(|e| e.file_name().to_string_lossy().starts_with(".lumo-tmp-"))
        .map(|e| (e.path(), e.metadata().map_or(0, |m| m.len())))
        .collect()
}

fn interrupt_a_write(signal: i32, name: &str) {
    let dir = std::env::temp_dir().join(format!("lumo-signal-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // Large enough that writing the image and its AOV planes takes a while.
    let mut child = Command::new(env!("CARGO_BIN_EXE_lumo"))
        .args([
            "render",
            "cornell",
            "--size",
            "2048x2048",
            "--spp",
            "1",
            "--pipeline",
            "none",
            "--aovs",
            "aovs",
            "-o",
            "out.exr",
        ])
        .current_dir(&dir)
        .env_remove("LUMO_MEMORY_LIMIT")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("run lumo");
    let dirs = [dir.clone(), dir.join("aovs")];
    let start = Instant::now();
    let seen = loop {
        // A temporary with bytes in it: an image being written (the empty ones are the
        // writability probes before the render, which a signal removes as well).
        let temps = temporaries(&dirs);
        if temps.iter().any(|(_, len)| *len > 0) {
            break temps;
        }
        if let Some(status) = child.try_wait().unwrap() {
            panic!("lumo ended ({status}) before a temporary was seen");
        }
        assert!(start.elapsed() < Duration::from_secs(120), "no write began");
        std::thread::sleep(Duration::from_micros(200));
    };
    let killed = Command::new("kill")
        .args([format!("-{signal}"), child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let status = child.wait().unwrap();
    assert_eq!(status.signal(), Some(signal), "{status} after {seen:?}");
    let left = temporaries(&dirs);
    assert!(left.is_empty(), "left behind: {left:?} (seen: {seen:?})");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn sigint_during_a_write_removes_the_temporary() {
    interrupt_a_write(2, "int");
}

#[test]
fn sigterm_during_a_write_removes_the_temporary() {
    interrupt_a_write(15, "term");
}
