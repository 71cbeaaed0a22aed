//! What an image file may cost before lumo reads it: a pixel budget checked against the header
//! before any pixel buffer is allocated, and a refusal of paths that are not regular files.
//!
//! Image headers are a few bytes that claim a size; a 74-byte PNG can claim 100000² pixels and
//! a decoder that trusts it allocates tens of gigabytes and aborts the process (under
//! `lumo serve`, the whole server). So every reader looks at the header first and refuses a
//! size over the budget with a message naming the file, its size and the limit.

use std::path::Path;
use std::sync::OnceLock;

use crate::ImageError;

/// The default pixel budget: 2^27 pixels (134 M), e.g. a 16384×8192 environment map, which
/// is 1.5 GiB as RGB float32. Larger images are rare enough to ask for an explicit opt-in.
pub const DEFAULT_MAX_PIXELS: u64 = 1 << 27;

/// The environment variable that replaces [`DEFAULT_MAX_PIXELS`] (a pixel count).
pub const MAX_PIXELS_VAR: &str = "LUMO_MAX_PIXELS";

/// The pixel budget in force: `LUMO_MAX_PIXELS` if set to a positive integer, else
/// [`DEFAULT_MAX_PIXELS`]. Read once per process.
pub fn max_image_pixels() -> u64 {
    static LIMIT: OnceLock<u64> = OnceLock::new();
    *LIMIT.get_or_init(|| {
        std::env::var(MAX_PIXELS_VAR)
            .ok()
            .and_then(|v| v.trim().parse::<u64>().ok())
            .filter(|&n| n > 0)
            .unwrap_or(DEFAULT_MAX_PIXELS)
    })
}

/// Bytes per pixel a reader may hold while decoding: the decoder's buffer and the float image
/// (up to four channels of f32 each).
pub const DECODE_BYTES_PER_PIXEL: u64 = 32;

/// Errors unless a `width`×`height` image fits the pixel budget, has at least one pixel and
/// its decoding fits the memory this process may still allocate ([`crate::memory_available`]:
/// an 11585² PNG of 400 KB is within the pixel budget yet aborted `lumo compare` at 7.4 GB).
/// `file_bytes` is only reported.
pub fn check_image_size(
    path: &Path,
    width: usize,
    height: usize,
    file_bytes: u64,
) -> Result<(), ImageError> {
    check_image_pixels(path, width, height, file_bytes)?;
    let need = (width as u64 * height as u64).saturating_mul(DECODE_BYTES_PER_PIXEL);
    if let Some(available) = crate::memory_available().filter(|&a| need > a) {
        return Err(ImageError::OutOfMemory {
            path: path.to_path_buf(),
            width,
            height,
            need,
            available,
        });
    }
    Ok(())
}

/// The empty-image and pixel-budget part of [`check_image_size`], for an image already read
/// (its memory is spent).
pub(crate) fn check_image_pixels(
    path: &Path,
    width: usize,
    height: usize,
    file_bytes: u64,
) -> Result<(), ImageError> {
    if width == 0 || height == 0 {
        return Err(ImageError::Empty {
            path: path.to_path_buf(),
            width,
            height,
        });
    }
    let limit = max_image_pixels();
    if (width as u64).saturating_mul(height as u64) > limit {
        return Err(ImageError::TooLarge {
            path: path.to_path_buf(),
            width,
            height,
            file_bytes,
            limit,
        });
    }
    Ok(())
}

/// The size of the regular file at `path`; an error for a missing file and for anything that
/// is not a regular file (directory, FIFO, device, socket). Checked on the path's metadata
/// before opening: opening a FIFO blocks until someone writes to it, and a device such as
/// `/dev/zero` never ends.
pub fn regular_file_size(path: &Path) -> Result<u64, ImageError> {
    let meta = std::fs::metadata(path).map_err(|source| ImageError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    if meta.is_file() {
        return Ok(meta.len());
    }
    Err(ImageError::NotAFile {
        path: path.to_path_buf(),
        kind: file_kind(&meta.file_type()),
    })
}

/// A word for what a non-regular file is, for messages.
pub fn file_kind(t: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "FIFO (named pipe)";
        }
        if t.is_char_device() || t.is_block_device() {
            return "device";
        }
        if t.is_socket() {
            return "socket";
        }
    }
    if t.is_dir() {
        "directory"
    } else if t.is_file() {
        "regular file"
    } else {
        "special file"
    }
}
