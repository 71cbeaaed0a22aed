//! glTF 2.0 (.gltf with external or embedded buffers, .glb): meshes placed by the node
//! hierarchy, cameras, metallic-roughness materials, `KHR_lights_punctual`,
//! `KHR_materials_emissive_strength`, `KHR_texture_transform` and node animations.

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use glam::{Affine2, Mat2, Mat4, Quat, Vec2, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};

use super::check::check_mesh;
use super::gltf_refs::check_references;
use super::images::decode_image;
use super::materials::metal_from_reflectance;
use super::{
    defaults, read_file, read_limited, Diagnostics, FileSettings, LoadError, LoadOptions, Location,
};
use crate::animation::{
    AnimatedNode, AnimatedProperty, AnimatedScene, Animation, AnimationChannel, Interpolation,
    NodeItem,
};
use crate::{
    BsdfSpec, Camera, FovAxis, Instance, Light, Material, Mesh, Roughness, Scene, Texture,
    TextureFilter, WrapMode,
};

/// Extensions lumo reads; a file that requires any other one is refused.
const SUPPORTED: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
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
        LoadError::invalid(
            Location::file(path),
            format!("not a valid glTF 2.0 file: {e}"),
        )
    };
    // Parse, check every index, and only then let the gltf crate validate (see gltf_refs).
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes).map_err(invalid)?;
    let blob = gltf.blob;
    let root = gltf.document.into_json();
    check_references(path, &root)?;
    let document = gltf::Document::from_json(root).map_err(invalid)?;
    let doc = &document;
    for ext in doc.extensions_required() {
        if !SUPPORTED.contains(&ext) {
            return Err(LoadError::invalid(
                Location::item(path, "extensionsRequired"),
                format!(
                    "the file requires extension {ext}, which lumo does not support (supported: {})",
                    SUPPORTED.join(", ")
                ),
            ));
        }
    }
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
        diag,
        buffers,
        images: HashMap::new(),
        scene: defaults::empty_scene(path),
        mesh_map: HashMap::new(),
        material_map: HashMap::new(),
        rig: AnimatedScene::default(),
        cameras: Vec::new(),
        node_index: HashMap::new(),
    };
    let gscene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| LoadError::invalid(Location::file(path), "the file has no scene"))?;
    for node in gscene.nodes() {
        r.node(&node, None, 0)?;
    }
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
    let mut scene = r.scene;
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

/// Buffer contents: the GLB chunk, data URIs or files beside the glTF.
fn load_buffers(
    path: &Path,
    doc: &gltf::Document,
    blob: Option<&[u8]>,
) -> Result<Vec<Vec<u8>>, LoadError> {
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let at = Location::item(path, format!("buffer {}", buffer.index()));
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob
                .ok_or_else(|| {
                    LoadError::invalid(
                        at.clone(),
                        "refers to the GLB binary chunk, which is missing",
                    )
                })?
                .to_vec(),
            gltf::buffer::Source::Uri(uri) => uri_bytes(path, uri, &at)?,
        };
        if data.len() < buffer.length() {
            return Err(LoadError::invalid(
                at,
                format!(
                    "holds {} bytes but declares byteLength {} (truncated file?)",
                    data.len(),
                    buffer.length()
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// Bytes of a `data:` URI or of a file relative to the glTF.
fn uri_bytes(path: &Path, uri: &str, at: &Location) -> Result<Vec<u8>, LoadError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (meta, data) = rest
            .split_once(',')
            .ok_or_else(|| LoadError::invalid(at.clone(), "malformed data URI"))?;
        if !meta.ends_with(";base64") {
            return Err(LoadError::invalid(
                at.clone(),
                "only base64 data URIs are supported",
            ));
        }
        return base64_decode(data)
            .ok_or_else(|| LoadError::invalid(at.clone(), "data URI is not valid base64"));
    }
    let file = path
        .parent()
        .unwrap_or(Path::new(""))
        .join(percent_decode(uri));
    read_limited(&file, u64::MAX)
        .map_err(|e| LoadError::invalid(at.clone(), format!("cannot read {}: {e}", file.display())))
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            if let Ok(v) = u8::from_str_radix(&s[i + 1..i + 3], 16) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

fn base64_decode(s: &str) -> Option<Vec<u8>> {
    let val = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            _ => return None,
        } as u32)
    };
    let clean: Vec<u8> = s
        .bytes()
        .filter(|c| !c.is_ascii_whitespace() && *c != b'=')
        .collect();
    let mut out = Vec::with_capacity(clean.len() * 3 / 4);
    for chunk in clean.chunks(4) {
        let mut acc = 0u32;
        for (i, &c) in chunk.iter().enumerate() {
            acc |= val(c)? << (18 - 6 * i);
        }
        let bytes = acc.to_be_bytes();
        match chunk.len() {
            4 => out.extend_from_slice(&bytes[1..4]),
            3 => out.extend_from_slice(&bytes[1..3]),
            2 => out.push(bytes[1]),
            _ => return None,
        }
    }
    Some(out)
}

