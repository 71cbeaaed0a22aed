//! glTF 2.0 (.gltf with external or embedded buffers, .glb): meshes placed by the node
//! hierarchy, cameras, metallic-roughness materials, `KHR_lights_punctual`,
//! `KHR_materials_emissive_strength`, `KHR_texture_transform` and node animations.

mod alpha;
mod attributes;
mod buffers;
mod extensions;
mod json_texture;
mod materials;
mod morph_anim;
mod skin;
mod sparse;

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use glam::{Affine2, Mat2, Quat, Vec2, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};

use super::check::{check_emission, check_light, check_mesh};
use super::gltf_refs::check_references;
use super::images::decode_image;
use super::{
    defaults, read_file, read_limited, Diagnostics, FileSettings, LoadError, LoadOptions, Location,
};
use crate::animation::{
    AnimatedNode, AnimatedProperty, AnimatedScene, Animation, AnimationChannel, Interpolation,
    NodeItem,
};
use crate::{
    BsdfSpec, Camera, FovAxis, Lens, Light, Material, Mesh, Scene, Texture, TextureFilter, WrapMode,
};
use buffers::{load_buffers, uri_bytes};

/// Extensions lumo reads; a file that requires any other one is refused.
const SUPPORTED: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_clearcoat",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_sheen",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_unlit",
    "KHR_materials_volume",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
];

/// Loads a glTF scene; its node hierarchy and clips go to `animation`.
///
/// The `gltf` crate trusts its own validation and unwraps in accessors; its validation misses
/// some malformed inputs (found by tests/integration/robustness.rs), so a panic inside it is caught here
/// and reported as a malformed file rather than taking the process down.
pub(crate) fn load(
    path: &Path,
    options: &LoadOptions,
    diag: &mut Diagnostics,
    settings: &mut FileSettings,
    animation: &mut Option<AnimatedScene>,
) -> Result<Scene, LoadError> {
    let run =
        std::panic::AssertUnwindSafe(|| load_unguarded(path, options, diag, settings, animation));
    std::panic::catch_unwind(run).unwrap_or_else(|panic| {
        let what = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        Err(LoadError::invalid(
            Location::file(path),
            format!("malformed glTF that the glTF parser failed on ({what})"),
        ))
    })
}

