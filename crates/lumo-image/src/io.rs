use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::limits::{check_image_pixels, regular_file_size};
use crate::{exr_io, pfm, png_io, Image, ImageError};

/// The file formats lumo reads and writes, chosen by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// OpenEXR, float32 on write; half or float on read.
    Exr,
    /// Portable float map (Debevec), float32, bottom-to-top rows.
    Pfm,
    /// 8-bit sRGB PNG (values clamped to [0,1] and gamma-encoded on write).
    Png,
}

impl ImageFormat {
    /// The format named by `path`'s extension.
    pub fn from_path(path: &Path) -> Result<Self, ImageError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("exr") => Ok(Self::Exr),
            Some("pfm") => Ok(Self::Pfm),
            Some("png") => Ok(Self::Png),
            _ => Err(ImageError::UnsupportedExtension {
                path: path.to_path_buf(),
            }),
        }
    }
}

/// Reads an EXR, PFM or PNG file (by extension) into a linear float image.
///
/// Refused with an error naming the file: a path that is not a regular file (checked before
/// opening it), a header whose size is over the pixel budget ([`crate::max_image_pixels`],
/// checked before allocating) and an image without pixels.
pub fn read_image(path: &Path) -> Result<Image, ImageError> {
    let format = ImageFormat::from_path(path)?;
    let file_bytes = regular_file_size(path)?;
    let image = match format {
        ImageFormat::Exr => exr_io::read(path, file_bytes)?,
        ImageFormat::Pfm => pfm::read(path, file_bytes)?,
        ImageFormat::Png => png_io::read(path, file_bytes)?,
    };
    // The readers check their headers; this is the one rule all formats share, kept here too
    // so that no reader can hand out an image that indexing would panic on.
    check_image_pixels(path, image.width, image.height, file_bytes)?;
    Ok(image)
}

/// Writes `image` as EXR, PFM or PNG (by extension). One-channel images stay one channel in
/// EXR and PFM; PNG is always RGB.
///
/// The write is all or nothing: the image goes to a temporary file in `path`'s directory
/// ([`temp_path`]) that is then renamed over `path`. A rename within one directory is atomic
/// on POSIX file systems, so a failed or interrupted write (a full disk, Ctrl-C, a crash)
/// leaves the previous file as it was instead of half an image. Errors name `path`.
pub fn write_image(path: &Path, image: &Image) -> Result<(), ImageError> {
    let format = ImageFormat::from_path(path)?;
    let tmp = temp_path(path);
    let _in_flight = crate::temps::InFlight::new(&tmp);
    let written = match format {
        ImageFormat::Exr => exr_io::write(&tmp, image),
        ImageFormat::Pfm => pfm::write(&tmp, image),
        ImageFormat::Png => png_io::write(&tmp, image),
    }
    .and_then(|()| std::fs::rename(&tmp, path).map_err(|e| io_err(path, e)));
    if let Err(e) = written {
        // Best effort: the temporary may not exist (creating it is what failed).
        std::fs::remove_file(&tmp).ok();
        return Err(e.with_path(&tmp, path));
    }
    Ok(())
}

/// The temporary name [`write_image`] writes `path` under before renaming it: the same
/// directory (a rename cannot cross file systems), hidden, unique per process and write (so
/// concurrent writers never share one), and ending in the real extension.
pub fn temp_path(path: &Path) -> PathBuf {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    let prefix = format!("{TEMP_PREFIX}{}-{n}.", std::process::id());
    // A name near the file system's 255-byte limit is valid, but not with the prefix: keep
    // only its extension then (the temporary once failed where the name itself would not).
    let name = if prefix.len() + name.len() > MAX_NAME_BYTES {
        path.extension()
            .map_or_else(|| "out".into(), |e| e.to_string_lossy().into_owned())
    } else {
        name
    };
    path.with_file_name(format!("{prefix}{name}"))
}

/// How [`temp_path`]'s names start.
const TEMP_PREFIX: &str = ".lumo-tmp-";

/// The longest file name common file systems (ext4, XFS, btrfs, APFS, NTFS) accept, in bytes.
pub const MAX_NAME_BYTES: usize = 255;

/// Removes the temporaries of [`write_image`] in `dir` left by lumo processes that no longer
/// run (a write killed by a signal or a crash cannot remove its own); returns how many were
/// removed. Another live process's temporaries are left alone. Linux only (a process is
/// known to be gone when /proc has no entry for it); elsewhere nothing is removed.
pub fn sweep_stale_temps(dir: &Path) -> usize {
    if !cfg!(target_os = "linux") || !Path::new("/proc/self").exists() {
        return 0;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(rest) = name.to_str().and_then(|n| n.strip_prefix(TEMP_PREFIX)) else {
            continue;
        };
        let Some(pid) = rest.split('-').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        let gone = pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists();
        if gone && entry.file_type().is_ok_and(|t| t.is_file()) {
            removed += usize::from(std::fs::remove_file(entry.path()).is_ok());
        }
    }
    removed
}

