use std::fmt;
use std::path::PathBuf;

/// Everything that can go wrong reading, writing or combining images.
///
/// Every message names the file once, says what is wrong once and, where there is one, how to
/// fix it. The OS error of [`ImageError::Io`] is part of the message and deliberately not
/// returned by [`std::error::Error::source`]: printers that walk the source chain (anyhow's
/// `{:#}`) would otherwise print it twice. That is why this type implements `Display` and
/// `Error` by hand instead of deriving them with thiserror, which always chains a field named
/// `source`.
#[derive(Debug)]
pub enum ImageError {
    /// The file could not be opened, read or written.
    Io {
        /// The file involved.
        path: PathBuf,
        /// The underlying OS error.
        source: std::io::Error,
    },
    /// The path names something that is not a regular file (a directory, a pipe, a device):
    /// reading one could block forever or never end, so it is refused before it is opened.
    NotAFile {
        /// The path.
        path: PathBuf,
        /// What it is instead ("directory", "FIFO (named pipe)", "device", ...).
        kind: &'static str,
    },
    /// The file exists but its content is not a valid image of the expected format.
    Format {
        /// The file involved.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// The image has no pixels (a zero width or height).
    Empty {
        /// The file involved.
        path: PathBuf,
        /// Width in its header.
        width: usize,
        /// Height in its header.
        height: usize,
    },
    /// The header asks for more pixels than the budget ([`crate::max_image_pixels`]); refused
    /// before anything is allocated.
    TooLarge {
        /// The file involved.
        path: PathBuf,
        /// Width in its header.
        width: usize,
        /// Height in its header.
        height: usize,
        /// Size of the file in bytes.
        file_bytes: u64,
        /// The pixel budget in force.
        limit: u64,
    },
    /// Decoding the image would need more memory than this process may still allocate
    /// ([`crate::memory_available`]); refused before anything is allocated.
    OutOfMemory {
        /// The file involved.
        path: PathBuf,
        /// Width in its header.
        width: usize,
        /// Height in its header.
        height: usize,
        /// Bytes the decoding needs, about.
        need: u64,
        /// Bytes available.
        available: u64,
    },
    /// The extension is not one lumo reads or writes.
    UnsupportedExtension {
        /// The file involved.
        path: PathBuf,
    },
    /// Two images that must have the same size do not.
    SizeMismatch {
        /// Name of the first image.
        a: String,
        /// Width of the first image.
        aw: usize,
        /// Height of the first image.
        ah: usize,
        /// Name of the second image.
        b: String,
        /// Width of the second image.
        bw: usize,
        /// Height of the second image.
        bh: usize,
    },
}

impl fmt::Display for ImageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ImageError::Io { path, source } => {
                write!(f, "{}: {}", path.display(), describe_io_error(source))
            }
            ImageError::NotAFile { path, kind } => write!(
                f,
                "{}: is a {kind}, not a regular file; name an image file",
                path.display()
            ),
            ImageError::Format { path, reason } => write!(f, "{}: {reason}", path.display()),
            ImageError::Empty {
                path,
                width,
                height,
            } => write!(
                f,
                "{}: the image is empty ({width}x{height} pixels); save it with at least one \
                 pixel",
                path.display()
            ),
            ImageError::TooLarge {
                path,
                width,
                height,
                file_bytes,
                limit,
            } => write!(
                f,
                "{}: {width}x{height} pixels (in a file of {file_bytes} bytes) is over the image \
                 limit of {limit} pixels; if the image is genuine, raise the limit with \
                 {}=PIXELS",
                path.display(),
                crate::limits::MAX_PIXELS_VAR
            ),
            ImageError::OutOfMemory {
                path,
                width,
                height,
                need,
                available,
            } => write!(
                f,
                "{}: reading {width}x{height} pixels needs about {} of memory, but only {} is \
                 available; free memory or use a smaller image",
                path.display(),
                crate::memory::format_bytes(*need),
                crate::memory::format_bytes(*available),
            ),
            ImageError::UnsupportedExtension { path } => write!(
                f,
                "{}: unsupported image extension (use .exr, .pfm or .png)",
                path.display()
            ),
            ImageError::SizeMismatch {
                a,
                aw,
                ah,
                b,
                bw,
                bh,
            } => write!(f, "size mismatch: {a} is {aw}x{ah} but {b} is {bw}x{bh}"),
        }
    }
}

impl std::error::Error for ImageError {}

impl ImageError {
    /// The same error naming `to` where it named `from`: writes go through a temporary file,
    /// and the user should read the name they asked for.
    pub(crate) fn with_path(mut self, from: &std::path::Path, to: &std::path::Path) -> Self {
        match &mut self {
            ImageError::Io { path, .. }
            | ImageError::NotAFile { path, .. }
            | ImageError::Format { path, .. }
            | ImageError::Empty { path, .. }
            | ImageError::TooLarge { path, .. }
            | ImageError::OutOfMemory { path, .. }
            | ImageError::UnsupportedExtension { path } => {
                if path == from {
                    *path = to.to_path_buf();
                }
            }
            ImageError::SizeMismatch { .. } => {}
        }
        self
    }
}

/// An I/O error as a short cause and, where there is an obvious one, a fix, without the
/// "(os error N)" suffix. For messages that name the path themselves.
pub fn describe_io_error(e: &std::io::Error) -> String {
    use std::io::ErrorKind;
    match e.kind() {
        ErrorKind::NotFound => "no such file; check the name and the directory".into(),
        ErrorKind::PermissionDenied => "permission denied; check the file's permissions".into(),
        ErrorKind::IsADirectory => "is a directory, not a file".into(),
        ErrorKind::UnexpectedEof => "the file ends early (truncated?)".into(),
        _ => {
            let text = e.to_string();
            match text.find(" (os error ") {
                Some(i) => text[..i].to_string(),
                None => text,
            }
        }
    }
}