fn load_unguarded(
    path: &Path,
    options: &LoadOptions,
    diag: &mut Diagnostics,
    settings: &mut FileSettings,
    animation: &mut Option<AnimatedScene>,
) -> Result<Scene, LoadError> {
    let bytes = read_file(path)?;
    let invalid = |e: gltf::Error| {
        let text = e.to_string();
        // serde reads an integer beyond u64 as a float and says "invalid type: floating
        // point", which reads as if a fraction had been written (a 2^64 byteOffset).
        let text = match text.split_once("invalid type: floating point `") {
            Some((_, rest)) if text.contains("expected u64") => {
                let value = rest.split('`').next().unwrap_or("");
                let at = rest.rsplit_once(" at ").map_or("", |(_, at)| at);
                format!(
                    "the integer {value} at {at} is beyond 2^64 − 1; indices, counts, offsets \
                     and lengths must be whole numbers that fit the file"
                )
            }
            _ => text,
        };
        LoadError::invalid(
            Location::file(path),
            format!("not a valid glTF 2.0 file: {text}"),
        )
    };
    // Parse, check every index, and only then let the gltf crate validate (see gltf_refs).
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes).map_err(invalid)?;
    let blob = gltf.blob;
    let mut root = gltf.document.into_json();
    check_references(path, &root)?;
    // Before the gltf crate's validation, which refuses these with its own terser message.
    for ext in &root.extensions_required {
        if !SUPPORTED.contains(&ext.as_str()) {
            return Err(LoadError::invalid(
                Location::item(path, "extensionsRequired"),
                format!(
                    "the file requires extension {ext}, which lumo does not support (supported: {})",
                    SUPPORTED.join(", ")
                ),
            ));
        }
    }
    // The gltf crate's validation refuses required extensions it has no reader for, which
    // lumo reads itself (KHR_materials_specular from the JSON, KHR_mesh_quantization's
    // attributes in attributes.rs): lumo has checked them above.
    root.extensions_required
        .retain(|e| gltf::json::extensions::ENABLED_EXTENSIONS.contains(&e.as_str()));
    let document = gltf::Document::from_json(root).map_err(invalid)?;
    let doc = &document;
    for ext in doc.extensions_used() {
        if !SUPPORTED.contains(&ext) {
            diag.warn(
                Location::item(path, "extensionsUsed"),
                format!("extension {ext} is not supported; its data is ignored"),
            )?;
        }
    }
    let buffers = load_buffers(path, doc, blob.as_deref())?;
    let mut r = GltfReader {
        path,
        doc,
        diag,
        buffers,
        images: HashMap::new(),
        mips: HashMap::new(),
        scene: defaults::empty_scene(path),
        mesh_map: HashMap::new(),
        material_map: HashMap::new(),
        vertex_alpha_map: HashMap::new(),
        rig: AnimatedScene::default(),
        cameras: Vec::new(),
        node_index: HashMap::new(),
        deform: Default::default(),
        uv_set: 0,
    };
    let gscene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| LoadError::invalid(Location::file(path), "the file has no scene"))?;
    check_tree(path, doc, &gscene)?;
    for node in gscene.nodes() {
        r.node(&node, None, 0)?;
    }
    r.deformers(doc)?;
    r.animations(doc)?;
    let has_anim = !r.rig.animations.is_empty();
    if options.time.is_some() && !has_anim {
        r.diag.warn(
            Location::file(path),
            "--time given but the file has no animations",
        )?;
    }
    // Camera: the requested one, else the first, else one framing the scene.
    let cameras = std::mem::take(&mut r.cameras);
    let chosen = match options.camera {
        Some(n) => Some(*cameras.get(n).ok_or_else(|| {
            LoadError::invalid(
                Location::item(path, "cameras"),
                format!(
                    "--camera {n}: the scene has {} camera node(s) (numbered from 0)",
                    cameras.len()
                ),
            )
        })?),
        None => cameras.first().copied(),
    };
    if let Some((node, camera)) = chosen {
        r.rig.items.push((node, NodeItem::Camera));
        r.camera(doc, camera, settings)?;
    }
    let mut rig = std::mem::take(&mut r.rig);
    rig.pose(&mut r.scene, options.time);
    if let Some((_, camera)) = chosen.filter(|_| !r.scene.camera.is_well_formed()) {
        // A zero scale on the camera's node (or one of its parents) collapses its view
        // direction: every ray would be NaN, a black image.
        return Err(LoadError::invalid(
            Location::item(path, format!("camera {camera}")),
            "the camera node's transform is singular or not finite (a zero scale, or up along \
             the view direction): give the node and its parents a non-zero scale",
        ));
    }
    let mut scene = r.scene;
    extensions::attach_volume_media(&mut scene);
    if chosen.is_none() {
        let (lo, hi) = scene.bounds();
        scene.camera = defaults::framing_camera(lo, hi);
    }
    if scene.lights.is_empty() && !scene.materials.iter().any(Material::is_emissive) {
        // glTF assets usually expect the viewer's environment light.
        scene.lights = defaults::sky_lights();
    }
    rig.items
        .retain(|(_, item)| *item != NodeItem::Camera || chosen.is_some());
    *animation = Some(rig);
    Ok(scene)
}

struct GltfReader<'p, 'd> {
    path: &'p Path,
    /// The document, for the textures that extension JSON names by index.
    doc: &'p gltf::Document,
    diag: &'d mut Diagnostics,
    buffers: Vec<Vec<u8>>,
    /// Decoded images by (image index, raw).
    images: HashMap<(usize, bool), Arc<lumo_image::Image>>,
    /// Mip-maps of the decoded images, built once per image and colour space.
    mips: HashMap<(usize, bool), Arc<crate::MipMap>>,
    scene: Scene,
    /// lumo meshes of each glTF mesh.
    mesh_map: HashMap<usize, Vec<usize>>,
    /// lumo material of each glTF material (`None`: the default material).
    material_map: HashMap<Option<usize>, usize>,
    /// glTF material → its lumo material for primitives with vertex alpha (see
    /// `vertex_alpha_material`).
    vertex_alpha_map: HashMap<Option<usize>, usize>,
    rig: AnimatedScene,
    /// (node, camera index) in traversal order.
    cameras: Vec<(usize, usize)>,
    /// Rig node of each glTF node.
    node_index: HashMap<usize, usize>,
    /// Skins and morph targets waiting to become deformers.
    deform: skin::DeformState,
    /// The TEXCOORD set of the material being read (see attributes::uv_set).
    uv_set: u32,
}

