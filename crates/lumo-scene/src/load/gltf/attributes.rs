//! Vertex attributes as authored: the texture coordinate set a material's textures name, and
//! `KHR_mesh_quantization`'s integer and normalised-integer POSITION, NORMAL, TEXCOORD_n and
//! morph target data, dequantised as the extension defines.

use gltf::accessor::{DataType, Dimensions};

use super::GltfReader;
use crate::load::LoadError;

/// The `TEXCOORD_n` set a texture reference reads (`KHR_texture_transform`'s `texCoord`
/// overrides the texture's own).
pub(super) fn info_set(info: &gltf::texture::Info) -> u32 {
    info.texture_transform()
        .and_then(|t| t.tex_coord())
        .unwrap_or(info.tex_coord())
}

/// The `TEXCOORD_n` set a normalTexture reads (its `KHR_texture_transform` `texCoord`
/// overrides its own; the `gltf` crate exposes that extension as JSON here).
pub(super) fn normal_set(n: &gltf::material::NormalTexture) -> u32 {
    n.extension_value("KHR_texture_transform")
        .and_then(|t| t.get("texCoord"))
        .and_then(|s| s.as_u64())
        .and_then(|s| u32::try_from(s).ok())
        .unwrap_or(n.tex_coord())
}

/// The one `TEXCOORD_n` set the primitives of `mat` keep (a lumo mesh has one): its base colour
/// texture's, else that of its metallic-roughness, normal or emissive texture; 0 without any.
pub(super) fn uv_set(mat: &gltf::Material) -> u32 {
    let pbr = mat.pbr_metallic_roughness();
    pbr.base_color_texture()
        .map(|i| info_set(&i))
        .or_else(|| pbr.metallic_roughness_texture().map(|i| info_set(&i)))
        .or_else(|| mat.normal_texture().map(|n| normal_set(&n)))
        .or_else(|| mat.emissive_texture().map(|i| info_set(&i)))
        .unwrap_or(0)
}

/// Which component types an attribute may have (float, and what KHR_mesh_quantization adds).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Quantized {
    /// POSITION, TEXCOORD_n and position displacements: signed or unsigned bytes and shorts,
    /// normalised or not.
    AnyInteger,
    /// NORMAL and normal displacements: normalised signed bytes and shorts.
    SignedNormalized,
}

impl GltfReader<'_, '_> {
    /// Checks an attribute accessor: its layout and a component type that `kind` allows.
    pub(super) fn check_attribute(
        &self,
        acc: &gltf::Accessor,
        dims: Dimensions,
        what: &str,
        kind: Quantized,
    ) -> Result<(), LoadError> {
        self.check_layout(acc, &[dims], what)?;
        let ok = match (acc.data_type(), kind) {
            (DataType::F32, _) => true,
            (DataType::U32, _) => false,
            (DataType::I8 | DataType::I16, Quantized::SignedNormalized) => acc.normalized(),
            (_, Quantized::SignedNormalized) => false,
            (_, Quantized::AnyInteger) => true,
        };
        if ok {
            return Ok(());
        }
        let allowed = match kind {
            Quantized::AnyInteger => "float, or (KHR_mesh_quantization) byte or short",
            Quantized::SignedNormalized => {
                "float, or (KHR_mesh_quantization) normalised signed byte or short"
            }
        };
        Err(LoadError::invalid(
            self.at(format!("accessor {} ({what})", acc.index())),
            format!(
                "component type {:?}{} is not allowed here: use {allowed}",
                acc.data_type(),
                if acc.normalized() {
                    " (normalised)"
                } else {
                    ""
                }
            ),
        ))
    }