pub(crate) fn io_err(path: &Path, source: std::io::Error) -> ImageError {
    ImageError::Io {
        path: path.to_path_buf(),
        source,
    }
}

pub(crate) fn format_err(path: &Path, reason: impl Into<String>) -> ImageError {
    ImageError::Format {
        path: path.to_path_buf(),
        reason: reason.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The names in `dir`, sorted.
    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn writes_replace_the_file_whole_or_not_at_all() {
        let dir = std::env::temp_dir().join(format!("lumo-image-atomic-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("out.png");
        let good = gradient(3);
        write_image(&p, &good).unwrap();
        assert_eq!(names(&dir), ["out.png"], "no temporary left behind");
        let before = std::fs::read(&p).unwrap();
        // The PNG encoder refuses a zero width after the file was created: a write that fails
        // half way. The previous image must survive it, and the temporary must go.
        let err = write_image(&p, &Image::new(0, 4, 3, 0.5)).unwrap_err();
        assert!(err.to_string().contains("out.png"), "{err}");
        assert!(!err.to_string().contains("lumo-tmp"), "{err}");
        assert_eq!(std::fs::read(&p).unwrap(), before);
        assert_eq!(names(&dir), ["out.png"]);
        std::fs::remove_dir_all(&dir).ok();
    }

    fn gradient(channels: usize) -> Image {
        let (w, h) = (7, 5);
        let data = (0..w * h * channels)
            .map(|i| i as f32 / (w * h * channels) as f32)
            .collect();
        Image::from_vec(w, h, channels, data)
    }

    #[test]
    fn float_formats_round_trip_exactly() {
        let dir = std::env::temp_dir().join(format!("lumo-image-rt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for ext in ["exr", "pfm"] {
            for channels in [1, 3] {
                let img = gradient(channels);
                let p = dir.join(format!("t{channels}.{ext}"));
                write_image(&p, &img).unwrap();
                let back = read_image(&p).unwrap();
                assert_eq!(back, img, "{ext} with {channels} channels");
            }
        }
        let img = gradient(3);
        let p = dir.join("t.png");
        write_image(&p, &img).unwrap();
        let back = read_image(&p).unwrap();
        for (a, b) in img.data.iter().zip(&back.data) {
            assert!((a - b).abs() < 0.01, "{a} vs {b}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn exr_files_are_byte_identical_for_the_same_image() {
        // Big enough for many 64×64 tiles, so parallel compression finishes them out of order.
        let (w, h) = (300, 260);
        let data = (0..w * h * 3)
            .map(|i| ((i * 7919) % 1000) as f32 / 999.0)
            .collect();
        let img = Image::from_vec(w, h, 3, data);
        let dir = std::env::temp_dir().join(format!("lumo-image-det-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let first = dir.join("a.exr");
        write_image(&first, &img).unwrap();
        let want = std::fs::read(&first).unwrap();
        for k in 0..8 {
            let p = dir.join(format!("b{k}.exr"));
            write_image(&p, &img).unwrap();
            assert!(std::fs::read(&p).unwrap() == want, "write {k} differs");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn pfm_reads_big_endian_bottom_row_first_and_rejects_huge_sizes() {
        let dir = std::env::temp_dir();
        // 2×2 grey, big-endian (positive scale), rows stored bottom to top.
        let mut bytes = b"Pf\n2 2\n1.0\n".to_vec();
        for v in [3.0f32, 4.0, 1.0, 2.0] {
            bytes.extend_from_slice(&v.to_be_bytes());
        }
        let p = dir.join(format!("lumo-be-{}.pfm", std::process::id()));
        std::fs::write(&p, &bytes).unwrap();
        let img = read_image(&p).unwrap();
        assert_eq!((img.width, img.height, img.channels), (2, 2, 1));
        assert_eq!(img.data, vec![1.0, 2.0, 3.0, 4.0]);
        // A header whose size overflows is an error, not a panic or a wrapped size.
        std::fs::write(&p, b"PF\n9999999999999 9999999999999\n-1\n").unwrap();
        let e = read_image(&p).unwrap_err();
        assert!(e.to_string().contains("too large"), "{e}");
        std::fs::remove_file(&p).ok();
    }

    #[test]
    fn errors_name_the_file() {
        let e = read_image(Path::new("/nonexistent/x.exr")).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/x.exr"));
        let e = read_image(Path::new("x.tiff")).unwrap_err();
        assert!(e.to_string().contains("unsupported"));
        let dir = std::env::temp_dir();
        let p = dir.join(format!("lumo-bad-{}.pfm", std::process::id()));
        std::fs::write(&p, b"PF\n3 3\n-1\nshort").unwrap();
        let e = read_image(&p).unwrap_err();
        assert!(e.to_string().contains("truncated"), "{e}");
        std::fs::remove_file(&p).ok();
    }
}
