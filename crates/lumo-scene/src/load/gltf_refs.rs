//! Index checks on a glTF document before the `gltf` crate validates it: its validation indexes
//! some arrays unchecked (a POSITION accessor index past the end panics inside gltf-json 1.4),
//! so every cross-reference is checked here first and reported with its JSON path.

use gltf::json;

use super::{LoadError, Location};

/// Fails on the first reference to an item that does not exist.
pub(crate) fn check_references(path: &std::path::Path, root: &json::Root) -> Result<(), LoadError> {
    let mut err: Option<String> = None;
    let mut check = |what: &dyn Fn() -> String, index: u32, len: usize| {
        if err.is_none() && index as usize >= len {
            err = Some(format!("{} = {index}, but there are only {len}", what()));
        }
    };
    for (i, a) in root.accessors.iter().enumerate() {
        if let Some(v) = a.buffer_view {
            check(
                &|| format!("accessors[{i}].bufferView"),
                v.value() as u32,
                root.buffer_views.len(),
            );
        }
        if let Some(s) = &a.sparse {
            check(
                &|| format!("accessors[{i}].sparse.indices.bufferView"),
                s.indices.buffer_view.value() as u32,
                root.buffer_views.len(),
            );
            check(
                &|| format!("accessors[{i}].sparse.values.bufferView"),
                s.values.buffer_view.value() as u32,
                root.buffer_views.len(),
            );
        }
    }
    for (i, v) in root.buffer_views.iter().enumerate() {
        check(
            &|| format!("bufferViews[{i}].buffer"),
            v.buffer.value() as u32,
            root.buffers.len(),
        );
    }
    for (i, im) in root.images.iter().enumerate() {
        if let Some(v) = im.buffer_view {
            check(
                &|| format!("images[{i}].bufferView"),
                v.value() as u32,
                root.buffer_views.len(),
            );
        }
    }
    for (i, t) in root.textures.iter().enumerate() {
        check(
            &|| format!("textures[{i}].source"),
            t.source.value() as u32,
            root.images.len(),
        );
        if let Some(s) = t.sampler {
            check(
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
            check(
                &|| format!("materials[{i}] texture index"),
                t as u32,
                root.textures.len(),
            );
        }
    }
    for (i, mesh) in root.meshes.iter().enumerate() {
        for (j, p) in mesh.primitives.iter().enumerate() {
            for a in p.attributes.values() {
                check(
                    &|| format!("meshes[{i}].primitives[{j}].attributes"),
                    a.value() as u32,
                    root.accessors.len(),
                );
            }
            if let Some(a) = p.indices {
                check(
                    &|| format!("meshes[{i}].primitives[{j}].indices"),
                    a.value() as u32,
                    root.accessors.len(),
                );
            }
            if let Some(m) = p.material {
                check(
                    &|| format!("meshes[{i}].primitives[{j}].material"),
                    m.value() as u32,
                    root.materials.len(),
                );
            }
            for t in p.targets.iter().flatten() {
                for a in [t.positions, t.normals, t.tangents].into_iter().flatten() {
                    check(
                        &|| format!("meshes[{i}].primitives[{j}].targets"),
                        a.value() as u32,
                        root.accessors.len(),
                    );
                }
            }
        }
    }
    let lights = root
        .extensions
        .as_ref()
        .and_then(|e| e.khr_lights_punctual.as_ref())
        .map_or(0, |l| l.lights.len());
    for (i, node) in root.nodes.iter().enumerate() {
        let refs: [(&str, Option<u32>, usize); 4] = [
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
        for (field, index, len) in refs {
            if let Some(index) = index {
                check(&|| format!("nodes[{i}].{field}"), index, len);
            }
        }
        for c in node.children.iter().flatten() {
            check(
                &|| format!("nodes[{i}].children"),
                c.value() as u32,
                root.nodes.len(),
            );
        }
    }
    for (i, skin) in root.skins.iter().enumerate() {
        for j in skin.joints.iter().chain(skin.skeleton.iter()) {
            check(
                &|| format!("skins[{i}].joints"),
                j.value() as u32,
                root.nodes.len(),
            );
        }
        if let Some(a) = skin.inverse_bind_matrices {
            check(
                &|| format!("skins[{i}].inverseBindMatrices"),
                a.value() as u32,
                root.accessors.len(),
            );
        }
    }
    for (i, s) in root.scenes.iter().enumerate() {
        for node in &s.nodes {
            check(
                &|| format!("scenes[{i}].nodes"),
                node.value() as u32,
                root.nodes.len(),
            );
        }
    }
    if let Some(s) = root.scene {
        check(&|| "scene".to_string(), s.value() as u32, root.scenes.len());
    }
    for (i, a) in root.animations.iter().enumerate() {
        for s in &a.samplers {
            for acc in [s.input, s.output] {
                check(
                    &|| format!("animations[{i}].samplers"),
                    acc.value() as u32,
                    root.accessors.len(),
                );
            }
        }
        for c in &a.channels {
            check(
                &|| format!("animations[{i}].channels.sampler"),
                c.sampler.value() as u32,
                a.samplers.len(),
            );
            check(
                &|| format!("animations[{i}].channels.target.node"),
                c.target.node.value() as u32,
                root.nodes.len(),
            );
        }
    }
    // Enumerations the gltf crate unwraps without its validation having checked them.
    for (i, a) in root.animations.iter().enumerate() {
        use json::validation::Checked::Invalid;
        if a.samplers
            .iter()
            .any(|s| matches!(s.interpolation, Invalid))
            || a.channels.iter().any(|c| matches!(c.target.path, Invalid))
        {
            err.get_or_insert(format!(
                "animations[{i}] has an unknown interpolation or target path"
            ));
        }
    }
    match err {
        None => Ok(()),
        Some(e) => Err(LoadError::invalid(
            Location::item(path, "JSON"),
            format!("invalid reference: {e}"),
        )),
    }
}