struct GltfReader<'p, 'd> {
    path: &'p Path,
    diag: &'d mut Diagnostics,
    buffers: Vec<Vec<u8>>,
    /// Decoded images by (image index, raw).
    images: HashMap<(usize, bool), Arc<lumo_image::Image>>,
    scene: Scene,
    /// lumo meshes of each glTF mesh.
    mesh_map: HashMap<usize, Vec<usize>>,
    /// lumo material of each glTF material (`None`: the default material).
    material_map: HashMap<Option<usize>, usize>,
    rig: AnimatedScene,
    /// (node, camera index) in traversal order.
    cameras: Vec<(usize, usize)>,
    /// Rig node of each glTF node.
    node_index: HashMap<usize, usize>,
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
            for m in meshes {
                self.scene.instances.push(Instance {
                    mesh: m,
                    transform: Mat4::IDENTITY,
                });
                self.rig
                    .items
                    .push((me, NodeItem::Instance(self.scene.instances.len() - 1)));
            }
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

    /// Refuses accessors lumo cannot read safely: sparse, wrong type, or beyond their buffer.
    fn check_accessor(
        &self,
        acc: &gltf::Accessor,
        dims: &[Dimensions],
        what: &str,
    ) -> Result<(), LoadError> {
        let at = self.at(format!("accessor {} ({what})", acc.index()));
        if acc.sparse().is_some() {
            return Err(LoadError::invalid(at, "sparse accessors are not supported"));
        }
        if !dims.contains(&acc.dimensions()) {
            return Err(LoadError::invalid(
                at,
                format!("has type {:?}; expected {dims:?}", acc.dimensions()),
            ));
        }
        if acc.count() == 0 {
            return Err(LoadError::invalid(at, "count is 0"));
        }
        let Some(view) = acc.view() else {
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
        let need = acc.offset() + stride * (acc.count() - 1) + elem;
        let buffer_len = self.buffers.get(view.buffer().index()).map_or(0, Vec::len);
        if need > view.length() || view.offset() + view.length() > buffer_len {
            return Err(LoadError::invalid(
                at,
                format!(
                    "reads past the end of its data (needs {need} bytes of buffer view {}, which \
                     has {}; buffer {} has {buffer_len})",
                    view.index(),
                    view.length(),
                    view.buffer().index()
                ),
            ));
        }
        if acc.data_type() != DataType::F32 && dims != [Dimensions::Scalar] && !acc.normalized() {
            return Err(LoadError::invalid(
                at,
                format!(
                    "component type {:?} is not float or normalised",
                    acc.data_type()
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
            self.check_accessor(&pos_acc, &[Dimensions::Vec3], "POSITION")?;
            if let Some(a) = prim.get(&gltf::Semantic::Normals) {
                self.check_accessor(&a, &[Dimensions::Vec3], "NORMAL")?;
            }
            if let Some(a) = prim.get(&gltf::Semantic::TexCoords(0)) {
                self.check_accessor(&a, &[Dimensions::Vec2], "TEXCOORD_0")?;
            }
            if let Some(a) = prim.indices() {
                self.check_accessor(&a, &[Dimensions::Scalar], "indices")?;
                if a.data_type() == DataType::F32 {
                    return Err(LoadError::invalid(
                        self.at(format!("accessor {} (indices)", a.index())),
                        "indices must be unsigned integers",
                    ));
                }
            }
            if let Some(a) = prim.get(&gltf::Semantic::Colors(0)) {
                self.check_accessor(&a, &[Dimensions::Vec3, Dimensions::Vec4], "COLOR_0")?;
            }
            let buffers = &self.buffers;
            let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
            let positions: Vec<Vec3> = reader
                .read_positions()
                .map(|it| it.map(Vec3::from).collect())
                .unwrap_or_default();
            let normals: Vec<Vec3> = reader
                .read_normals()
                .map(|it| it.map(Vec3::from).collect())
                .unwrap_or_default();
            let uvs: Vec<Vec2> = reader
                .read_tex_coords(0)
                .map(|it| it.into_f32().map(Vec2::from).collect())
                .unwrap_or_default();
            // COLOR_0 multiplies the base colour (alpha is not modelled).
            let colors: Vec<Vec3> = reader
                .read_colors(0)
                .map(|it| it.into_rgb_f32().map(Vec3::from).collect())
                .unwrap_or_default();
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
            let material = self.material(prim.material())?;
            let mut m = Mesh {
                name: mesh
                    .name()
                    .map_or_else(|| label.clone(), |n| format!("{n}/{}", prim.index())),
                positions,
                normals,
                uvs,
                colors,
                indices,
                material,
                analytic: None,
            };
            for (attr, len) in [
                ("NORMAL", m.normals.len()),
                ("TEXCOORD_0", m.uvs.len()),
                ("COLOR_0", m.colors.len()),
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
            check_mesh(&mut m, &self.at(label), self.diag)?;
            self.scene.meshes.push(m);
            out.push(self.scene.meshes.len() - 1);
        }
        self.mesh_map.insert(mesh.index(), out.clone());
        Ok(out)
    }

    /// `v` with negative components read as 0, with a warning at `label`: a colour (base
    /// colour, emission) cannot be negative, and glTF allows only [0, 1] there.
    fn non_negative(&mut self, label: &str, what: &str, v: Vec3) -> Result<Vec3, LoadError> {
        if v.min_element() < 0.0 {
            self.diag.warn(
                self.at(label.to_string()),
                format!(
                    "{what} {v} has a negative value; a colour cannot be negative, so it is read \
                     as 0"
                ),
            )?;
        }
        Ok(v.max(Vec3::ZERO))
    }

    /// The lumo material for a glTF material (metallic-roughness model).
    fn material(&mut self, mat: gltf::Material) -> Result<usize, LoadError> {
        if let Some(&m) = self.material_map.get(&mat.index()) {
            return Ok(m);
        }
        let label = match mat.index() {
            Some(i) => format!("material {i}"),
            None => "default material".into(),
        };
        let pbr = mat.pbr_metallic_roughness();
        let factor = Vec4::from(pbr.base_color_factor()).truncate();
        let factor = self.non_negative(&label, "baseColorFactor", factor)?;
        let base = match pbr.base_color_texture() {
            Some(info) => self.texture(&info, false, factor)?,
            None => Texture::Constant(factor),
        };
        let mut metallic = pbr.metallic_factor();
        let mut roughness = pbr.roughness_factor();
        if let Some(info) = pbr.metallic_roughness_texture() {
            // lumo's roughness and metalness are per material: use the texture's mean.
            let mean = self.texture(&info, true, Vec3::ONE)?.average();
            roughness *= mean.y;
            metallic *= mean.z;
            self.diag.warn(
                self.at(label.clone()),
                format!(
                    "metallicRoughnessTexture replaced by its mean (roughness {roughness:.3}, \
                     metallic {metallic:.3}); lumo has no per-texel roughness"
                ),
            )?;
        }
        if mat.normal_texture().is_some() || mat.occlusion_texture().is_some() {
            self.diag.warn(
                self.at(label.clone()),
                "normal and occlusion textures are not supported; ignored",
            )?;
        }
        if mat.alpha_mode() != gltf::material::AlphaMode::Opaque {
            self.diag.warn(
                self.at(label.clone()),
                format!("alphaMode {:?} is rendered opaque", mat.alpha_mode()),
            )?;
        }
        let emission = Vec3::from(mat.emissive_factor()) * mat.emissive_strength().unwrap_or(1.0);
        let mut emission = self.non_negative(
            &label,
            "emissiveFactor × KHR_materials_emissive_strength",
            emission,
        )?;
        if let Some(info) = mat.emissive_texture() {
            let mean = self.texture(&info, false, Vec3::ONE)?.average();
            emission *= mean;
            if emission.max_element() > 0.0 {
                self.diag.warn(
                    self.at(label.clone()),
                    "emissiveTexture replaced by its mean (lumo emission is uniform per material)",
                )?;
            }
        }
        let alpha = roughness * roughness;
        let bsdf = if metallic >= 0.5 {
            let (eta, k) = metal_from_reflectance(base.average());
            if metallic < 1.0 {
                self.diag.warn(
                    self.at(label.clone()),
                    format!("metallic {metallic} rendered as fully metallic"),
                )?;
            }
            BsdfSpec::Conductor {
                eta,
                k,
                roughness: Roughness::ggx(alpha),
            }
        } else {
            if metallic > 0.0 {
                self.diag.warn(
                    self.at(label.clone()),
                    format!("metallic {metallic} rendered as dielectric"),
                )?;
            }
            // glTF's dielectric: a diffuse base under a specular layer with F0 = 0.04 (ior 1.5).
            BsdfSpec::Plastic {
                diffuse: base,
                ior: 1.5,
                roughness: Roughness::ggx(alpha),
                nonlinear: false,
                exact_rough_coat: false,
            }
        };
        let name = mat.name().map_or(label, str::to_string);
        let index = self.scene.add_material(Material {
            name,
            bsdf,
            emission,
            // glTF's doubleSided is about culling; lumo's opaque glTF surfaces reflect on both sides.
            two_sided: true,
            emission_map: None,
        });
        self.material_map.insert(mat.index(), index);
        Ok(index)
    }

    /// A texture reference with its `KHR_texture_transform`; `tint` multiplies the pixels.
    fn texture(
        &mut self,
        info: &gltf::texture::Info,
        raw: bool,
        tint: Vec3,
    ) -> Result<Texture, LoadError> {
        let image = info.texture().source();
        let at = self.at(format!("image {}", image.index()));
        if info.tex_coord() != 0 {
            self.diag
                .warn(at.clone(), "only TEXCOORD_0 is supported; using it")?;
        }
        let decoded = match self.images.get(&(image.index(), raw)) {
            Some(img) => img.clone(),
            None => {
                let bytes = match image.source() {
                    gltf::image::Source::View { view, .. } => {
                        let buf = self
                            .buffers
                            .get(view.buffer().index())
                            .map(Vec::as_slice)
                            .unwrap_or(&[]);
                        buf.get(view.offset()..view.offset() + view.length())
                            .ok_or_else(|| {
                                LoadError::invalid(at.clone(), "image buffer view is out of range")
                            })?
                            .to_vec()
                    }
                    gltf::image::Source::Uri { uri, .. } => uri_bytes(self.path, uri, &at)?,
                };
                let img =
                    decode_image(&bytes, raw).map_err(|e| LoadError::invalid(at.clone(), e))?;
                // glTF puts v = 0 at the image's top row, lumo at its bottom row.
                let img = Arc::new(flip_rows(img));
                self.images.insert((image.index(), raw), img.clone());
                img
            }
        };
        let image = if tint == Vec3::ONE {
            decoded
        } else {
            let mut img = (*decoded).to_channels(3);
            for px in img.data.chunks_exact_mut(3) {
                px[0] *= tint.x;
                px[1] *= tint.y;
                px[2] *= tint.z;
            }
            Arc::new(img)
        };
        // glTF samplers' filters are not read yet: nearest, as lumo has always looked them up.
        let texture = Texture::Bitmap {
            image,
            uv_scale: Vec2::ONE,
            filter: TextureFilter::Nearest,
            wrap: WrapMode::Repeat,
        };
        Ok(match info.texture_transform() {
            None => texture,
            Some(t) => {
                let (s, c) = t.rotation().sin_cos();
                // uv' = T(offset) · R(rotation) · S(scale) · uv, as the extension defines.
                let rot = Mat2::from_cols(Vec2::new(c, -s), Vec2::new(s, c));
                let m = Affine2::from_mat2_translation(
                    rot * Mat2::from_diagonal(Vec2::from(t.scale())),
                    Vec2::from(t.offset()),
                );
                Texture::Transformed {
                    texture: Arc::new(texture),
                    uv: m,
                }
            }
        })
    }

    fn light(
        &mut self,
        light: &gltf::khr_lights_punctual::Light,
        node: usize,
    ) -> Result<(), LoadError> {
        use gltf::khr_lights_punctual::Kind;
        // glTF's photometric intensities are taken as lumo's radiometric units one to one.
        let power = Vec3::from(light.color()) * light.intensity();
        let l = match light.kind() {
            Kind::Point => Light::Point {
                position: Vec3::ZERO,
                intensity: power,
            },
            Kind::Directional => Light::Directional {
                direction: -Vec3::Z,
                irradiance: power,
            },
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => Light::Spot {
                position: Vec3::ZERO,
                direction: -Vec3::Z,
                intensity: power,
                beam_width: inner_cone_angle.to_degrees(),
                cutoff: outer_cone_angle.to_degrees(),
            },
        };
        if !power.is_finite() || power.min_element() < 0.0 {
            return Err(LoadError::invalid(
                self.at(format!("light {}", light.index())),
                format!("intensity × color = {power} is not a finite non-negative value"),
            ));
        }
        self.scene.lights.push(l);
        self.rig
            .items
            .push((node, NodeItem::Light(self.scene.lights.len() - 1)));
        Ok(())
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
                };
                if let Some(aspect) = p.aspect_ratio().filter(|a| a.is_finite() && *a > 0.0) {
                    let h = self.scene.defaults.height;
                    let w = ((h as f32 * aspect).round() as usize).clamp(1, 16384);
                    self.scene.defaults.width = w;
                    settings.size = Some((w, h));
                }
            }
            gltf::camera::Projection::Orthographic(_) => {
                self.diag.warn(at, "orthographic cameras are not supported; using a perspective camera at its place")?;
            }
        }
        Ok(())
    }

    /// Node animation clips (translation, rotation, scale).
    fn animations(&mut self, doc: &gltf::Document) -> Result<(), LoadError> {
        for anim in doc.animations() {
            let mut channels = Vec::new();
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
                        self.diag.warn(
                            self.at(label),
                            "morph target animation is not supported; ignored",
                        )?;
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
                let interpolation = match sampler.interpolation() {
                    gltf::animation::Interpolation::Step => Interpolation::Step,
                    gltf::animation::Interpolation::Linear => Interpolation::Linear,
                    gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
                };
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
                if bad_times
                    || values.len() != times.len() * per_key
                    || values.iter().any(|v| !v.is_finite())
                {
                    return Err(LoadError::invalid(
                        self.at(label),
                        format!(
                            "{} key times (must increase) and {} values do not form a valid {interpolation:?} track",
                            times.len(),
                            values.len()
                        ),
                    ));
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
