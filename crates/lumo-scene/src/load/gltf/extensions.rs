//! A glTF material's KHR_materials_ior, KHR_materials_specular, KHR_materials_transmission
//! and KHR_materials_volume as lumo's [`GltfExtensions`], the absorbing media of volumes, and
//! KHR_materials_unlit's emission. KHR_materials_clearcoat and KHR_materials_sheen, which the
//! `gltf` crate does not parse, are read from the material's extension JSON.

use super::*;
use crate::media::{Density, MediumSpectra};
use crate::{Boundary, GltfExtensions, Medium, MediumInterface, PhaseFunction};

impl GltfReader<'_, '_> {
    /// The extensions `mat` uses that change its BSDF; `None` where it uses none.
    pub(super) fn extensions(
        &mut self,
        label: &str,
        mat: &gltf::Material,
    ) -> Result<Option<Arc<GltfExtensions>>, LoadError> {
        let (ior, specular) = (mat.ior(), mat.specular());
        let (transmission, volume) = (mat.transmission(), mat.volume());
        let clearcoat = mat.extension_value("KHR_materials_clearcoat");
        let sheen = mat.extension_value("KHR_materials_sheen");
        if ior.is_none()
            && specular.is_none()
            && transmission.is_none()
            && volume.is_none()
            && clearcoat.is_none()
            && sheen.is_none()
        {
            return Ok(None);
        }
        let mut ext = GltfExtensions::default();
        if let Some(ior) = ior {
            ext.ior = self.ior(label, ior)?;
        }
        if let Some(s) = specular {
            let what = "KHR_materials_specular specularFactor";
            let factor = self.unit_factor(label, what, s.specular_factor(), 1.0)?;
            // The weight is the texture's alpha channel (an image without one reads as 1).
            let texture = match s.specular_texture() {
                Some(info) => self.alpha_bitmap(&info, &|a| a * factor)?,
                None => None,
            };
            ext.specular = texture.unwrap_or(Texture::Constant(Vec3::splat(factor)));
            let what = "KHR_materials_specular specularColorFactor";
            let color = self.non_negative(label, what, Vec3::from(s.specular_color_factor()))?;
            ext.specular_color = match s.specular_color_texture() {
                Some(info) => self.texture(&info, false, color)?,
                None => Texture::Constant(color),
            };
        }
        if let Some(t) = transmission {
            let what = "KHR_materials_transmission transmissionFactor";
            let factor = self.unit_factor(label, what, t.transmission_factor(), 0.0)?;
            ext.transmission = match t.transmission_texture() {
                Some(info) if factor > 0.0 => self.red_channel(&info, factor)?,
                _ => Texture::Constant(Vec3::splat(factor)),
            };
        }
        if let Some(v) = volume {
            (ext.thickness, ext.absorption) = self.volume(label, &v)?;
        }
        if let Some(c) = clearcoat {
            self.clearcoat(label, c, &mut ext)?;
        }
        if let Some(s) = sheen {
            (ext.sheen_color, ext.sheen_roughness) = self.sheen(label, s)?;
        }
        Ok(Some(Arc::new(ext)))
    }

    /// KHR_materials_volume: the thickness factor and the absorption coefficient σ_a =
    /// −ln(attenuationColor) / attenuationDistance (`None` for an infinite distance or a
    /// white colour). The thickness texture is not read: a path tracer follows the mesh's
    /// own thickness.
    fn volume(
        &mut self,
        label: &str,
        v: &gltf::material::Volume,
    ) -> Result<(f32, Option<Vec3>), LoadError> {
        let mut thickness = v.thickness_factor();
        if !(thickness >= 0.0 && thickness.is_finite()) {
            self.diag.warn(
                self.at(label.to_string()),
                format!(
                    "KHR_materials_volume thicknessFactor {thickness} is not a length ≥ 0; read                      as 0 (thin-walled)"
                ),
            )?;
            thickness = 0.0;
        }
        let distance = v.attenuation_distance();
        let what = "KHR_materials_volume attenuationColor";
        let color = self.non_negative(label, what, Vec3::from(v.attenuation_color()))?;
        if distance.is_nan() || distance <= 0.0 {
            self.diag.warn(
                self.at(label.to_string()),
                format!(
                    "KHR_materials_volume attenuationDistance {distance} is not a length > 0;                      nothing is absorbed (write a positive distance, or leave it out for none)"
                ),
            )?;
            return Ok((thickness, None));
        }
        if distance.is_infinite() || color.min_element() >= 1.0 {
            return Ok((thickness, None));
        }
        if color.min_element() <= 0.0 {
            self.diag.warn(
                self.at(label.to_string()),
                format!(
                    "KHR_materials_volume attenuationColor {color} has a zero channel, which                      would absorb everything at once; read as 1e-6"
                ),
            )?;
        }
        let sigma = color
            .clamp(Vec3::splat(1e-6), Vec3::ONE)
            .to_array()
            .map(|c| -c.ln() / distance);
        Ok((thickness, Some(Vec3::from(sigma))))
    }