/// Most mesh primitives the nodes of one glTF file may place (each becomes an instance of
/// about 200 bytes with its acceleration-structure share).
const MAX_INSTANCES: usize = 1 << 21;

/// Refuses a node hierarchy that is not a forest, as glTF requires: a node listed twice among
/// one node's children, a child of two nodes, or a scene root that is also a child (or listed
/// twice). Such a graph is walked once per path to each node, so a 1.5 KB file whose node i has
/// children [i+1, i+1] expanded to 2^24 instances (7.3 GB).
fn check_tree(path: &Path, doc: &gltf::Document, scene: &gltf::Scene) -> Result<(), LoadError> {
    let mut parent: Vec<Option<usize>> = vec![None; doc.nodes().len()];
    let fix = "glTF node hierarchies are trees: give each node at most one parent (copy the \
               node to place its mesh twice)";
    for node in doc.nodes() {
        for child in node.children() {
            let c = child.index();
            if let Some(first) = parent[c] {
                let how = if first == node.index() {
                    format!("is listed twice among node {first}'s children")
                } else {
                    format!("is a child of both node {first} and node {}", node.index())
                };
                return Err(LoadError::invalid(
                    Location::item(path, format!("node {c}")),
                    format!("{how}; {fix}"),
                ));
            }
            parent[c] = Some(node.index());
        }
    }
    // A tree visits each node once, yet nodes × primitives per mesh still multiply: a few
    // kilobytes of nodes sharing a mesh of many primitives.
    let instances: usize = doc
        .nodes()
        .filter_map(|n| n.mesh())
        .map(|m| m.primitives().len())
        .sum();
    if instances > MAX_INSTANCES {
        return Err(LoadError::invalid(
            Location::file(path),
            format!(
                "the nodes place {instances} mesh primitives, more than lumo's limit of \
                 {MAX_INSTANCES}; merge primitives or split the scene"
            ),
        ));
    }
    let mut root = vec![false; parent.len()];
    for node in scene.nodes() {
        let n = node.index();
        let how = if let Some(p) = parent[n] {
            format!(
                "is a root of scene {} and a child of node {p}",
                scene.index()
            )
        } else if std::mem::replace(&mut root[n], true) {
            format!("is listed twice among scene {}'s nodes", scene.index())
        } else {
            continue;
        };
        return Err(LoadError::invalid(
            Location::item(path, format!("node {n}")),
            format!("{how}; {fix}"),
        ));
    }
    Ok(())
}

/// Deepest node nesting accepted (the hierarchy must be a tree; this also stops cycles).
const MAX_DEPTH: usize = 256;

impl GltfReader<'_, '_> {
    fn node(
        &mut self,
        node: &gltf::Node,
        parent: Option<usize>,
        depth: usize,
    ) -> Result<(), LoadError> {
        if depth > MAX_DEPTH {
            return Err(LoadError::invalid(
                Location::item(self.path, format!("node {}", node.index())),
                "the node hierarchy is deeper than 256 levels or has a cycle",
            ));
        }
        let (t, r, s) = node.transform().decomposed();
        let (translation, scale) = (Vec3::from(t), Vec3::from(s));
        if !translation.is_finite() || !scale.is_finite() {
            return Err(LoadError::invalid(
                self.at(format!("node {}", node.index())),
                format!(
                    "translation {translation} or scale {scale} is not finite; fix the node's \
                     transform"
                ),
            ));
        }
        let rotation = match unit_quat(Vec4::from(r)) {
            Some(q) => q,
            None => {
                self.diag.warn(
                    self.at(format!("node {}", node.index())),
                    format!(
                        "rotation {r:?} is not a rotation (a unit quaternion x, y, z, w); \
                         using no rotation"
                    ),
                )?;
                Quat::IDENTITY
            }
        };
        let me = self.rig.nodes.len();
        self.rig.nodes.push(AnimatedNode {
            parent,
            translation,
            rotation,
            scale,
        });
        self.node_index.insert(node.index(), me);
        if let Some(mesh) = node.mesh() {
            let meshes = self.mesh(&mesh)?;
            self.place_mesh(node, &mesh, me, meshes)?;
        }
        if let Some(camera) = node.camera() {
            self.cameras.push((me, camera.index()));
        }
        if let Some(light) = node.light() {
            self.light(&light, me)?;
        }
        for child in node.children() {
            self.node(&child, Some(me), depth + 1)?;
        }
        Ok(())
    }

