//! Writing a [`crate::Scene`] out in another renderer's format, so that a scene built in code
//! (lumo's built-in scenes) or loaded from glTF can be rendered by that renderer as it is.
//!
//! Only what the other format holds exactly is written; anything else is an
//! [`ExportError::Unsupported`] naming the item, never an approximation: the point of an
//! export is a like-for-like comparison.

mod mitsuba;
mod ply;

pub use mitsuba::write_mitsuba;

use std::path::PathBuf;

/// Why a scene could not be exported.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// Something in the scene has no exact counterpart in the target format.
    #[error("{what} cannot be written as Mitsuba 3 XML: {why}")]
    Unsupported {
        /// The item (material, light, mesh, camera) by name.
        what: String,
        /// What about it has no counterpart.
        why: String,
    },
    /// A file could not be written.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

impl ExportError {
    fn unsupported(what: impl Into<String>, why: impl Into<String>) -> Self {
        ExportError::Unsupported {
            what: what.into(),
            why: why.into(),
        }
    }
}