    /// The values of a checked float or integer accessor of `N` components, dequantised: a
    /// normalised integer c becomes c / max (at least −1), any other integer its value. A
    /// sparse accessor's substitutions are applied (over zeros where it has no buffer view).
    pub(super) fn read_floats<const N: usize>(
        &self,
        acc: &gltf::Accessor,
    ) -> Result<Vec<[f32; N]>, LoadError> {
        let at = || self.at(format!("accessor {}", acc.index()));
        let ty = acc.data_type();
        let size = ty.size();
        let norm = acc.normalized();
        let value = |b: &[u8]| -> f32 {
            match (ty, norm) {
                (DataType::F32, _) => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                (DataType::I8, true) => (f32::from(b[0] as i8) / 127.0).max(-1.0),
                (DataType::I8, false) => f32::from(b[0] as i8),
                (DataType::U8, true) => f32::from(b[0]) / 255.0,
                (DataType::U8, false) => f32::from(b[0]),
                (DataType::I16, n) => {
                    let c = f32::from(i16::from_le_bytes([b[0], b[1]]));
                    if n {
                        (c / 32767.0).max(-1.0)
                    } else {
                        c
                    }
                }
                (DataType::U16, n) => {
                    let c = f32::from(u16::from_le_bytes([b[0], b[1]]));
                    if n {
                        c / 65535.0
                    } else {
                        c
                    }
                }
                (DataType::U32, _) => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
            }
        };
        let element = |buf: &[u8], start: usize| -> Result<[f32; N], LoadError> {
            let mut v = [0.0; N];
            for (c, x) in v.iter_mut().enumerate() {
                let start = start + c * size;
                // check_layout bounds the accessor by its views and buffers; stay safe anyway.
                let Some(bytes) = buf.get(start..start + size) else {
                    return Err(LoadError::invalid(at(), "reads past the end of its buffer"));
                };
                *x = value(bytes);
            }
            Ok(v)
        };
        let buffer = |i: usize| self.buffers.get(i).map_or(&[][..], Vec::as_slice);
        let mut out = match acc.view() {
            Some(view) => {
                let buf = buffer(view.buffer().index());
                let stride = view.stride().unwrap_or(size * N);
                let base = view.offset() + acc.offset();
                (0..acc.count())
                    .map(|i| element(buf, base + i * stride))
                    .collect::<Result<Vec<_>, _>>()?
            }
            None if acc.sparse().is_some() => vec![[0.0; N]; acc.count()],
            None => return Err(LoadError::invalid(at(), "has no buffer view")),
        };
        if let (Some(indices), Some((b, base))) =
            (self.sparse_indices(acc), self.sparse_values_at(acc))
        {
            // Sparse values are tightly packed elements of the accessor's own type.
            for (k, &i) in indices.iter().enumerate() {
                let v = element(buffer(b), base + k * size * N)?;
                match out.get_mut(i as usize) {
                    Some(slot) => *slot = v,
                    None => {
                        return Err(LoadError::invalid(
                            at(),
                            format!("sparse index {i} is past the accessor's count"),
                        ))
                    }
                }
            }
        }
        Ok(out)
    }
}

impl GltfReader<'_, '_> {
    /// `COLOR_0`'s alpha per vertex where it matters: under alphaMode MASK or BLEND (OPAQUE
    /// ignores alpha) and where some vertex has alpha below 1; empty otherwise.
    pub(super) fn vertex_alpha(&self, prim: &gltf::Primitive) -> Vec<f32> {
        let Some(acc) = prim.get(&gltf::Semantic::Colors(0)) else {
            return Vec::new();
        };
        let mode = prim.material().alpha_mode();
        if acc.dimensions() != Dimensions::Vec4 || mode == gltf::material::AlphaMode::Opaque {
            return Vec::new();
        }
        let buffers = &self.buffers;
        let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let alphas: Vec<f32> = reader
            .read_colors(0)
            .map(|it| it.into_rgba_f32().map(|c| c[3]).collect())
            .unwrap_or_default();
        if alphas.iter().all(|&a| a >= 1.0) {
            return Vec::new();
        }
        alphas
    }
}