    fn at(&self, item: String) -> Location {
        Location::item(self.path, item)
    }

    /// Refuses accessors lumo cannot read safely: wrong type, or beyond their buffer (their
    /// sparse part included).
    fn check_accessor(
        &self,
        acc: &gltf::Accessor,
        dims: &[Dimensions],
        what: &str,
    ) -> Result<(), LoadError> {
        self.check_layout(acc, dims, what)?;
        if acc.data_type() != DataType::F32 && dims != [Dimensions::Scalar] && !acc.normalized() {
            return Err(LoadError::invalid(
                self.at(format!("accessor {} ({what})", acc.index())),
                format!(
                    "component type {:?} is not float or normalised",
                    acc.data_type()
                ),
            ));
        }
        Ok(())
    }

    /// [`Self::check_accessor`] without the component type check (for integer attributes).
    fn check_layout(
        &self,
        acc: &gltf::Accessor,
        dims: &[Dimensions],
        what: &str,
    ) -> Result<(), LoadError> {
        let at = self.at(format!("accessor {} ({what})", acc.index()));
        if !dims.contains(&acc.dimensions()) {
            return Err(LoadError::invalid(
                at,
                format!("has type {:?}; expected {dims:?}", acc.dimensions()),
            ));
        }
        if acc.count() == 0 {
            return Err(LoadError::invalid(at, "count is 0"));
        }
        self.check_sparse(acc, &at)?;
        let Some(view) = acc.view() else {
            // A sparse accessor without a view substitutes into zeros.
            if acc.sparse().is_some() {
                return Ok(());
            }
            return Err(LoadError::invalid(at, "has no buffer view"));
        };
        let elem = acc.size();
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(LoadError::invalid(
                at,
                format!("byteStride {stride} is smaller than an element ({elem} bytes)"),
            ));
        }
        // Saturating: offsets near 2^64 wrapped around and passed (or were reported as a
        // parser failure); a saturated sum is past any buffer and reported as such.
        let need = stride
            .saturating_mul(acc.count() - 1)
            .saturating_add(acc.offset())
            .saturating_add(elem);
        let buffer_len = self.buffers.get(view.buffer().index()).map_or(0, Vec::len);
        if need > view.length() {
            return Err(LoadError::invalid(
                at,
                format!(
                    "reads past the end of its data (needs {need} bytes of buffer view {}, which \
                     has {})",
                    view.index(),
                    view.length(),
                ),
            ));
        }
        if view.offset().saturating_add(view.length()) > buffer_len {
            return Err(LoadError::invalid(
                at,
                format!(
                    "reads past the end of its data (buffer view {} spans bytes {}..{} of \
                     buffer {}, which has {buffer_len})",
                    view.index(),
                    view.offset(),
                    view.offset() as u128 + view.length() as u128,
                    view.buffer().index()
                ),
            ));
        }
        Ok(())
    }

    /// The lumo meshes of a glTF mesh (one per triangle primitive).
    fn mesh(&mut self, mesh: &gltf::Mesh) -> Result<Vec<usize>, LoadError> {
        if let Some(m) = self.mesh_map.get(&mesh.index()) {
            return Ok(m.clone());
        }
        let mut out = Vec::new();
        for prim in mesh.primitives() {
            let label = format!("mesh {} primitive {}", mesh.index(), prim.index());
            let mode = prim.mode();
            if !matches!(
                mode,
                gltf::mesh::Mode::Triangles
                    | gltf::mesh::Mode::TriangleStrip
                    | gltf::mesh::Mode::TriangleFan
            ) {
                self.diag.warn(
                    self.at(label),
                    format!("{mode:?} primitives are not renderable; skipped"),
                )?;
                continue;
            }
            let pos_acc = prim.get(&gltf::Semantic::Positions).ok_or_else(|| {
                LoadError::invalid(self.at(label.clone()), "has no POSITION attribute")
            })?;
            use attributes::Quantized;
            self.check_attribute(
                &pos_acc,
                Dimensions::Vec3,
                "POSITION",
                Quantized::AnyInteger,
            )?;
            let normal_acc = prim.get(&gltf::Semantic::Normals);
            if let Some(a) = &normal_acc {
                self.check_attribute(a, Dimensions::Vec3, "NORMAL", Quantized::SignedNormalized)?;
            }
            // The one uv set a lumo mesh keeps: the one the material's textures read.
            let set = attributes::uv_set(&prim.material());
            let texcoord = format!("TEXCOORD_{set}");
            let uv_acc = prim.get(&gltf::Semantic::TexCoords(set));
            if let Some(a) = &uv_acc {
                self.check_attribute(a, Dimensions::Vec2, &texcoord, Quantized::AnyInteger)?;
            }
            let tangent_acc = prim.get(&gltf::Semantic::Tangents);
            if let Some(a) = &tangent_acc {
                self.check_attribute(a, Dimensions::Vec4, "TANGENT", Quantized::SignedNormalized)?;
            }
            if let Some(a) = prim.indices() {
                // The type first: a float accessor is wrong whatever its view holds.
                if a.data_type() == DataType::F32 {
                    return Err(LoadError::invalid(
                        self.at(format!("accessor {} (indices)", a.index())),
                        "indices must be unsigned integers",
                    ));
                }
                self.check_accessor(&a, &[Dimensions::Scalar], "indices")?;
            }
            if let Some(a) = prim.get(&gltf::Semantic::Colors(0)) {
                self.check_accessor(&a, &[Dimensions::Vec3, Dimensions::Vec4], "COLOR_0")?;
            }
            let buffers = &self.buffers;
            let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
            let positions: Vec<Vec3> = self
                .read_floats::<3>(&pos_acc)?
                .into_iter()
                .map(Vec3::from)
                .collect();
            let normals: Vec<Vec3> = match &normal_acc {
                Some(a) => self
                    .read_floats::<3>(a)?
                    .into_iter()
                    .map(Vec3::from)
                    .collect(),
                None => Vec::new(),
            };
            let uvs: Vec<Vec2> = match &uv_acc {
                Some(a) => self
                    .read_floats::<2>(a)?
                    .into_iter()
                    .map(Vec2::from)
                    .collect(),
                None => Vec::new(),
            };
            // w is ±1 by the specification; its sign is what matters.
            let tangents: Vec<Vec4> = match &tangent_acc {
                Some(a) => self
                    .read_floats::<4>(a)?
                    .into_iter()
                    .map(|[x, y, z, w]| Vec4::new(x, y, z, if w < 0.0 { -1.0 } else { 1.0 }))
                    .collect(),
                None => Vec::new(),
            };
            // COLOR_0 multiplies the base colour, and its alpha the opacity (MASK, BLEND).
            let colors: Vec<Vec3> = reader
                .read_colors(0)
                .map(|it| it.into_rgb_f32().map(Vec3::from).collect())
                .unwrap_or_default();
            let alphas = self.vertex_alpha(&prim);
            let flat: Vec<u32> = match reader.read_indices() {
                Some(it) => it.into_u32().collect(),
                None => (0..positions.len() as u32).collect(),
            };
            let indices = match mode {
                gltf::mesh::Mode::Triangles => {
                    flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
                }
                gltf::mesh::Mode::TriangleStrip => (2..flat.len())
                    .map(|i| {
                        if i % 2 == 0 {
                            [flat[i - 2], flat[i - 1], flat[i]]
                        } else {
                            [flat[i - 1], flat[i - 2], flat[i]]
                        }
                    })
                    .collect(),
                _ => (2..flat.len())
                    .map(|i| [flat[0], flat[i - 1], flat[i]])
                    .collect(),
            };
            let mut material = self.material(prim.material())?;
            if !alphas.is_empty() {
                material = self.vertex_alpha_material(&prim.material(), material)?;
            }
            // A base-colour texture needs texture coordinates to vary: without them every
            // point reads the texel at (0, 0).
            let textured = prim
                .material()
                .pbr_metallic_roughness()
                .base_color_texture()
                .is_some();
            if textured && uvs.is_empty() {
                self.diag.warn(
                    self.at(label.clone()),
                    format!(
                        "its material has a base-colour texture but the primitive has no \
                         {texcoord}; every point takes the texel at (0, 0)"
                    ),
                )?;
            }
            let mut m = Mesh {
                name: mesh
                    .name()
                    .map_or_else(|| label.clone(), |n| format!("{n}/{}", prim.index())),
                positions,
                normals,
                uvs,
                tangents,
                colors,
                alphas,
                indices,
                material,
                analytic: None,
            };
            for (attr, len) in [
                ("NORMAL", m.normals.len()),
                (texcoord.as_str(), m.uvs.len()),
                ("COLOR_0", m.colors.len()),
                ("COLOR_0 alpha", m.alphas.len()),
                ("TANGENT", m.tangents.len()),
            ] {
                if len != 0 && len != m.positions.len() {
                    return Err(LoadError::invalid(
                        self.at(label.clone()),
                        format!(
                            "{attr} has {len} entries but POSITION has {}",
                            m.positions.len()
                        ),
                    ));
                }
            }
            check_mesh(&mut m, &self.at(label.clone()), self.diag)?;
            self.scene.meshes.push(m);
            self.read_deform(mesh, &prim, &label, self.scene.meshes.len() - 1)?;
            out.push(self.scene.meshes.len() - 1);
        }
        self.mesh_map.insert(mesh.index(), out.clone());
        Ok(out)
    }

    fn light(
        &mut self,
        light: &gltf::khr_lights_punctual::Light,
        node: usize,
    ) -> Result<(), LoadError> {
        use gltf::khr_lights_punctual::Kind;
        // glTF's photometric intensities are taken as lumo's radiometric units one to one.
        let power = Vec3::from(light.color()) * light.intensity();
        let at = self.at(format!("light {}", light.index()));
        let range = self.light_range(light, &at)?;
        let l = match light.kind() {
            Kind::Point => Light::Point {
                position: Vec3::ZERO,
                intensity: power,
                range,
            },
            Kind::Directional => Light::Directional {
                direction: -Vec3::Z,
                irradiance: power,
            },
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } if !(outer_cone_angle > 0.0
                && outer_cone_angle <= std::f32::consts::FRAC_PI_2
                && (0.0..=outer_cone_angle).contains(&inner_cone_angle)) =>
            {
                return Err(LoadError::invalid(
                    self.at(format!("light {}", light.index())),
                    format!(
                        "spot cone angles inner {inner_cone_angle}, outer {outer_cone_angle}: \
                         KHR_lights_punctual needs 0 < outer ≤ π/2 and 0 ≤ inner ≤ outer"
                    ),
                ));
            }
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => Light::Spot {
                position: Vec3::ZERO,
                direction: -Vec3::Z,
                intensity: power,
                beam_width: inner_cone_angle.to_degrees(),
                cutoff: outer_cone_angle.to_degrees(),
                falloff: crate::SpotFalloff::SquaredCosine,
                range,
            },
        };
        if power.min_element() < 0.0 {
            return Err(LoadError::invalid(
                at,
                format!("intensity × color = {power} is negative; a light cannot emit less than nothing"),
            ));
        }
        let l = check_light(&at, Some("intensity × color"), l)?;
        self.scene.lights.push(l);
        self.rig
            .items
            .push((node, NodeItem::Light(self.scene.lights.len() - 1)));
        Ok(())
    }

    /// A point or spot light's `range` (world units: the spec leaves it unscaled by the
    /// node), checked: a finite distance above zero. A directional light's range means
    /// nothing (the spec defines it for point and spot lights) and is ignored with a warning.
    fn light_range(
        &mut self,
        light: &gltf::khr_lights_punctual::Light,
        at: &Location,
    ) -> Result<Option<f32>, LoadError> {
        let Some(range) = light.range() else {
            return Ok(None);
        };
        if matches!(light.kind(), gltf::khr_lights_punctual::Kind::Directional) {
            self.diag.warn(
                at.clone(),
                format!(
                    "range {range} ignored: a directional light has no distance to fall off \
                     over (remove range to silence this)"
                ),
            )?;
            return Ok(None);
        }
        if !(range.is_finite() && range > 0.0) {
            return Err(LoadError::invalid(
                at.clone(),
                format!(
                    "range {range}: KHR_lights_punctual needs a finite distance above 0; remove \
                     range for a light that reaches any distance"
                ),
            ));
        }
        Ok(Some(range))
    }

    fn camera(
        &mut self,
        doc: &gltf::Document,
        index: usize,
        settings: &mut FileSettings,
    ) -> Result<(), LoadError> {
        let Some(camera) = doc.cameras().nth(index) else {
            return Ok(());
        };
        let at = self.at(format!("camera {index}"));
        match camera.projection() {
            gltf::camera::Projection::Perspective(p) => {
                let fov = p.yfov().to_degrees();
                if !(fov > 0.0 && fov < 180.0) {
                    return Err(LoadError::invalid(
                        at,
                        format!("yfov {fov}° is not between 0 and 180"),
                    ));
                }
                self.scene.camera = Camera {
                    origin: Vec3::ZERO,
                    target: -Vec3::Z,
                    up: Vec3::Y,
                    fov,
                    fov_axis: FovAxis::Y,
                    lens: Default::default(),
                    filter: Default::default(),
                };
                match p.aspect_ratio() {
                    Some(aspect) if aspect.is_finite() && aspect > 0.0 => {
                        let h = self.scene.defaults.height;
                        let exact = (h as f32 * aspect).round();
                        let w = (exact as usize).clamp(1, 16384);
                        if w as f32 != exact {
                            self.diag.warn(
                                at.clone(),
                                format!(
                                    "aspectRatio {aspect} asks for a {exact}×{h} image; the \
                                     width is clamped to {w} (give --size to choose)"
                                ),
                            )?;
                        }
                        self.scene.defaults.width = w;
                        settings.size = Some((w, h));
                    }
                    Some(aspect) => self.diag.warn(
                        at.clone(),
                        format!(
                            "aspectRatio {aspect} is not a positive number; ignored (the image \
                             keeps its default size)"
                        ),
                    )?,
                    None => {}
                }
            }
            gltf::camera::Projection::Orthographic(o) => {
                let (xmag, ymag) = (o.xmag(), o.ymag());
                if !(xmag.is_finite() && ymag.is_finite() && xmag != 0.0 && ymag != 0.0) {
                    return Err(LoadError::invalid(
                        at,
                        format!(
                            "orthographic xmag {xmag}, ymag {ymag}: give the view's half width \
                             and half height, non-zero and finite"
                        ),
                    ));
                }
                self.scene.camera = Camera {
                    origin: Vec3::ZERO,
                    target: -Vec3::Z,
                    up: Vec3::Y,
                    // Unused by an orthographic camera.
                    fov: 90.0,
                    fov_axis: FovAxis::Y,
                    lens: Lens::Orthographic {
                        half_width: xmag.abs(),
                        half_height: ymag.abs(),
                    },
                    filter: Default::default(),
                };
                // The image takes the view's shape (as aspectRatio does for perspective).
                let h = self.scene.defaults.height;
                let w = ((h as f32 * xmag.abs() / ymag.abs()).round() as usize).clamp(1, 16384);
                self.scene.defaults.width = w;
                settings.size = Some((w, h));
            }
        }
        Ok(())
    }

    /// Node animation clips (translation, rotation, scale).
    fn animations(&mut self, doc: &gltf::Document) -> Result<(), LoadError> {
        for anim in doc.animations() {
            let mut channels = Vec::new();
            let mut weights = Vec::new();
            for ch in anim.channels() {
                let label = format!("animation {} channel {}", anim.index(), ch.index());
                let Some(&node) = self.node_index.get(&ch.target().node().index()) else {
                    continue;
                };
                let property = match ch.target().property() {
                    gltf::animation::Property::Translation => AnimatedProperty::Translation,
                    gltf::animation::Property::Rotation => AnimatedProperty::Rotation,
                    gltf::animation::Property::Scale => AnimatedProperty::Scale,
                    gltf::animation::Property::MorphTargetWeights => {
                        if let Some(c) = self.weights_channel(&ch, node, &label)? {
                            weights.push(c);
                        }
                        continue;
                    }
                };
                let sampler = ch.sampler();
                self.check_accessor(&sampler.input(), &[Dimensions::Scalar], "animation input")?;
                let dims = if property == AnimatedProperty::Rotation {
                    Dimensions::Vec4
                } else {
                    Dimensions::Vec3
                };
                self.check_accessor(&sampler.output(), &[dims], "animation output")?;
                let interpolation = interpolation(sampler.interpolation());
                let buffers = &self.buffers;
                let reader = ch.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
                let times: Vec<f32> = reader
                    .read_inputs()
                    .map(|i| i.collect())
                    .unwrap_or_default();
                use gltf::animation::util::ReadOutputs;
                let values: Vec<Vec4> = match reader.read_outputs() {
                    Some(ReadOutputs::Translations(it)) | Some(ReadOutputs::Scales(it)) => {
                        it.map(|v| Vec3::from(v).extend(0.0)).collect()
                    }
                    Some(ReadOutputs::Rotations(it)) => it.into_f32().map(Vec4::from).collect(),
                    _ => Vec::new(),
                };
                let per_key = if interpolation == Interpolation::CubicSpline {
                    3
                } else {
                    1
                };
                let bad_times = times
                    .windows(2)
                    .any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
                    || times.iter().any(|t| !t.is_finite());
                // Say which part is wrong: the times, the count, or a value.
                let problem = if bad_times {
                    Some(format!(
                        "its {} key times must be finite and increase",
                        times.len()
                    ))
                } else if values.len() != times.len() * per_key {
                    Some(format!(
                        "{} key times and {} values do not form a valid {interpolation:?} track \
                         ({per_key} value(s) per key)",
                        times.len(),
                        values.len()
                    ))
                } else {
                    values
                        .iter()
                        .position(|v| !v.is_finite())
                        .map(|i| format!("value {i} is not finite; give every key a finite value"))
                };
                if let Some(problem) = problem {
                    return Err(LoadError::invalid(self.at(label), problem));
                }
                let mut values = values;
                if property == AnimatedProperty::Rotation {
                    // Key values only: a cubic spline's tangents (first and third of each
                    // triple) may be zero.
                    let keys = values.iter_mut().skip(per_key / 2).step_by(per_key);
                    let mut bad = 0;
                    for v in keys {
                        if unit_quat(*v).is_none() {
                            *v = Vec4::W;
                            bad += 1;
                        }
                    }
                    if bad > 0 {
                        self.diag.warn(
                            self.at(label),
                            format!(
                                "{bad} rotation key(s) are not rotations (zero quaternions); \
                                 using no rotation there"
                            ),
                        )?;
                    }
                }
                channels.push(AnimationChannel {
                    node,
                    property,
                    interpolation,
                    times,
                    values,
                });
            }
            self.rig.animations.push(Animation {
                name: anim
                    .name()
                    .map_or_else(|| format!("animation {}", anim.index()), str::to_string),
                channels,
                weights,
            });
        }
        Ok(())
    }
}

/// `q` normalised, if it is a usable rotation: finite and not (nearly) zero. glTF requires
/// unit quaternions; slightly off ones are normalised, a zero one has no direction at all.
fn unit_quat(q: Vec4) -> Option<Quat> {
    let len = q.length();
    (len.is_finite() && len > 1e-6).then(|| Quat::from_vec4(q / len))
}

fn flip_rows(img: lumo_image::Image) -> lumo_image::Image {
    let row = img.width * img.channels;
    let mut data = Vec::with_capacity(img.data.len());
    for r in img.data.chunks_exact(row.max(1)).rev() {
        data.extend_from_slice(r);
    }
    lumo_image::Image::from_vec(img.width, img.height, img.channels, data)
}

/// lumo's name for a glTF animation sampler's interpolation (transform and morph-weight
/// channels alike).
fn interpolation(i: gltf::animation::Interpolation) -> Interpolation {
    match i {
        gltf::animation::Interpolation::Step => Interpolation::Step,
        gltf::animation::Interpolation::Linear => Interpolation::Linear,
        gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
    }
}
