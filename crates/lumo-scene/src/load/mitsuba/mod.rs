//! Mitsuba 3 XML scenes (the subset research scenes use; see docs/scenes.md).
//!
//! The file is read into an owned element tree ([`xml`]), then walked once: sensors give the
//! camera and film, integrators the depth settings, shapes meshes with materials made of their
//! BSDF and area emitter, emitters the other lights.

mod bsdf;
mod depth;
mod medium;
mod objects;
pub(crate) mod presets;
mod props;
mod spectrum;
mod spectrum_plugins;
mod xml;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::Vec3;

use self::props::Props;
use self::xml::Element;
use super::images::ImageCache;
use super::{defaults, Diagnostics, FileSettings, LoadError, LoadOptions, Location};
use lumo_spectrum::Tabulated;

use crate::{BsdfSpec, Material, Scene, Spectra, Texture};

/// Deepest nesting of BSDFs, textures and integrators inside each other (counting `<ref>`s
/// followed). Real scenes nest a handful; the bound turns a `<ref>` cycle into an error
/// instead of endless recursion.
const MAX_PLUGIN_DEPTH: usize = 32;

/// Loads a Mitsuba XML scene.
pub(crate) fn load(
    path: &Path,
    options: &LoadOptions,
    diag: &mut Diagnostics,
    settings: &mut FileSettings,
) -> Result<Scene, LoadError> {
    let root = xml::read_tree(path, &options.defines, diag)?;
    convert(path, &root, diag, settings, true)
}

/// Loads a Mitsuba XML scene from `text` (as if read from `path`) without reading any other
/// file: includes, meshes and images it names are errors.
pub(crate) fn load_str(
    text: &str,
    path: &Path,
    options: &LoadOptions,
    diag: &mut Diagnostics,
    settings: &mut FileSettings,
) -> Result<Scene, LoadError> {
    let root = xml::read_tree_str(text, path, &options.defines, diag)?;
    convert(path, &root, diag, settings, false)
}

/// Turns the element tree of `path` into a scene; `files` allows reading the meshes and
/// images it names.
fn convert(
    path: &Path,
    root: &Element,
    diag: &mut Diagnostics,
    settings: &mut FileSettings,
    files: bool,
) -> Result<Scene, LoadError> {
    let mut ids = HashMap::new();
    index_ids(root, &mut ids)?;
    let mut b = Builder {
        diag,
        settings,
        ids,
        images: ImageCache::default(),
        scene: defaults::empty_scene(path),
        bsdfs: HashMap::new(),
        spectra: Spectra::default(),
        emission_spectrum: None,
        materials: HashMap::new(),
        textures: HashMap::new(),
        groups: HashMap::new(),
        media: HashMap::new(),
        has_camera: false,
        has_environment: false,
        proxy_triangles: 0,
        root_dir: path.parent().unwrap_or(Path::new("")).to_path_buf(),
        files,
        depth: 0,
    };
    let props = Props::new(root);
    // Declared BSDFs become materials first, in file order, so material indices follow the file.
    for (i, el) in props.nested() {
        // A null BSDF makes no material: its shapes are invisible boundaries (medium.rs).
        if el.tag == "bsdf" && el.attr("type") != Some("null") {
            props.mark(i);
            b.material(Some(el), Vec3::ZERO, None)?;
        }
    }
    for (i, el) in props.nested() {
        props.mark(i);
        match el.tag.as_str() {
            "bsdf" => {}
            "medium" => {
                b.medium(el)?;
            }
            "texture" => {
                b.texture(el)?;
            }
            "sensor" => b.sensor(el)?,
            "integrator" => b.integrator(el)?,
            "shape" => b.shape(el)?,
            "emitter" => b.emitter(el)?,
            _ => b.diag.warn(
                el.at(),
                format!("{} is not supported by lumo and was ignored", el.describe()),
            )?,
        }
    }
    // The image cache cannot reach the diagnostics; its warnings (NaN or negative pixels in an
    // envmap or texture) are passed on here.
    for w in b.images.take_warnings() {
        b.diag.warn(w.at, w.message)?;
    }
    props.finish(b.diag)?;
    if !b.has_camera {
        let (lo, hi) = b.scene.bounds();
        b.scene.camera = defaults::framing_camera(lo, hi);
        b.diag.warn(
            Location::file(path),
            "the scene has no <sensor>; using a camera that frames the whole scene",
        )?;
    }
    let has_area = b.scene.materials.iter().any(Material::is_emissive);
    if !has_area && b.scene.lights.is_empty() {
        b.diag.warn(
            Location::file(path),
            "the scene has no emitters; the image will be black",
        )?;
    }
    Ok(b.scene)
}

/// Every element with an `id`, for `<ref>`.
fn index_ids<'a>(el: &'a Element, ids: &mut HashMap<String, &'a Element>) -> Result<(), LoadError> {
    for c in &el.children {
        if c.tag != "ref" {
            if let Some(id) = c.attr("id") {
                if let Some(prev) = ids.insert(id.to_string(), c) {
                    return Err(LoadError::invalid(
                        c.at(),
                        format!("id {id:?} is already used at line {}", prev.line),
                    ));
                }
            }
        }
        index_ids(c, ids)?;
    }
    Ok(())
}

