//! glTF materials (metallic-roughness per texel, emissive strength, texture transforms) as
//! lumo's.

use super::*;
use crate::{MipFilter, MipMap};
use lumo_image::Image;

impl GltfReader<'_, '_> {
    /// `v` with negative components read as 0, with a warning at `label`: a colour (base
    /// colour, emission) cannot be negative, and glTF allows only [0, 1] there.
    pub(super) fn non_negative(
        &mut self,
        label: &str,
        what: &str,
        v: Vec3,
    ) -> Result<Vec3, LoadError> {
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

    /// A factor glTF bounds to [0, 1] (metallic, roughness): clamped with a warning where
    /// it is out of range, `default` with a warning where it is not a number.
    pub(super) fn unit_factor(
        &mut self,
        label: &str,
        what: &str,
        v: f32,
        default: f32,
    ) -> Result<f32, LoadError> {
        if v.is_nan() {
            self.diag.warn(
                self.at(label.to_string()),
                format!("{what} is NaN; using the default {default} (write a number in [0, 1])"),
            )?;
            return Ok(default);
        }
        if !(0.0..=1.0).contains(&v) {
            self.diag.warn(
                self.at(label.to_string()),
                format!("{what} {v} is outside [0, 1]; clamped (glTF bounds it to [0, 1])"),
            )?;
        }
        Ok(v.clamp(0.0, 1.0))
    }

    /// The lumo material for a glTF material (metallic-roughness model).
    pub(super) fn material(&mut self, mat: gltf::Material) -> Result<usize, LoadError> {
        if let Some(&m) = self.material_map.get(&mat.index()) {
            return Ok(m);
        }
        let label = match mat.index() {
            Some(i) => format!("material {i}"),
            None => "default material".into(),
        };
        self.uv_set = attributes::uv_set(&mat);
        let pbr = mat.pbr_metallic_roughness();
        let factor = Vec4::from(pbr.base_color_factor()).truncate();
        let factor = self.non_negative(&label, "baseColorFactor", factor)?;
        let base = match pbr.base_color_texture() {
            Some(info) => self.texture(&info, false, factor)?,
            None => Texture::Constant(factor),
        };
        let metallic = self.unit_factor(&label, "metallicFactor", pbr.metallic_factor(), 1.0)?;
        let roughness = self.unit_factor(&label, "roughnessFactor", pbr.roughness_factor(), 1.0)?;
        let metallic_roughness = match pbr.metallic_roughness_texture() {
            Some(info) => Some(self.texture(&info, true, Vec3::ONE)?),
            None => None,
        };
        if mat.occlusion_texture().is_some() {
            self.diag.warn(
                self.at(label.clone()),
                "occlusionTexture ignored: the path tracer computes occlusion itself",
            )?;
        }
        let emission = Vec3::from(mat.emissive_factor()) * mat.emissive_strength().unwrap_or(1.0);
        let what = "emissiveFactor × KHR_materials_emissive_strength";
        let emission = self.non_negative(&label, what, emission)?;
        let mut emission = check_emission(&self.at(label.clone()), what, emission)?;
        let mut emission_map = None;
        if let Some(info) = mat.emissive_texture() {
            // Per texel: the texture × emissiveFactor × strength; `emission` becomes its mean
            // (what weighs this light against the others).
            if emission.max_element() > 0.0 {
                let map = self.texture(&info, false, emission)?;
                emission = map.average();
                emission_map = Some(Arc::new(map));
            }
        }
        let unlit = mat.unlit();
        let mut bsdf = if unlit {
            (emission, emission_map) = extensions::unlit_emission(base);
            BsdfSpec::Diffuse {
                reflectance: Texture::Constant(Vec3::ZERO),
            }
        } else {
            BsdfSpec::GltfPbr {
                base_color: base,
                metallic_roughness,
                metallic,
                roughness,
                extensions: self.extensions(&label, &mat)?,
            }
        };
        if let Some(normal) = mat.normal_texture().filter(|_| !unlit) {
            bsdf = BsdfSpec::NormalMap {
                normals: self.normal_texture(&label, &normal)?,
                nested: Box::new(bsdf),
            };
        }
        if let Some((opacity, cutoff)) = self.opacity(&label, &mat, false)? {
            bsdf = BsdfSpec::Mask {
                opacity,
                cutoff,
                nested: Box::new(bsdf),
            };
        }
        let name = mat.name().map_or(label, str::to_string);
        let index = self.scene.add_material(Material {
            name,
            bsdf,
            emission,
            // glTF's doubleSided is about culling; lumo's opaque glTF surfaces reflect on both sides.
            two_sided: true,
            emission_map,
            spectra: Default::default(),
        });
        self.material_map.insert(mat.index(), index);
        Ok(index)
    }

    /// A texture reference with its `KHR_texture_transform`; `tint` multiplies the pixels.
    pub(super) fn texture(
        &mut self,
        info: &gltf::texture::Info,
        raw: bool,
        tint: Vec3,
    ) -> Result<Texture, LoadError> {
        let pixel = move |c: Vec3| c * tint;
        let map: Option<&dyn Fn(Vec3) -> Vec3> = (tint != Vec3::ONE).then_some(&pixel);
        let transform = info.texture_transform();
        // KHR_texture_transform's texCoord overrides the texture's own set.
        let tex_coord = transform
            .as_ref()
            .and_then(|t| t.tex_coord())
            .unwrap_or(info.tex_coord());
        let texture = self.bitmap(info.texture(), tex_coord, raw, map)?;
        Ok(match transform {
            None => texture,
            Some(t) => transformed(texture, &t),
        })
    }

    /// A normalTexture as a tangent-space normal map whose x and y are multiplied by its
    /// `scale` (the texels are rewritten so the renderer's normal-map lookup, which decodes
    /// 2c − 1 and normalises, reads glTF's normalize((2c − 1)·(scale, scale, 1))).
    fn normal_texture(
        &mut self,
        label: &str,
        normal: &gltf::material::NormalTexture,
    ) -> Result<Texture, LoadError> {
        let scale = normal.scale();
        if !scale.is_finite() {
            return Err(LoadError::invalid(
                self.at(label.to_string()),
                format!("normalTexture scale {scale} is not a finite number; write one (1 is the default)"),
            ));
        }
        let pixel = scaled_normal(scale);
        let map: Option<&dyn Fn(Vec3) -> Vec3> = (scale != 1.0).then_some(&pixel);
        // The `gltf` crate exposes KHR_texture_transform on textureInfo only; a normalTexture's
        // is read from its JSON like the extension textures' (offset, rotation, scale and the
        // texCoord override).
        let Some(transform) = normal.extension_value("KHR_texture_transform") else {
            return self.bitmap(normal.texture(), normal.tex_coord(), true, map);
        };
        use gltf::json::Value;
        let info = Value::Object(
            [
                ("index".to_string(), Value::from(normal.texture().index())),
                ("texCoord".to_string(), Value::from(normal.tex_coord())),
                (
                    "extensions".to_string(),
                    Value::Object(
                        [("KHR_texture_transform".to_string(), transform.clone())]
                            .into_iter()
                            .collect(),
                    ),
                ),
            ]
            .into_iter()
            .collect(),
        );
        self.json_texture(label, "normalTexture", &info, true, map)
    }

    /// The bitmap of `texture` (decoded once per image and colour space), its texels passed
    /// through `pixel` where given.
    pub(super) fn bitmap(
        &mut self,
        texture: gltf::Texture,
        tex_coord: u32,
        raw: bool,
        pixel: Option<&dyn Fn(Vec3) -> Vec3>,
    ) -> Result<Texture, LoadError> {
        let image = texture.source();
        let at = self.at(format!("image {}", image.index()));
        self.check_uv_set(&at, tex_coord)?;
        let decoded = match self.images.get(&(image.index(), raw)) {
            Some(img) => img.clone(),
            None => {
                let bytes = self.image_bytes(&image, &at)?;
                let img =
                    decode_image(&bytes, raw).map_err(|e| LoadError::invalid(at.clone(), e))?;
                // glTF puts v = 0 at the image's top row, lumo at its bottom row.
                let img = Arc::new(flip_rows(img));
                self.images.insert((image.index(), raw), img.clone());
                img
            }
        };
        let (sampler, wrap) = self.sampler(&texture, &at)?;
        let Some((minify, between)) = sampler.mipmaps else {
            let image = match pixel {
                None => decoded,
                Some(f) => Arc::new(mapped(&decoded, f)),
            };
            return Ok(Texture::Bitmap {
                image,
                uv_scale: Vec2::ONE,
                filter: sampler.magnify,
                wrap,
            });
        };
        let mips = match pixel {
            None => self
                .mips
                .entry((image.index(), raw))
                .or_insert_with(|| Arc::new(MipMap::new(decoded)))
                .clone(),
            // A mapped image (one channel of a packed texture, a scaled normal map) reduces
            // after the mapping, as the lookup reads the mapped values.
            Some(f) => Arc::new(MipMap::new(Arc::new(mapped(&decoded, f)))),
        };
        Ok(Texture::Mipmapped {
            mips,
            magnify: sampler.magnify,
            minify,
            between,
            wrap,
        })
    }

    /// Warns where a texture reads `tex_coord` but the mesh keeps another set.
    pub(super) fn check_uv_set(&mut self, at: &Location, tex_coord: u32) -> Result<(), LoadError> {
        if tex_coord != self.uv_set {
            // A lumo mesh keeps one uv set per primitive (attributes::uv_set).
            self.diag.warn(
                at.clone(),
                format!(
                    "texCoord {tex_coord} differs from TEXCOORD_{} that the material's base \
                     colour texture reads; lumo keeps one set per mesh and reads that one here",
                    self.uv_set
                ),
            )?;
        }
        Ok(())
    }

    /// A texture's sampler as lumo's lookup: magFilter NEAREST is nearest, LINEAR or unset
    /// bilinear; a `*_MIPMAP_*` minFilter, or none (glTF leaves "auto" filtering to the
    /// renderer), reads a mip-map, while NEAREST and LINEAR minify without one (pixel samples
    /// average the texture); the wrap mode of `wrapS`, with a warning where `wrapT` differs
    /// (lumo wraps both axes alike).
    pub(super) fn sampler(
        &mut self,
        texture: &gltf::Texture,
        at: &Location,
    ) -> Result<(Sampler, WrapMode), LoadError> {
        use gltf::texture::{MagFilter, MinFilter, WrappingMode};
        let sampler = texture.sampler();
        let magnify = match sampler.mag_filter() {
            Some(MagFilter::Nearest) => TextureFilter::Nearest,
            Some(MagFilter::Linear) | None => TextureFilter::Bilinear,
        };
        let (near, linear) = (TextureFilter::Nearest, TextureFilter::Bilinear);
        let mipmaps = match sampler.min_filter() {
            Some(MinFilter::Nearest | MinFilter::Linear) => None,
            Some(MinFilter::NearestMipmapNearest) => Some((near, MipFilter::Nearest)),
            Some(MinFilter::LinearMipmapNearest) => Some((linear, MipFilter::Nearest)),
            Some(MinFilter::NearestMipmapLinear) => Some((near, MipFilter::Linear)),
            Some(MinFilter::LinearMipmapLinear) | None => Some((linear, MipFilter::Linear)),
        };
        let wrap = |m: WrappingMode| match m {
            WrappingMode::ClampToEdge => WrapMode::Clamp,
            WrappingMode::MirroredRepeat => WrapMode::Mirror,
            WrappingMode::Repeat => WrapMode::Repeat,
        };
        let (s, t) = (wrap(sampler.wrap_s()), wrap(sampler.wrap_t()));
        if s != t {
            self.diag.warn(
                at.clone(),
                format!(
                    "sampler wrapS {s:?} and wrapT {t:?} differ; lumo wraps both axes as wrapS"
                ),
            )?;
        }
        Ok((Sampler { magnify, mipmaps }, s))
    }
}

/// A glTF sampler's filters as lumo's lookups.
#[derive(Clone, Copy, Debug)]
pub(super) struct Sampler {
    /// The lookup where a texel covers more than the footprint (`magFilter`).
    pub magnify: TextureFilter,
    /// With a mip-mapped `minFilter`: the lookup within a level and between levels.
    pub mipmaps: Option<(TextureFilter, MipFilter)>,
}

/// `image`'s colour passed through `f`, texel by texel.
fn mapped(image: &Image, f: &dyn Fn(Vec3) -> Vec3) -> Image {
    let mut img = image.to_channels(3);
    for px in img.data.chunks_exact_mut(3) {
        let c = f(Vec3::new(px[0], px[1], px[2]));
        px.copy_from_slice(&c.to_array());
    }
    img
}

impl GltfReader<'_, '_> {
    /// The encoded bytes of `image` (from its buffer view or URI).
    pub(super) fn image_bytes(
        &self,
        image: &gltf::Image,
        at: &Location,
    ) -> Result<Vec<u8>, LoadError> {
        Ok(match image.source() {
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
            gltf::image::Source::Uri { uri, .. } => uri_bytes(self.path, uri, at)?,
        })
    }
}

/// `texture` looked up through a `KHR_texture_transform`: uv' = T(offset) · R(rotation) ·
/// S(scale) · uv, as the extension defines.
pub(super) fn transformed(texture: Texture, t: &gltf::texture::TextureTransform) -> Texture {
    transformed_by(texture, t.offset(), t.rotation(), t.scale())
}

/// [`transformed`] from the transform's offset, rotation and scale.
pub(super) fn transformed_by(
    texture: Texture,
    offset: [f32; 2],
    rotation: f32,
    scale: [f32; 2],
) -> Texture {
    let (s, c) = rotation.sin_cos();
    let rot = Mat2::from_cols(Vec2::new(c, -s), Vec2::new(s, c));
    let m = Affine2::from_mat2_translation(
        rot * Mat2::from_diagonal(Vec2::from(scale)),
        Vec2::from(offset),
    );
    Texture::Transformed {
        texture: Arc::new(texture),
        uv: m,
    }
}

/// A normal map's texel map for glTF's `scale`: the tangent-space vector (2c − 1) with x and y
/// multiplied by `scale`, stored back as RGB in [0, 1]-space (normalTexture and
/// clearcoatNormalTexture read it the same way).
pub(super) fn scaled_normal(scale: f32) -> impl Fn(Vec3) -> Vec3 {
    move |c: Vec3| {
        let n = (c * 2.0 - Vec3::ONE) * Vec3::new(scale, scale, 1.0);
        (n + Vec3::ONE) * 0.5
    }
}
