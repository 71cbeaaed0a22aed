//! glTF `alphaMode`: MASK (opaque where alpha ≥ alphaCutoff, absent elsewhere) and BLEND
//! (stochastic transparency: opaque with probability alpha), both as lumo's opacity mask, with
//! `COLOR_0`'s alpha multiplied in at each hit where a primitive has it.

use super::*;
use crate::load::images::decode_alpha;

impl GltfReader<'_, '_> {
    /// The opacity of `mat` (its base colour alpha: baseColorFactor's alpha × the texture's
    /// alpha channel) and the cutoff left to the hit: `per_vertex` false thresholds MASK
    /// per texel (no cutoff left) and gives `None` where the opacity is 1 everywhere; true
    /// (a primitive with vertex alpha, which must multiply in before the threshold) keeps the
    /// alpha as it is and leaves MASK's cutoff to the hit. `None` for OPAQUE.
    pub(super) fn opacity(
        &mut self,
        label: &str,
        mat: &gltf::Material,
        per_vertex: bool,
    ) -> Result<Option<(Texture, Option<f32>)>, LoadError> {
        use gltf::material::AlphaMode;
        let mode = mat.alpha_mode();
        if mode == AlphaMode::Opaque {
            return Ok(None);
        }
        let factor = mat.pbr_metallic_roughness().base_color_factor()[3];
        let factor = self.unit_factor(label, "baseColorFactor alpha", factor, 1.0)?;
        let cutoff = match mode {
            AlphaMode::Mask => {
                let c = mat.alpha_cutoff().unwrap_or(0.5);
                if !c.is_finite() || c < 0.0 {
                    return Err(LoadError::invalid(
                        self.at(label.to_string()),
                        format!("alphaCutoff {c} must be a number ≥ 0 (0.5 is the default)"),
                    ));
                }
                Some(c)
            }
            _ => None,
        };
        let (texel_cutoff, hit_cutoff) = if per_vertex {
            (None, cutoff)
        } else {
            (cutoff, None)
        };
        let opacity = move |a: f32| match texel_cutoff {
            Some(c) => f32::from(u8::from(a * factor >= c)),
            None => a * factor,
        };
        let texture = match mat.pbr_metallic_roughness().base_color_texture() {
            Some(info) => self.alpha_bitmap(&info, &opacity)?,
            None => None,
        };
        Ok(match texture {
            Some(t) => Some((t, hit_cutoff)),
            None if opacity(1.0) >= 1.0 && !per_vertex => None,
            None => Some((Texture::Constant(Vec3::splat(opacity(1.0))), hit_cutoff)),
        })
    }

    /// The lumo material of glTF material `mat` (lumo index `base`) for a primitive with
    /// vertex alpha: `base` with its mask replaced by one that multiplies the vertex alpha in
    /// before MASK's cutoff. One per glTF material, made on first use.
    pub(super) fn vertex_alpha_material(
        &mut self,
        mat: &gltf::Material,
        base: usize,
    ) -> Result<usize, LoadError> {
        if let Some(&i) = self.vertex_alpha_map.get(&mat.index()) {
            return Ok(i);
        }
        let label = match mat.index() {
            Some(i) => format!("material {i}"),
            None => "default material".to_string(),
        };
        let mut m = self.scene.materials[base].clone();
        let Some((opacity, cutoff)) = self.opacity(&label, mat, true)? else {
            return Ok(base);
        };
        // The loader's mask is the outermost adapter; the rest is kept as it is.
        let nested = match m.bsdf {
            BsdfSpec::Mask { nested, .. } => nested,
            other => Box::new(other),
        };
        m.bsdf = BsdfSpec::Mask {
            opacity,
            cutoff,
            nested,
        };
        m.name = format!("{} (vertex alpha)", m.name);
        let index = self.scene.add_material(m);
        self.vertex_alpha_map.insert(mat.index(), index);
        Ok(index)
    }

    /// The base colour texture's alpha channel through `opacity`, as a grey bitmap looked up
    /// like the base colour (same transform); `None` where the image has no alpha.
    pub(super) fn alpha_bitmap(
        &mut self,
        info: &gltf::texture::Info,
        opacity: &dyn Fn(f32) -> f32,
    ) -> Result<Option<Texture>, LoadError> {
        let texture = self.alpha_of(&info.texture(), opacity)?;
        Ok(texture.map(|texture| match info.texture_transform() {
            None => texture,
            Some(t) => materials::transformed(texture, &t),
        }))
    }

    /// `texture`'s alpha channel through `f` as a grey bitmap (untransformed); `None` where
    /// the image has no alpha.
    pub(super) fn alpha_of(
        &mut self,
        texture: &gltf::Texture,
        f: &dyn Fn(f32) -> f32,
    ) -> Result<Option<Texture>, LoadError> {
        let image = texture.source();
        let at = self.at(format!("image {}", image.index()));
        let bytes = self.image_bytes(&image, &at)?;
        let Some(alpha) = decode_alpha(&bytes).map_err(|e| LoadError::invalid(at.clone(), e))?
        else {
            return Ok(None);
        };
        // Grey RGB so that a luminance lookup reads the value itself.
        let data = alpha.data.iter().flat_map(|&a| [f(a); 3]).collect();
        let img = flip_rows(lumo_image::Image::from_vec(
            alpha.width,
            alpha.height,
            3,
            data,
        ));
        // Alpha is read at full resolution whatever the minification filter: a mask's cutoff
        // on averaged alpha would erode thin cut-outs (foliage) with distance.
        let (sampler, wrap) = self.sampler(texture, &at)?;
        Ok(Some(Texture::Bitmap {
            image: Arc::new(img),
            uv_scale: Vec2::ONE,
            filter: sampler.magnify,
            wrap,
        }))
    }
}
