//! Scene files: Mitsuba 3 XML, glTF 2.0 (.gltf, .glb), OBJ/MTL and PLY, read into a [`Scene`].
//!
//! [`load_scene`] picks the reader by extension and returns the scene, the warnings (what was
//! ignored or approximated, with file and line) and the render settings the file asks for,
//! which command-line options override.

mod check;
mod defaults;
mod error;
mod gltf;
mod gltf_refs;
mod images;
mod materials;
mod mitsuba;
mod obj;
mod ply;

use std::path::Path;

pub use error::{Diagnostics, LoadError, Location, Warning, MAX_WARNINGS};

use crate::{AnimatedScene, Scene};

/// How to load a scene file.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// `name=value` definitions for Mitsuba's `$name` parameters; they win over `<default>`.
    pub defines: Vec<(String, String)>,
    /// Turn warnings into errors.
    pub strict: bool,
    /// glTF: which camera (index into the file's camera list); the first one when `None`.
    pub camera: Option<usize>,
    /// glTF: animation time in seconds at which node transforms are evaluated (0 when `None`).
    pub time: Option<f32>,
}

/// Render settings a scene file asks for; `None` where it says nothing.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FileSettings {
    /// Samples per pixel.
    pub spp: Option<u32>,
    /// Longest path depth (Mitsuba convention).
    pub max_depth: Option<u32>,
    /// Depth from which Russian roulette may end paths.
    pub rr_depth: Option<u32>,
    /// Image size (width, height).
    pub size: Option<(usize, usize)>,
    /// Random seed.
    pub seed: Option<u32>,
}

/// A loaded scene file.
#[derive(Clone, Debug)]
pub struct LoadedScene {
    /// The scene, validated.
    pub scene: Scene,
    /// What was ignored or approximated.
    pub warnings: Vec<Warning>,
    /// Render settings from the file.
    pub settings: FileSettings,
    /// The node hierarchy and its clips (glTF); `scene` is already posed at
    /// [`LoadOptions::time`].
    pub animation: Option<AnimatedScene>,
}

/// The formats [`load_scene`] reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneFormat {
    /// Mitsuba 3 XML.
    Mitsuba,
    /// glTF 2.0, JSON or binary.
    Gltf,
    /// Wavefront OBJ (with MTL).
    Obj,
    /// Stanford PLY.
    Ply,
}

impl SceneFormat {
    /// The format named by `path`'s extension, if lumo reads it.
    pub fn from_path(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "xml" => Some(Self::Mitsuba),
            "gltf" | "glb" => Some(Self::Gltf),
            "obj" => Some(Self::Obj),
            "ply" => Some(Self::Ply),
            _ => None,
        }
    }
}

/// Loads the scene file at `path` (format by extension).
pub fn load_scene(path: &Path, options: &LoadOptions) -> Result<LoadedScene, LoadError> {
    let format = SceneFormat::from_path(path).ok_or_else(|| LoadError::UnknownFormat {
        path: path.to_path_buf(),
    })?;
    let mut diag = Diagnostics::new(options.strict);
    let mut settings = FileSettings::default();
    let mut animation = None;
    if format != SceneFormat::Gltf && (options.camera.is_some() || options.time.is_some()) {
        diag.warn(
            Location::file(path),
            "--camera and --time apply to glTF scenes only; ignored",
        )?;
    }
    let scene = match format {
        SceneFormat::Mitsuba => mitsuba::load(path, options, &mut diag, &mut settings)?,
        SceneFormat::Gltf => gltf::load(path, options, &mut diag, &mut settings, &mut animation)?,
        SceneFormat::Obj => defaults::lone_mesh_scene(path, obj::load(path, &mut diag)?),
        SceneFormat::Ply => defaults::lone_mesh_scene(path, ply::load(path, &mut diag)?),
    };
    finish(path, scene, diag, settings, animation)
}