    /// KHR_materials_clearcoat's intensity (clearcoatFactor × clearcoatTexture's red
    /// channel) and roughness (clearcoatRoughnessFactor × clearcoatRoughnessTexture's green
    /// channel), both read linear, factors default 0 and clamped to [0, 1] with a warning, and
    /// its clearcoatNormalTexture (the coat's own normal map).
    fn clearcoat(
        &mut self,
        label: &str,
        json: &gltf::json::Value,
        ext: &mut GltfExtensions,
    ) -> Result<(), LoadError> {
        let mut factor = |key: &str| -> Result<f32, LoadError> {
            let value = match json.get(key) {
                None => 0.0,
                Some(v) => v.as_f64().map_or(f32::NAN, |x| x as f32),
            };
            let what = format!("KHR_materials_clearcoat {key}");
            self.unit_factor(label, &what, value, 0.0)
        };
        let (c, r) = (
            factor("clearcoatFactor")?,
            factor("clearcoatRoughnessFactor")?,
        );
        (ext.clearcoat, ext.clearcoat_roughness) = (c, r);
        if let Some(info) = json.get("clearcoatTexture").filter(|_| c > 0.0) {
            let red = move |t: Vec3| Vec3::splat(t.x * c);
            let what = "KHR_materials_clearcoat clearcoatTexture";
            ext.clearcoat_texture = Some(self.json_texture(label, what, info, true, Some(&red))?);
        }
        if let Some(info) = json.get("clearcoatRoughnessTexture").filter(|_| r > 0.0) {
            let green = move |t: Vec3| Vec3::splat(t.y * r);
            let what = "KHR_materials_clearcoat clearcoatRoughnessTexture";
            let texture = self.json_texture(label, what, info, true, Some(&green))?;
            ext.clearcoat_roughness_texture = Some(texture);
        }
        if let Some(info) = json.get("clearcoatNormalTexture").filter(|_| c > 0.0) {
            ext.clearcoat_normal = Some(self.clearcoat_normal(label, info)?);
        }
        Ok(())
    }

    /// clearcoatNormalTexture (textureInfo `json`: index, texCoord, KHR_texture_transform and
    /// `scale`) as a normalTexture is read: raw texels, x and y scaled by `scale`.
    fn clearcoat_normal(
        &mut self,
        label: &str,
        json: &gltf::json::Value,
    ) -> Result<Texture, LoadError> {
        let what = "KHR_materials_clearcoat clearcoatNormalTexture";
        let scale = match json.get("scale") {
            None => 1.0,
            Some(v) => v.as_f64().map_or(f32::NAN, |x| x as f32),
        };
        if !scale.is_finite() {
            return Err(LoadError::invalid(
                self.at(label.to_string()),
                format!(
                    "{what}.scale {} is not a finite number; write one (1 is the default)",
                    json.get("scale").map_or(String::new(), ToString::to_string)
                ),
            ));
        }
        let pixel = materials::scaled_normal(scale);
        let map: Option<&dyn Fn(Vec3) -> Vec3> = (scale != 1.0).then_some(&pixel);
        self.json_texture(label, what, json, true, map)
    }

