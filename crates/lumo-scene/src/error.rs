/// A scene that cannot be rendered as given.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A mesh refers to a vertex that does not exist.
    #[error(
        "mesh {mesh:?}: triangle {triangle} uses vertex {index} but the mesh has {count} vertices"
    )]
    IndexOutOfRange {
        /// Mesh name.
        mesh: String,
        /// Triangle number.
        triangle: usize,
        /// The bad index.
        index: u32,
        /// Number of vertices.
        count: usize,
    },
    /// A vertex attribute holds NaN or infinity.
    #[error("mesh {mesh:?}: {attribute} {index} is not finite ({value})")]
    NonFinite {
        /// Mesh name.
        mesh: String,
        /// Which attribute (position, normal, uv).
        attribute: &'static str,
        /// Element index.
        index: usize,
        /// The value, printed.
        value: String,
    },
    /// Per-vertex attribute arrays of the wrong length.
    #[error("mesh {mesh:?}: {attribute} has {got} entries but the mesh has {expected} vertices")]
    AttributeLength {
        /// Mesh name.
        mesh: String,
        /// Which attribute.
        attribute: &'static str,
        /// Its length.
        got: usize,
        /// Vertex count.
        expected: usize,
    },
    /// Something refers to a mesh or material that does not exist.
    #[error("{what} refers to {kind} {index}, but the scene has {count}")]
    BadReference {
        /// The referring item.
        what: String,
        /// "mesh" or "material".
        kind: &'static str,
        /// The index.
        index: usize,
        /// How many exist.
        count: usize,
    },
    /// A scene name that is not built in.
    #[error("unknown scene {name:?}; built-in scenes: {available} (see `lumo render --list`)")]
    UnknownBuiltin {
        /// The name asked for.
        name: String,
        /// The names that exist.
        available: String,
    },
    /// An invalid parameter value.
    #[error("{0}")]
    Invalid(String),
}
