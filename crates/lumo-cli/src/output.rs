//! Output files checked before the work, and how rates are printed.

use crate::cli_common::errln;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use lumo_image::ImageFormat;

/// Fails early (before rendering) if `path` cannot be written as an image.
pub fn check_writable(path: &Path) -> Result<()> {
    ImageFormat::from_path(path)?;
    check_output_file(path)
}

/// Fails early (before the work) if the file `path` cannot be written: it is a directory, its
/// directory does not exist or is not writable.
pub fn check_output_file(path: &Path) -> Result<()> {
    // "out.png/" names a directory to the OS but passes Path's extension test: it failed only
    // when written, after the render.
    if path.as_os_str().as_encoded_bytes().ends_with(b"/") {
        bail!(
            "cannot write {}: the name ends in '/', so it names a directory; drop the '/'",
            path.display()
        );
    }
    if path.is_dir() {
        bail!(
            "cannot write {}: it is a directory; name a file in it, e.g. {}",
            path.display(),
            path.join("image.exr").display()
        );
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        bail!(
            "cannot write {}: directory {} does not exist",
            path.display(),
            dir.display()
        );
    }
    // Temporaries of writes killed earlier (Ctrl-C, a crash) are swept here, once per output.
    let swept = lumo_image::sweep_stale_temps(&dir);
    if swept > 0 {
        errln!(
            "note: removed {swept} temporary file(s) .lumo-tmp-* left in {} by interrupted \
             writes",
            dir.display()
        );
    }
    // The probe is the temporary the write will use, so a name too long for the file system
    // fails here, not after the render.
    if let Some(name) = path
        .file_name()
        .filter(|n| n.len() > lumo_image::MAX_NAME_BYTES)
    {
        bail!(
            "cannot write {}: the file name is {} bytes; file systems take at most {}",
            path.display(),
            name.len(),
            lumo_image::MAX_NAME_BYTES
        );
    }
    let probe = lumo_image::temp_path(path);
    // Registered like a write's temporary, so that a signal now removes it too.
    let _in_flight = lumo_image::temps::InFlight::new(&probe);
    std::fs::write(&probe, b"").with_context(|| {
        format!(
            // The cause follows (permission denied, read-only file system, or /proc's "no
            // such file"): "not writable" alone misread the last.
            "cannot write {}: cannot create a file in {}",
            path.display(),
            dir.display()
        )
    })?;
    std::fs::remove_file(&probe).ok();
    Ok(())
}

/// Formats a rate with k/M/G prefixes.
pub fn si(v: f64) -> String {
    if v >= 1e9 {
        format!("{:.2} G", v / 1e9)
    } else if v >= 1e6 {
        format!("{:.2} M", v / 1e6)
    } else if v >= 1e3 {
        format!("{:.2} k", v / 1e3)
    } else {
        format!("{v:.1} ")
    }
}