    /// KHR_materials_sheen's colour (sheenColorFactor × sheenColorTexture, sRGB decoded) and
    /// roughness (sheenRoughnessFactor × sheenRoughnessTexture's alpha channel, which an image
    /// without alpha reads as 1). Factors outside [0, 1] are clamped with a warning.
    fn sheen(
        &mut self,
        label: &str,
        json: &gltf::json::Value,
    ) -> Result<(Texture, Texture), LoadError> {
        let what = "KHR_materials_sheen sheenColorFactor";
        let color = match json.get("sheenColorFactor") {
            None => Vec3::ZERO,
            Some(v) => match v.as_array().map(Vec::as_slice) {
                Some([r, g, b]) => Vec3::new(
                    r.as_f64().map_or(f32::NAN, |x| x as f32),
                    g.as_f64().map_or(f32::NAN, |x| x as f32),
                    b.as_f64().map_or(f32::NAN, |x| x as f32),
                ),
                _ => Vec3::NAN,
            },
        };
        let color = if color.is_nan() {
            self.diag.warn(
                self.at(label.to_string()),
                format!(
                    "{what} is not three numbers; using the default (0, 0, 0), no sheen \
                     (write three numbers in [0, 1])"
                ),
            )?;
            Vec3::ZERO
        } else {
            let c = self.non_negative(label, what, color)?;
            if c.max_element() > 1.0 {
                self.diag.warn(
                    self.at(label.to_string()),
                    format!("{what} {c} is above 1; clamped (glTF bounds it to [0, 1])"),
                )?;
            }
            c.min(Vec3::ONE)
        };
        let sheen_color = match json.get("sheenColorTexture") {
            Some(info) if color.max_element() > 0.0 => {
                let tint = move |c: Vec3| c * color;
                let what = "KHR_materials_sheen sheenColorTexture";
                self.json_texture(label, what, info, false, Some(&tint))?
            }
            _ => Texture::Constant(color),
        };
        let roughness = match json.get("sheenRoughnessFactor") {
            None => 0.0,
            Some(v) => v.as_f64().map_or(f32::NAN, |x| x as f32),
        };
        let what = "KHR_materials_sheen sheenRoughnessFactor";
        let roughness = self.unit_factor(label, what, roughness, 0.0)?;
        let texture = match json.get("sheenRoughnessTexture") {
            Some(info) if roughness > 0.0 => {
                let what = "KHR_materials_sheen sheenRoughnessTexture";
                self.json_alpha_texture(label, what, info, &|a| a * roughness)?
            }
            _ => None,
        };
        let sheen_roughness = texture.unwrap_or(Texture::Constant(Vec3::splat(roughness)));
        Ok((sheen_color, sheen_roughness))
    }

    /// A texture's red channel × `factor` as a grey texture (transmissionTexture), read linear.
    fn red_channel(
        &mut self,
        info: &gltf::texture::Info,
        factor: f32,
    ) -> Result<Texture, LoadError> {
        let red = move |c: Vec3| Vec3::splat(c.x * factor);
        let transform = info.texture_transform();
        let tex_coord = transform
            .as_ref()
            .and_then(|t| t.tex_coord())
            .unwrap_or(info.tex_coord());
        let texture = self.bitmap(info.texture(), tex_coord, true, Some(&red))?;
        Ok(match transform {
            None => texture,
            Some(t) => materials::transformed(texture, &t),
        })
    }

    /// KHR_materials_ior's `ior`: 1 or more, or 0 (a perfect reflector); anything else warns
    /// and reads as the default 1.5.
    fn ior(&mut self, label: &str, ior: f32) -> Result<f32, LoadError> {
        if ior >= 1.0 || ior == 0.0 {
            return Ok(ior);
        }
        self.diag.warn(
            self.at(label.to_string()),
            format!(
                "KHR_materials_ior ior {ior} is not an index of refraction; using the default \
                 1.5 (write a number ≥ 1, or 0 for a perfect reflector)"
            ),
        )?;
        Ok(1.5)
    }
}

/// Gives every mesh whose glTF material is a volume (thickness > 0) that absorbs a
/// homogeneous, purely absorbing medium inside it (one medium per material), vacuum outside.
pub(super) fn attach_volume_media(scene: &mut Scene) {
    let mut medium_of = HashMap::new();
    for (i, material) in scene.materials.iter().enumerate() {
        let BsdfSpec::GltfPbr {
            extensions: Some(e),
            ..
        } = material.bsdf.innermost()
        else {
            continue;
        };
        let Some(sigma_a) = e.absorption.filter(|_| e.thickness > 0.0 && e.transmits()) else {
            continue;
        };
        medium_of.insert(i, scene.media.media.len());
        scene.media.media.push(Medium {
            name: format!("{} (KHR_materials_volume)", material.name),
            sigma_t: sigma_a,
            albedo: Vec3::ZERO,
            density: Density::Homogeneous,
            phase: PhaseFunction::Isotropic,
            spectra: MediumSpectra {
                sigma_t_scale: 1.0,
                ..Default::default()
            },
        });
    }
    for m in 0..scene.meshes.len() {
        if let Some(&medium) = medium_of.get(&scene.meshes[m].material) {
            let interface = MediumInterface {
                interior: Some(medium),
                exterior: None,
            };
            scene.media.set_boundary(
                m,
                Boundary {
                    null: false,
                    interface: Some(interface),
                },
            );
        }
    }
}

/// KHR_materials_unlit: the base colour (texture × factor) shown as it is, i.e. emitted as
/// radiance over a black BSDF — (mean, per-texel map where textured). Blender's importer
/// likewise makes unlit materials emit their colour.
pub(super) fn unlit_emission(base: Texture) -> (Vec3, Option<Arc<Texture>>) {
    match base {
        Texture::Constant(c) => (c, None),
        textured => (textured.average(), Some(Arc::new(textured))),
    }
}
