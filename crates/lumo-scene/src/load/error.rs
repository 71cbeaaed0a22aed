//! Errors and warnings of the scene-file loaders, each naming the file and where in it.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::SceneError;

/// A place in a scene file: the file, and a line (text formats) or an item such as a glTF
/// accessor or a PLY element (binary formats).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Location {
    /// The file.
    pub file: PathBuf,
    /// 1-based line number, where the format has lines.
    pub line: Option<usize>,
    /// What inside the file (element, accessor, node), where that is more useful than a line.
    pub item: Option<String>,
}

impl Location {
    /// The whole file.
    pub fn file(file: &Path) -> Self {
        Self {
            file: file.to_path_buf(),
            line: None,
            item: None,
        }
    }

    /// A line of `file`.
    pub fn line(file: &Path, line: usize) -> Self {
        Self {
            file: file.to_path_buf(),
            line: Some(line),
            item: None,
        }
    }

    /// An item (accessor, element) of `file`.
    pub fn item(file: &Path, item: impl Into<String>) -> Self {
        Self {
            file: file.to_path_buf(),
            line: None,
            item: Some(item.into()),
        }
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
        }
        if let Some(item) = &self.item {
            write!(f, " ({item})")?;
        }
        Ok(())
    }
}

/// Something in a scene file that lumo ignored or approximated; the scene still renders.
#[derive(Clone, Debug, PartialEq)]
pub struct Warning {
    /// Where.
    pub at: Location,
    /// What was ignored or approximated, and what lumo did instead.
    pub message: String,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: warning: {}", self.at, self.message)
    }
}

/// A scene file that cannot be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file (or one it refers to) cannot be read.
    #[error("{}: cannot read: {}", path.display(), lumo_image::describe_io_error(error))]
    Io {
        /// The file.
        path: PathBuf,
        /// Why (printed in the message, so not chained as a source).
        error: std::io::Error,
    },
    /// The extension names no format lumo reads.
    #[error(
        "{}: unknown scene format; lumo reads Mitsuba 3 XML (.xml), glTF 2.0 (.gltf, .glb), \
         OBJ (.obj) and PLY (.ply), or a built-in scene name",
        path.display()
    )]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// Malformed or unsupported content.
    #[error("{at}: {message}")]
    Invalid {
        /// Where.
        at: Location,
        /// What is wrong and how to fix it.
        message: String,
    },
    /// A warning raised to an error by strict mode.
    #[error("{at}: {message} (error because of --strict)")]
    Strict {
        /// Where.
        at: Location,
        /// The warning's text.
        message: String,
    },
    /// The loaded scene fails validation (index out of range, non-finite data, ...).
    #[error("{}: {error}", path.display())]
    Scene {
        /// The scene file.
        path: PathBuf,
        /// The validation error (printed in the message, so not chained as a source).
        error: SceneError,
    },
}

impl LoadError {
    /// An [`LoadError::Invalid`] at `at`.
    pub fn invalid(at: Location, message: impl Into<String>) -> Self {
        LoadError::Invalid {
            at,
            message: message.into(),
        }
    }

    /// An [`LoadError::Io`] for `path`.
    pub fn io(path: &Path, error: std::io::Error) -> Self {
        LoadError::Io {
            path: path.to_path_buf(),
            error,
        }
    }
}

/// Collects warnings; in strict mode the first one becomes an error.
#[derive(Debug, Default)]
pub struct Diagnostics {
    /// Raise warnings as errors.
    pub strict: bool,
    /// Warnings so far (at most [`MAX_WARNINGS`] and a last one counting the rest).
    pub warnings: Vec<Warning>,
    /// Warnings past [`MAX_WARNINGS`], counted in the last warning instead of kept.
    suppressed: usize,
}

/// Warnings kept per load: a file of a million odd lines (`mtllib /etc/passwd`) gave a million
/// warnings; past this many, one last warning counts the rest.
pub const MAX_WARNINGS: usize = 100;

impl Diagnostics {
    /// No warnings yet; `strict` raises them as errors.
    pub fn new(strict: bool) -> Self {
        Self {
            strict,
            warnings: Vec::new(),
            suppressed: 0,
        }
    }

    /// Records a warning, or fails in strict mode.
    pub fn warn(&mut self, at: Location, message: impl Into<String>) -> Result<(), LoadError> {
        let message = message.into();
        if self.strict {
            return Err(LoadError::Strict { at, message });
        }
        if self.warnings.len() < MAX_WARNINGS {
            self.warnings.push(Warning { at, message });
            return Ok(());
        }
        self.suppressed += 1;
        let count = Warning {
            at: Location::file(&at.file),
            message: format!(
                "{} more warning(s) not shown (only the first {MAX_WARNINGS} are)",
                self.suppressed
            ),
        };
        if self.suppressed == 1 {
            self.warnings.push(count);
        } else if let Some(last) = self.warnings.last_mut() {
            *last = count;
        }
        Ok(())
    }
}
