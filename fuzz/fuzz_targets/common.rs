//! Shared by the targets that must go through a file: the input is written to a file of the
//! given name in a per-process directory (in /dev/shm where there is one, to keep it in memory).

use std::path::PathBuf;
use std::sync::OnceLock;

/// A small pixel budget for fuzzing: what matters is that the readers never allocate past the
/// budget and the file's size, and libFuzzer counts any allocation over 2 GiB as a crash, which
/// the default budget of 2^27 pixels in four float channels would reach legitimately.
pub fn set_small_pixel_budget() {
    static ONCE: OnceLock<()> = OnceLock::new();
    ONCE.get_or_init(|| std::env::set_var("LUMO_MAX_PIXELS", (1u64 << 22).to_string()));
}

/// Writes `data` to `name` in this process's scratch directory and returns its path.
pub fn write_input(name: &str, data: &[u8]) -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    let dir = DIR.get_or_init(|| {
        let base = if std::path::Path::new("/dev/shm").is_dir() {
            PathBuf::from("/dev/shm")
        } else {
            std::env::temp_dir()
        };
        let d = base.join(format!("lumo-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("scratch directory");
        d
    });
    let path = dir.join(name);
    std::fs::write(&path, data).expect("scratch file");
    path
}