/// Loads a Mitsuba XML scene from `text`, as if it had been read from the file `path` (which
/// is only used in messages and need not exist).
///
/// Nothing else is read from disk: an `<include>`, a mesh or a texture file named in `text` is
/// an error at its element. This keeps in-memory scenes (and fuzzed input) self-contained.
pub fn load_mitsuba_str(
    text: &str,
    path: &Path,
    options: &LoadOptions,
) -> Result<LoadedScene, LoadError> {
    let mut diag = Diagnostics::new(options.strict);
    let mut settings = FileSettings::default();
    let scene = mitsuba::load_str(text, path, options, &mut diag, &mut settings)?;
    finish(path, scene, diag, settings, None)
}

/// Loads a PLY mesh from `bytes` as a lone-mesh scene, as if it had been read from the file
/// `path` (used in messages and for the mesh name only; it need not exist).
pub fn load_ply_bytes(
    bytes: &[u8],
    path: &Path,
    options: &LoadOptions,
) -> Result<LoadedScene, LoadError> {
    let mut diag = Diagnostics::new(options.strict);
    let mesh = ply::read_bytes(path, bytes, &mut diag)?;
    let scene = defaults::lone_mesh_scene(path, (vec![mesh], vec![]));
    finish(path, scene, diag, FileSettings::default(), None)
}

/// The checks every loaded scene goes through, whatever its format.
fn finish(
    path: &Path,
    scene: Scene,
    mut diag: Diagnostics,
    settings: FileSettings,
    animation: Option<AnimatedScene>,
) -> Result<LoadedScene, LoadError> {
    check::check_scene(path, &scene, &mut diag)?;
    scene.validate().map_err(|error| LoadError::Scene {
        path: path.to_path_buf(),
        error,
    })?;
    if scene.triangle_count() == 0 && scene.lights.is_empty() {
        diag.warn(
            Location::file(path),
            "the scene has no geometry and no lights; the image will be black",
        )?;
    }
    Ok(LoadedScene {
        scene,
        warnings: diag.warnings,
        settings,
        animation,
    })
}

/// Reads a whole regular file, naming it in the error (see [`read_limited`]).
pub(crate) fn read_file(path: &Path) -> Result<Vec<u8>, LoadError> {
    read_limited(path, u64::MAX).map_err(|e| match e {
        ReadError::Io(error) => LoadError::io(path, error),
        other => LoadError::invalid(Location::file(path), format!("cannot read: {other}")),
    })
}

/// Why [`read_limited`] failed; its message is the cause and a fix, without the path.
#[derive(Debug)]
pub(crate) enum ReadError {
    /// Opening or reading failed.
    Io(std::io::Error),
    /// Not a regular file: what it is.
    NotAFile(&'static str),
    /// Longer than the limit given.
    TooLarge {
        /// The limit in bytes.
        limit: u64,
    },
}

impl std::fmt::Display for ReadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReadError::Io(e) => f.write_str(&lumo_image::describe_io_error(e)),
            ReadError::NotAFile(kind) => {
                write!(f, "it is a {kind}, not a regular file; name a file")
            }
            ReadError::TooLarge { limit } => write!(f, "it is larger than {limit} bytes"),
        }
    }
}

/// Reads the regular file at `path`, at most `limit` bytes.
///
/// Anything but a regular file is refused from its metadata, before it is opened: opening a
/// FIFO blocks until something writes to it, and a device such as `/dev/zero` never ends. The
/// read itself stops at the limit too, so a file that grows while it is read cannot run on.
pub(crate) fn read_limited(path: &Path, limit: u64) -> Result<Vec<u8>, ReadError> {
    use std::io::Read;
    let meta = std::fs::metadata(path).map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotAFile(lumo_image::file_kind(
            &meta.file_type(),
        )));
    }
    if meta.len() > limit {
        return Err(ReadError::TooLarge { limit });
    }
    let file = std::fs::File::open(path).map_err(ReadError::Io)?;
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(ReadError::Io)?;
    if bytes.len() as u64 > limit {
        return Err(ReadError::TooLarge { limit });
    }
    Ok(bytes)
}
