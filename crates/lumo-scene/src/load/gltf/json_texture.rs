//! textureInfo objects inside material extensions the `gltf` crate does not parse
//! (KHR_materials_sheen, KHR_materials_clearcoat): read from the extension's JSON, with their
//! `texCoord` and `KHR_texture_transform`, into lumo textures like the core material's.

use gltf::json::Value;

use super::*;

/// Where a textureInfo in extension JSON points: its texture, uv set and transform.
struct JsonTextureInfo<'a> {
    texture: gltf::Texture<'a>,
    tex_coord: u32,
    /// KHR_texture_transform's offset, rotation and scale.
    transform: Option<([f32; 2], f32, [f32; 2])>,
}

/// A JSON number array of two as `[f32; 2]`.
fn pair(v: Option<&Value>) -> Option<[f32; 2]> {
    match v?.as_array()?.as_slice() {
        [a, b] => Some([a.as_f64()? as f32, b.as_f64()? as f32]),
        _ => None,
    }
}

impl<'a> GltfReader<'a, '_> {
    /// The textureInfo `json` at `what` of material `label`, checked: its index names a
    /// texture of the file, its texCoord and transform are numbers of the right shape.
    fn json_texture_info(
        &self,
        label: &str,
        what: &str,
        json: &Value,
    ) -> Result<JsonTextureInfo<'a>, LoadError> {
        let at = || self.at(label.to_string());
        let count = self.doc.textures().len();
        let texture = json
            .get("index")
            .and_then(Value::as_u64)
            .and_then(|i| self.doc.textures().nth(usize::try_from(i).ok()?))
            .ok_or_else(|| {
                LoadError::invalid(
                    at(),
                    format!(
                        "{what}.index {} names no texture (the file has {count}); write the \
                         index of one of its textures",
                        json.get("index")
                            .map_or("(missing)".into(), Value::to_string)
                    ),
                )
            })?;
        let uv_set = |v: Option<&Value>, key: &str| -> Result<Option<u32>, LoadError> {
            match v {
                None => Ok(None),
                Some(v) => v
                    .as_u64()
                    .and_then(|s| u32::try_from(s).ok())
                    .map(Some)
                    .ok_or_else(|| {
                        LoadError::invalid(
                            at(),
                            format!("{what}.{key} {v} is not a texture coordinate set number"),
                        )
                    }),
            }
        };
        let mut tex_coord = uv_set(json.get("texCoord"), "texCoord")?.unwrap_or(0);
        let transform = match json.pointer("/extensions/KHR_texture_transform") {
            None => None,
            Some(t) => {
                let bad = |key: &str| {
                    LoadError::invalid(
                        at(),
                        format!(
                            "{what} KHR_texture_transform {key} is not {}",
                            if key == "rotation" {
                                "a number"
                            } else {
                                "two numbers"
                            }
                        ),
                    )
                };
                let offset = match t.get("offset") {
                    None => [0.0, 0.0],
                    v => pair(v).ok_or_else(|| bad("offset"))?,
                };
                let scale = match t.get("scale") {
                    None => [1.0, 1.0],
                    v => pair(v).ok_or_else(|| bad("scale"))?,
                };
                let rotation = match t.get("rotation") {
                    None => 0.0,
                    Some(v) => v.as_f64().ok_or_else(|| bad("rotation"))? as f32,
                };
                let key = "KHR_texture_transform texCoord";
                if let Some(set) = uv_set(t.get("texCoord"), key)? {
                    tex_coord = set;
                }
                Some((offset, rotation, scale))
            }
        };
        Ok(JsonTextureInfo {
            texture,
            tex_coord,
            transform,
        })
    }

    /// The texture of the textureInfo `json` (at `what` of material `label`), its texels
    /// passed through `pixel` where given; `raw`: read linear rather than sRGB decoded.
    pub(super) fn json_texture(
        &mut self,
        label: &str,
        what: &str,
        json: &Value,
        raw: bool,
        pixel: Option<&dyn Fn(Vec3) -> Vec3>,
    ) -> Result<Texture, LoadError> {
        let info = self.json_texture_info(label, what, json)?;
        let texture = self.bitmap(info.texture, info.tex_coord, raw, pixel)?;
        Ok(Self::json_transformed(texture, info.transform))
    }

    /// The alpha channel of the textureInfo `json`'s image through `f`, as a grey texture;
    /// `None` where the image has no alpha channel.
    pub(super) fn json_alpha_texture(
        &mut self,
        label: &str,
        what: &str,
        json: &Value,
        f: &dyn Fn(f32) -> f32,
    ) -> Result<Option<Texture>, LoadError> {
        let info = self.json_texture_info(label, what, json)?;
        let at = self.at(format!("image {}", info.texture.source().index()));
        self.check_uv_set(&at, info.tex_coord)?;
        let texture = self.alpha_of(&info.texture, f)?;
        Ok(texture.map(|t| Self::json_transformed(t, info.transform)))
    }

    fn json_transformed(texture: Texture, transform: Option<([f32; 2], f32, [f32; 2])>) -> Texture {
        match transform {
            None => texture,
            Some((offset, rotation, scale)) => {
                materials::transformed_by(texture, offset, rotation, scale)
            }
        }
    }
}
