use std::path::PathBuf;

/// Everything that can go wrong reading, writing or combining images.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// The file could not be opened, read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file involved.
        path: PathBuf,
        /// The underlying OS error.
        source: std::io::Error,
    },
    /// The file exists but its content is not a valid image of the expected format.
    #[error("{path}: {reason}")]
    Format {
        /// The file involved.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// The extension is not one lumo reads or writes.
    #[error("{path}: unsupported image extension (use .exr, .pfm or .png)")]
    UnsupportedExtension {
        /// The file involved.
        path: PathBuf,
    },
    /// Two images that must have the same size do not.
    #[error("size mismatch: {a} is {aw}x{ah} but {b} is {bw}x{bh}")]
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
