//! Index checks on a glTF document before the `gltf` crate validates it: its validation indexes
//! some arrays unchecked (a POSITION accessor index past the end panics inside gltf-json 1.4),
//! so every cross-reference is checked here first and reported with its JSON path.

use gltf::json;

use super::{LoadError, Location};

/// Fails on the first reference to an item that does not exist.
pub(crate) fn check_references(path: &std::path::Path, root: &json::Root) -> Result<(), LoadError> {
    let mut refs = Refs { err: None };
    // In document order of dependence: data, then what reads it, then the node tree.
    buffers(root, &mut refs);
    materials(root, &mut refs);
    meshes(root, &mut refs);
    nodes(root, &mut refs);
    skins_and_scenes(root, &mut refs);
    animations(root, &mut refs);
    match refs.err {
        None => Ok(()),
        Some(e) => Err(LoadError::invalid(
            Location::item(path, "JSON"),
            format!("invalid reference: {e}"),
        )),
    }
}

/// The first broken reference found, if any.
struct Refs {
    err: Option<String>,
}

impl Refs {
    /// Records `what = index` as broken where it is not below `len` and nothing broke before.
    fn check(&mut self, what: &dyn Fn() -> String, index: u32, len: usize) {
        if self.err.is_none() && index as usize >= len {
            self.err = Some(format!("{} = {index}, but there are only {len}", what()));
        }
    }
}

/// Accessors, buffer views and images: what points at the binary data.
fn buffers(root: &json::Root, refs: &mut Refs) {
    let views = root.buffer_views.len();
    for (i, a) in root.accessors.iter().enumerate() {
        if let Some(v) = a.buffer_view {
            refs.check(
                &|| format!("accessors[{i}].bufferView"),
                v.value() as u32,
                views,
            );
        }
        if let Some(s) = &a.sparse {
            refs.check(
                &|| format!("accessors[{i}].sparse.indices.bufferView"),
                s.indices.buffer_view.value() as u32,
                views,
            );
            refs.check(
                &|| format!("accessors[{i}].sparse.values.bufferView"),
                s.values.buffer_view.value() as u32,
                views,
            );
        }
    }
    for (i, v) in root.buffer_views.iter().enumerate() {
        refs.check(
            &|| format!("bufferViews[{i}].buffer"),
            v.buffer.value() as u32,
            root.buffers.len(),
        );
    }
    for (i, im) in root.images.iter().enumerate() {
        if let Some(v) = im.buffer_view {
            refs.check(
                &|| format!("images[{i}].bufferView"),
                v.value() as u32,
                views,
            );
        }
    }
}

/// Textures (their image and sampler) and the textures materials name.
fn materials(root: &json::Root, refs: &mut Refs) {
    for (i, t) in root.textures.iter().enumerate() {
        refs.check(
            &|| format!("textures[{i}].source"),
            t.source.value() as u32,
            root.images.len(),
        );
        if let Some(s) = t.sampler {
            refs.check(
                &|| format!("textures[{i}].sampler"),
                s.value() as u32,
                root.samplers.len(),
            );
        }
    }
    for (i, m) in root.materials.iter().enumerate() {
        let pbr = &m.pbr_metallic_roughness;
        let textures = [
            pbr.base_color_texture.as_ref().map(|t| t.index.value()),
            pbr.metallic_roughness_texture
                .as_ref()
                .map(|t| t.index.value()),
            m.normal_texture.as_ref().map(|t| t.index.value()),
            m.occlusion_texture.as_ref().map(|t| t.index.value()),
            m.emissive_texture.as_ref().map(|t| t.index.value()),
        ];
        for t in textures.into_iter().flatten() {
            refs.check(
                &|| format!("materials[{i}] texture index"),
                t as u32,
                root.textures.len(),
            );
        }
    }
}

