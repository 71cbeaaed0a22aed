//! A glTF material's KHR_materials_ior and KHR_materials_specular as lumo's
//! [`GltfExtensions`].

use super::*;
use crate::GltfExtensions;

impl GltfReader<'_, '_> {
    /// The extensions `mat` uses that change its BSDF; `None` where it uses none.
    pub(super) fn extensions(
        &mut self,
        label: &str,
        mat: &gltf::Material,
    ) -> Result<Option<Arc<GltfExtensions>>, LoadError> {
        let (ior, specular) = (mat.ior(), mat.specular());
        if ior.is_none() && specular.is_none() {
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
        Ok(Some(Arc::new(ext)))
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
