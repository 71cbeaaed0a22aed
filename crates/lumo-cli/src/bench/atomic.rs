//! All-or-nothing file writes: write under a temporary name in the target's directory, then
//! rename. A rename within one directory is atomic on POSIX file systems, so an interrupted
//! benchmark (Ctrl-C, a crash, a full disk) leaves either the old file or the new one, never
//! half of one.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use lumo_image::{write_image, Image};

/// The temporary name `path` is written under before the rename: same directory (so the
/// rename cannot cross file systems), hidden, tagged with the process id so two runs never
/// share one, and with the real extension last so image writers still pick the format.
pub fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    path.with_file_name(format!(".{}.tmp-{}.{name}", "lumo", std::process::id()))
}

/// Writes `bytes` to `path` atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    commit(path, |tmp| {
        std::fs::write(tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))
    })
}

/// Writes `image` (format by `path`'s extension) atomically.
pub fn write_image_atomic(path: &Path, image: &Image) -> Result<()> {
    commit(path, |tmp| Ok(write_image(tmp, image)?))
}

/// Fails early, before any work, if files cannot be created in `dir` (creating `dir` first).
pub fn check_dir_writable(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let probe = temp_path(&dir.join("probe"));
    let _in_flight = lumo_image::temps::InFlight::new(&probe);
    std::fs::write(&probe, b"").with_context(|| format!("cannot write into {}", dir.display()))?;
    std::fs::remove_file(&probe).ok();
    Ok(())
}

/// Runs `write` on the temporary path, then renames it over `path`; on any failure the
/// temporary file is removed and `path` is left as it was.
fn commit(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = temp_path(path);
    let _in_flight = lumo_image::temps::InFlight::new(&tmp);
    let result = write(&tmp).and_then(|()| {
        std::fs::rename(&tmp, path)
            .with_context(|| format!("cannot rename {} to {}", tmp.display(), path.display()))
    });
    if result.is_err() {
        std::fs::remove_file(&tmp).ok();
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("lumo-atomic-{name}-{}", std::process::id()));
        std::fs::remove_dir_all(&d).ok();
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn replaces_the_file_and_leaves_no_temporary() {
        let d = scratch("ok");
        let p = d.join("quality.md");
        std::fs::write(&p, "old").unwrap();
        write_bytes(&p, b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new");
        let names: Vec<_> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_removes_the_temporary() {
        let d = scratch("fail");
        let p = d.join("quality.md");
        std::fs::write(&p, "old").unwrap();
        let err = commit(&p, |tmp| {
            // Half a file, then the "interrupt".
            std::fs::write(tmp, "half").unwrap();
            anyhow::bail!("interrupted")
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old");
        assert!(!temp_path(&p).exists());
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn the_temporary_keeps_the_extension_and_directory() {
        let t = temp_path(Path::new("docs/results/quality.png"));
        assert_eq!(t.parent(), Some(Path::new("docs/results")));
        assert_eq!(t.extension().and_then(|e| e.to_str()), Some("png"));
    }

    #[test]
    fn images_are_written_atomically_too() {
        let d = scratch("img");
        let p = d.join("a.pfm");
        let img = Image::new(2, 2, 3, 0.5);
        write_image_atomic(&p, &img).unwrap();
        assert_eq!(lumo_image::read_image(&p).unwrap(), img);
        std::fs::remove_dir_all(&d).ok();
    }
}