/// Each primitive's attributes, indices, material and morph targets.
fn meshes(root: &json::Root, refs: &mut Refs) {
    let accessors = root.accessors.len();
    for (i, mesh) in root.meshes.iter().enumerate() {
        for (j, p) in mesh.primitives.iter().enumerate() {
            for a in p.attributes.values() {
                refs.check(
                    &|| format!("meshes[{i}].primitives[{j}].attributes"),
                    a.value() as u32,
                    accessors,
                );
            }
            if let Some(a) = p.indices {
                refs.check(
                    &|| format!("meshes[{i}].primitives[{j}].indices"),
                    a.value() as u32,
                    accessors,
                );
            }
            if let Some(m) = p.material {
                refs.check(
                    &|| format!("meshes[{i}].primitives[{j}].material"),
                    m.value() as u32,
                    root.materials.len(),
                );
            }
            for t in p.targets.iter().flatten() {
                for a in [t.positions, t.normals, t.tangents].into_iter().flatten() {
                    refs.check(
                        &|| format!("meshes[{i}].primitives[{j}].targets"),
                        a.value() as u32,
                        accessors,
                    );
                }
            }
        }
    }
}

/// What a node names (camera, mesh, skin, punctual light) and its children.
fn nodes(root: &json::Root, refs: &mut Refs) {
    let lights = root
        .extensions
        .as_ref()
        .and_then(|e| e.khr_lights_punctual.as_ref())
        .map_or(0, |l| l.lights.len());
    for (i, node) in root.nodes.iter().enumerate() {
        let named: [(&str, Option<u32>, usize); 4] = [
            (
                "camera",
                node.camera.map(|c| c.value() as u32),
                root.cameras.len(),
            ),
            (
                "mesh",
                node.mesh.map(|c| c.value() as u32),
                root.meshes.len(),
            ),
            (
                "skin",
                node.skin.map(|c| c.value() as u32),
                root.skins.len(),
            ),
            (
                "extensions.KHR_lights_punctual.light",
                node.extensions
                    .as_ref()
                    .and_then(|e| e.khr_lights_punctual.as_ref())
                    .map(|l| l.light.value() as u32),
                lights,
            ),
        ];
        for (field, index, len) in named {
            if let Some(index) = index {
                refs.check(&|| format!("nodes[{i}].{field}"), index, len);
            }
        }
        for c in node.children.iter().flatten() {
            refs.check(
                &|| format!("nodes[{i}].children"),
                c.value() as u32,
                root.nodes.len(),
            );
        }
    }
}

/// Skins' joints and matrices, scenes' root nodes and the default scene.
fn skins_and_scenes(root: &json::Root, refs: &mut Refs) {
    for (i, skin) in root.skins.iter().enumerate() {
        for j in skin.joints.iter().chain(skin.skeleton.iter()) {
            refs.check(
                &|| format!("skins[{i}].joints"),
                j.value() as u32,
                root.nodes.len(),
            );
        }
        if let Some(a) = skin.inverse_bind_matrices {
            refs.check(
                &|| format!("skins[{i}].inverseBindMatrices"),
                a.value() as u32,
                root.accessors.len(),
            );
        }
    }
    for (i, s) in root.scenes.iter().enumerate() {
        for node in &s.nodes {
            refs.check(
                &|| format!("scenes[{i}].nodes"),
                node.value() as u32,
                root.nodes.len(),
            );
        }
    }
    if let Some(s) = root.scene {
        refs.check(&|| "scene".to_string(), s.value() as u32, root.scenes.len());
    }
}

/// Animation samplers' accessors, channels' samplers and nodes, and the enumerations the
/// `gltf` crate unwraps without its validation having checked them (after every index).
fn animations(root: &json::Root, refs: &mut Refs) {
    for (i, a) in root.animations.iter().enumerate() {
        for s in &a.samplers {
            for acc in [s.input, s.output] {
                refs.check(
                    &|| format!("animations[{i}].samplers"),
                    acc.value() as u32,
                    root.accessors.len(),
                );
            }
        }
        for c in &a.channels {
            refs.check(
                &|| format!("animations[{i}].channels.sampler"),
                c.sampler.value() as u32,
                a.samplers.len(),
            );
            refs.check(
                &|| format!("animations[{i}].channels.target.node"),
                c.target.node.value() as u32,
                root.nodes.len(),
            );
        }
    }
    for (i, a) in root.animations.iter().enumerate() {
        use json::validation::Checked::Invalid;
        if a.samplers
            .iter()
            .any(|s| matches!(s.interpolation, Invalid))
            || a.channels.iter().any(|c| matches!(c.target.path, Invalid))
        {
            refs.err.get_or_insert(format!(
                "animations[{i}] has an unknown interpolation or target path"
            ));
        }
    }
}