/// State of one scene conversion.
pub(super) struct Builder<'a, 'd> {
    diag: &'d mut Diagnostics,
    settings: &'d mut FileSettings,
    ids: HashMap<String, &'a Element>,
    images: ImageCache,
    scene: Scene,
    /// Converted BSDFs by element address (a BSDF referenced twice is converted once).
    bsdfs: HashMap<usize, (String, BsdfSpec, Spectra)>,
    /// Spectral data of the BSDF being converted (and of its nested BSDFs), moved into its
    /// material.
    spectra: Spectra,
    /// The radiance spectrum of the area emitter read last, moved into the next material.
    emission_spectrum: Option<Arc<Tabulated>>,
    /// Material index by (BSDF element address or 0 for the default, emission bits).
    materials: HashMap<(usize, [u32; 3], usize, usize), usize>,
    /// Converted textures by element address.
    textures: HashMap<usize, Texture>,
    /// Mesh indices of each converted shapegroup, by element address.
    groups: HashMap<usize, Vec<usize>>,
    /// Converted media by element address (index into the scene's media).
    media: HashMap<usize, usize>,
    has_camera: bool,
    has_environment: bool,
    /// Proxy triangles of the exact shapes so far (see `objects::PROXY_TRIANGLE_BUDGET`).
    proxy_triangles: usize,
    /// Directory of the top-level scene file.
    root_dir: PathBuf,
    /// Whether files named in the scene may be read (false for in-memory scenes).
    files: bool,
    /// Plugins being converted inside each other right now (see [`MAX_PLUGIN_DEPTH`]).
    depth: usize,
}

impl<'a> Builder<'a, '_> {
    /// Runs `convert` for plugin `el` one nesting level deeper; fails past
    /// [`MAX_PLUGIN_DEPTH`], which only a `<ref>` cycle or a runaway file reaches.
    fn nested<T>(
        &mut self,
        el: &Element,
        convert: impl FnOnce(&mut Self) -> Result<T, LoadError>,
    ) -> Result<T, LoadError> {
        if self.depth >= MAX_PLUGIN_DEPTH {
            return Err(LoadError::invalid(
                el.at(),
                format!(
                    "{} is nested more than {MAX_PLUGIN_DEPTH} plugins deep; a <ref> probably \
                     refers back to a plugin that contains it (a cycle)",
                    el.describe()
                ),
            ));
        }
        self.depth += 1;
        let result = convert(self);
        self.depth -= 1;
        result
    }

    /// The element a `<ref>` points to (or `el` itself).
    fn resolve(&self, el: &'a Element) -> Result<&'a Element, LoadError> {
        if el.tag != "ref" {
            return Ok(el);
        }
        let id = el.required("id")?;
        self.ids.get(id).copied().ok_or_else(|| {
            LoadError::invalid(
                el.at(),
                format!("<ref id=\"{id}\"> refers to nothing; no element has id=\"{id}\""),
            )
        })
    }

    /// A file named in `el`: relative to the XML file that names it, or else (as Mitsuba
    /// resolves paths in included files) to the top-level scene's directory. An error for
    /// in-memory scenes, which read no files.
    fn file_path(&self, el: &Element, name: &str) -> Result<PathBuf, LoadError> {
        if !self.files {
            return Err(LoadError::invalid(
                el.at(),
                format!(
                    "{} names the file {name:?}; a scene loaded from memory reads no files",
                    el.describe()
                ),
            ));
        }
        let own = el.file.parent().unwrap_or(Path::new("")).join(name);
        if own.exists() {
            return Ok(own);
        }
        let top = self.root_dir.join(name);
        Ok(if top.exists() { top } else { own })
    }

    /// The material made of BSDF `bsdf` (Mitsuba's default when `None`: diffuse 0.5, or
    /// black when `emission` is not zero) and `emission` (per texel where `emission_map` is
    /// given).
    fn material(
        &mut self,
        bsdf: Option<&'a Element>,
        emission: Vec3,
        emission_map: Option<Arc<Texture>>,
    ) -> Result<usize, LoadError> {
        let emission_spectrum = self.emission_spectrum.take();
        let key = (
            bsdf.map_or(0, |e| e as *const Element as usize),
            emission.to_array().map(f32::to_bits),
            emission_map.as_ref().map_or(0, |t| Arc::as_ptr(t) as usize),
            emission_spectrum
                .as_ref()
                .map_or(0, |t| Arc::as_ptr(t) as usize),
        );
        if let Some(&m) = self.materials.get(&key) {
            return Ok(m);
        }
        // Mitsuba's BSDFs are one-sided unless wrapped in `twosided` (its default BSDF too).
        let two_sided = match bsdf {
            Some(el) => self.two_sided(el)?,
            None => false,
        };
        self.spectra = Spectra::default();
        let (name, bsdf) = match bsdf {
            Some(el) => self.bsdf(el)?,
            // Mitsuba 3's default: grey diffuse, but black on an emitting shape (its
            // area light reflects nothing unless the file gives it a BSDF).
            None => (
                "default".to_string(),
                BsdfSpec::Diffuse {
                    reflectance: Texture::Constant(if emission == Vec3::ZERO {
                        Vec3::splat(0.5)
                    } else {
                        Vec3::ZERO
                    }),
                },
            ),
        };
        let mut spectra = std::mem::take(&mut self.spectra);
        spectra.emission = emission_spectrum;
        let index = self.scene.add_material(Material {
            name,
            bsdf,
            emission,
            two_sided,
            emission_map,
            spectra,
        });
        self.materials.insert(key, index);
        Ok(index)
    }
}
