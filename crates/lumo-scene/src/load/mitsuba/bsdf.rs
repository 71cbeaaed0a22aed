//! Mitsuba BSDFs and textures → lumo materials.

use std::sync::Arc;

use glam::{Affine2, Mat4, Vec2, Vec3};

use super::props::Props;
use super::xml::Element;
use super::{presets, Builder};
use crate::load::LoadError;
use lumo_spectrum::{Glass, Tabulated};

use crate::{
    BsdfSpec, Distribution, Roughness, RoughnessMaps, Spectra, Texture, TextureFilter, WrapMode,
};

/// Mitsuba's default exterior medium (air) for `int_ior / ext_ior`.
const AIR: f32 = 1.00028;

impl<'a> Builder<'a, '_> {
    /// Converts a `<bsdf>` (cached); returns (name, BSDF).
    pub(super) fn bsdf(&mut self, el: &'a Element) -> Result<(String, BsdfSpec), LoadError> {
        let key = el as *const Element as usize;
        if let Some((name, bsdf, spectra)) = self.bsdfs.get(&key) {
            self.spectra = spectra.clone();
            return Ok((name.clone(), bsdf.clone()));
        }
        let props = Props::new(el);
        let name = el
            .attr("id")
            .map(str::to_string)
            .unwrap_or_else(|| props.kind().to_string());
        // A wrapper's spectra are those of the BSDF it wraps (set by the nested call).
        self.spectra = Spectra::default();
        let bsdf = self.nested(el, |b| b.convert_bsdf(&props))?;
        props.finish(self.diag)?;
        self.bsdfs
            .insert(key, (name.clone(), bsdf.clone(), self.spectra.clone()));
        Ok((name, bsdf))
    }

    /// Whether the `<bsdf>` reflects on both sides: a `twosided` wrapper, possibly inside the
    /// wrappers lumo reads as their first nested BSDF.
    pub(super) fn two_sided(&self, el: &'a Element) -> Result<bool, LoadError> {
        let el = self.resolve(el)?;
        match el.attr("type") {
            Some("twosided") => Ok(true),
            Some("mask" | "bumpmap" | "normalmap" | "blendbsdf") => {
                for c in el.children.iter() {
                    let r = self.resolve(c)?;
                    if r.tag == "bsdf" {
                        return self.two_sided(r);
                    }
                }
                Ok(false)
            }
            _ => Ok(false),
        }
    }

    fn convert_bsdf(&mut self, props: &Props<'a>) -> Result<BsdfSpec, LoadError> {
        let el = props.el;
        let kind = props.kind();
        let at = el.at();
        Ok(match kind {
            "diffuse" => {
                self.spectra.reflectance = props.tabulated("reflectance")?.map(Arc::new);
                BsdfSpec::Diffuse {
                    reflectance: self.texture_param(props, "reflectance", Vec3::splat(0.5))?,
                }
            }
            "normalmap" | "bumpmap" | "mask" => self.wrapper(props)?,
            "twosided" | "blendbsdf" => self.pair(props)?,
            "conductor" | "roughconductor" => {
                let (eta, k) = match props.string("material")? {
                    Some(m) => {
                        let (eta, k) = presets::conductor(&m).ok_or_else(|| {
                            let names: Vec<&str> =
                                presets::CONDUCTORS.iter().map(|c| c.0).collect();
                            LoadError::invalid(
                                at.clone(),
                                format!(
                                    "unknown conductor material {m:?}; Mitsuba's presets are \
                                     none, {}",
                                    names.join(", ")
                                ),
                            )
                        })?;
                        self.spectra.conductor = lumo_spectrum::conductor(&m).map(Arc::new);
                        (Vec3::from(eta), Vec3::from(k))
                    }
                    None => {
                        let (eta_s, k_s) = (props.tabulated("eta")?, props.tabulated("k")?);
                        let eta = self.color_param(props, "eta", Vec3::ZERO)?;
                        let k = self.color_param(props, "k", Vec3::ONE)?;
                        if eta_s.is_some() || k_s.is_some() {
                            // The other one a constant over the visible range.
                            let flat = |v: f32| Tabulated::new(&[(360.0, v), (830.0, v)]);
                            self.spectra.conductor = eta_s
                                .or_else(|| flat(eta.x))
                                .zip(k_s.or_else(|| flat(k.x)))
                                .map(Arc::new);
                        }
                        (eta, k)
                    }
                };
                self.unit_scale(props, "specular_reflectance")?;
                let roughness = if kind == "roughconductor" {
                    self.roughness(props)?
                } else {
                    Roughness::SMOOTH
                };
                BsdfSpec::Conductor { eta, k, roughness }
            }
            "plastic" | "roughplastic" => {
                let ior = self.ior(props)?;
                self.unit_scale(props, "specular_reflectance")?;
                let nonlinear = props.bool("nonlinear", false)?;
                let mut roughness = if kind == "roughplastic" {
                    self.roughness(props)?
                } else {
                    Roughness::SMOOTH
                };
                if roughness.maps.take().is_some() {
                    // Mitsuba's roughplastic takes α as a number only (its coat tables are
                    // integrated once, for one α).
                    self.diag.warn(
                        at.clone(),
                        format!(
                            "roughplastic takes alpha as a number, not a texture; using the \
                             texture's average {}",
                            roughness.alpha_u
                        ),
                    )?;
                }
                if roughness.is_anisotropic() {
                    // Mitsuba refuses this too (its coat tables are one-dimensional).
                    return Err(LoadError::invalid(
                        at,
                        "roughplastic does not support anisotropic roughness (alpha_u != alpha_v)",
                    ));
                }
                self.spectra.reflectance = props.tabulated("diffuse_reflectance")?.map(Arc::new);
                BsdfSpec::Plastic {
                    diffuse: self.texture_param(props, "diffuse_reflectance", Vec3::splat(0.5))?,
                    ior,
                    roughness,
                    nonlinear,
                    exact_rough_coat: true,
                }
            }
            "thindielectric" => {
                let ior = self.ior(props)?;
                self.unit_scale(props, "specular_reflectance")?;
                self.unit_scale(props, "specular_transmittance")?;
                BsdfSpec::ThinDielectric { ior }
            }
            "dielectric" | "roughdielectric" => {
                let ior = self.ior(props)?;
                self.spectra.dispersion = self.dispersion(props);
                self.unit_scale(props, "specular_reflectance")?;
                self.unit_scale(props, "specular_transmittance")?;
                let roughness = if kind == "roughdielectric" {
                    self.roughness(props)?
                } else {
                    Roughness::SMOOTH
                };
                BsdfSpec::Dielectric { ior, roughness }
            }
            "principled" => self.principled(props)?,
            _ => {
                self.diag.warn(
                    at,
                    format!("bsdf {kind:?} is not supported; using a grey diffuse BSDF instead"),
                )?;
                mark_all(props);
                BsdfSpec::Diffuse {
                    reflectance: Texture::Constant(Vec3::splat(0.5)),
                }
            }
        })
    }

    /// `twosided` (one BSDF on both sides, or a front and a back BSDF) and `blendbsdf` (two
    /// BSDFs and a weight). A wrapper's spectra are none of its two BSDFs': spectral rendering
    /// upsamples their RGB values.
    fn pair(&mut self, props: &Props<'a>) -> Result<BsdfSpec, LoadError> {
        let kind = props.kind();
        let at = props.el.at();
        let mut inner = Vec::new();
        for (i, c) in props.nested() {
            let r = self.resolve(c)?;
            if r.tag == "bsdf" {
                props.mark(i);
                inner.push((r.at(), self.bsdf(r)?.1));
            }
        }
        let count = inner.len();
        let mut inner = inner.into_iter();
        match (kind, inner.next(), inner.next()) {
            // lumo's opaque BSDFs already reflect on both sides.
            ("twosided", Some((_, one)), None) => Ok(one),
            ("twosided", Some((at_front, front)), Some((at_back, back))) if count == 2 => {
                for (at, b) in [(at_front, &front), (at_back, &back)] {
                    if transmits(b) {
                        return Err(LoadError::invalid(
                            at,
                            "twosided: a front or back BSDF must only reflect (a dielectric \
                             is two-sided by itself: use it without twosided)",
                        ));
                    }
                }
                self.spectra = Spectra::default();
                Ok(BsdfSpec::TwoSided {
                    front: Box::new(front),
                    back: Box::new(back),
                })
            }
            ("blendbsdf", Some((_, first)), Some((_, second))) if count == 2 => {
                let weight = self.texture_param(props, "weight", Vec3::splat(0.5))?;
                if let Texture::Constant(c) = &weight {
                    if !(c.min_element() >= 0.0 && c.max_element() <= 1.0) {
                        return Err(LoadError::invalid(
                            at,
                            format!("blendbsdf weight {c}: use a value in [0, 1]"),
                        ));
                    }
                }
                self.spectra = Spectra::default();
                Ok(BsdfSpec::Blend {
                    weight,
                    first: Box::new(first),
                    second: Box::new(second),
                })
            }
            _ => Err(LoadError::invalid(
                at,
                format!(
                    "bsdf {kind:?} has {count} nested <bsdf>; it takes {}",
                    if kind == "twosided" {
                        "one (both sides) or two (front, then back)"
                    } else {
                        "two (weight 0 is the first, 1 the second)"
                    }
                ),
            )),
        }
    }

    /// `normalmap`, `bumpmap` and `mask`: a texture and exactly one nested BSDF.
    fn wrapper(&mut self, props: &Props<'a>) -> Result<BsdfSpec, LoadError> {
        let kind = props.kind();
        let at = props.el.at();
        let mut nested = None;
        let mut texture = None;
        for (i, c) in props.nested() {
            let r = self.resolve(c)?;
            if r.tag == "bsdf" {
                props.mark(i);
                if nested.is_some() {
                    return Err(LoadError::invalid(
                        r.at(),
                        format!("bsdf {kind:?} takes exactly one nested <bsdf>"),
                    ));
                }
                nested = Some(Box::new(self.bsdf(r)?.1));
            } else if r.tag == "texture" && kind == "bumpmap" {
                // The height texture may have any name (Mitsuba takes the one nested texture).
                props.mark(i);
                if texture.is_none() {
                    texture = Some(self.texture(r)?);
                }
            }
        }
        let nested = nested.ok_or_else(|| {
            LoadError::invalid(at.clone(), format!("bsdf {kind:?} needs a nested <bsdf>"))
        })?;
        Ok(match kind {
            "normalmap" => {
                if !props.has("normalmap") {
                    return Err(LoadError::invalid(
                        at,
                        "normalmap needs a <texture name=\"normalmap\">",
                    ));
                }
                self.default_on_flags(props)?;
                BsdfSpec::NormalMap {
                    normals: self.texture_param(props, "normalmap", Vec3::new(0.5, 0.5, 1.0))?,
                    nested,
                }
            }
            "bumpmap" => {
                self.default_on_flags(props)?;
                let height = texture.ok_or_else(|| {
                    LoadError::invalid(at.clone(), "bumpmap needs a nested height <texture>")
                })?;
                let scale = props.float("scale", 1.0)?;
                if !scale.is_finite() {
                    return Err(LoadError::invalid(at, "bumpmap scale is not finite"));
                }
                BsdfSpec::BumpMap {
                    height,
                    scale,
                    nested,
                }
            }
            _ => BsdfSpec::Mask {
                opacity: self.texture_param(props, "opacity", Vec3::splat(0.5))?,
                cutoff: None,
                nested,
            },
        })
    }

    /// Mitsuba's `flip_invalid_normals` and `use_shadowing_function` of normal and bump maps:
    /// lumo implements them on (Mitsuba's default) and warns when a file turns them off.
    fn default_on_flags(&mut self, props: &Props<'a>) -> Result<(), LoadError> {
        for flag in ["flip_invalid_normals", "use_shadowing_function"] {
            if !props.bool(flag, true)? {
                self.diag.warn(
                    props.el.at(),
                    format!("{flag} = false is not supported; lumo renders it as true"),
                )?;
            }
        }
        Ok(())
    }

    /// `principled` as Mitsuba 3 defines it: every parameter a value or a texture, `eta` or
    /// `specular` (not both), the three sampling rates.
    fn principled(&mut self, props: &Props<'a>) -> Result<BsdfSpec, LoadError> {
        let at = props.el.at();
        self.spectra.reflectance = props.tabulated("base_color")?.map(Arc::new);
        let base_color = self.texture_param(props, "base_color", Vec3::splat(0.5))?;
        // (name, default, upper bound): Mitsuba asks for values in [0, 1].
        let mut scalar = |name: &str, default: f32| -> Result<Texture, LoadError> {
            let t = self.texture_param(props, name, Vec3::splat(default))?;
            if let Texture::Constant(c) = &t {
                if !(c.min_element() >= 0.0 && c.max_element() <= 1.0) {
                    return Err(LoadError::invalid(
                        at.clone(),
                        format!("principled {name} = {c}: use a value in [0, 1]"),
                    ));
                }
            }
            Ok(t)
        };
        let roughness = scalar("roughness", 0.5)?;
        let anisotropic = scalar("anisotropic", 0.0)?;
        let metallic = scalar("metallic", 0.0)?;
        let spec_trans = scalar("spec_trans", 0.0)?;
        let spec_tint = scalar("spec_tint", 0.0)?;
        let sheen = scalar("sheen", 0.0)?;
        let sheen_tint = scalar("sheen_tint", 0.0)?;
        let clearcoat = scalar("clearcoat", 0.0)?;
        let clearcoat_gloss = scalar("clearcoat_gloss", 0.0)?;
        let flatness = scalar("flatness", 0.0)?;
        let transmits = !matches!(spec_trans, Texture::Constant(c) if c == Vec3::ZERO);
        let eta = match (props.has("eta"), props.has("specular")) {
            (true, true) => {
                return Err(LoadError::invalid(
                    at,
                    "principled takes eta or specular, not both (specular 0.5 is eta 1.5); \
                     remove one",
                ))
            }
            (true, false) => {
                let eta = props.float("eta", 1.5)?;
                if !(eta.is_finite() && eta > 0.0) {
                    return Err(LoadError::invalid(
                        at,
                        format!("principled eta = {eta}: use a positive index ratio"),
                    ));
                }
                // Mitsuba's: an index of 1 cannot refract.
                if transmits && eta == 1.0 {
                    1.001
                } else {
                    eta
                }
            }
            (false, _) => {
                let mut specular = props.float("specular", 0.5)?;
                if !(0.0..=1.0).contains(&specular) {
                    return Err(LoadError::invalid(
                        at,
                        format!("principled specular = {specular}: use a value in [0, 1]"),
                    ));
                }
                if transmits && specular == 0.0 {
                    specular = 1e-3;
                }
                // Mitsuba's map from specular (0.08·F0 at normal incidence) to the index.
                2.0 / (1.0 - (0.08 * specular).sqrt()) - 1.0
            }
        };
        let mut rates = [1.0f32; 3];
        let names = [
            "diffuse_reflectance_sampling_rate",
            "main_specular_sampling_rate",
            "clearcoat_sampling_rate",
        ];
        for (rate, name) in rates.iter_mut().zip(names) {
            *rate = props.float(name, 1.0)?;
            if !(rate.is_finite() && *rate >= 0.0) {
                return Err(LoadError::invalid(
                    at,
                    format!("principled {name} = {rate}: use a rate >= 0"),
                ));
            }
        }
        if rates[0] + rates[1] == 0.0 {
            return Err(LoadError::invalid(
                at,
                "principled: diffuse_reflectance_sampling_rate and \
                 main_specular_sampling_rate are both 0; give one a positive rate",
            ));
        }
        Ok(BsdfSpec::Principled(Arc::new(crate::PrincipledSpec {
            base_color,
            roughness,
            anisotropic,
            metallic,
            spec_trans,
            spec_tint,
            sheen,
            sheen_tint,
            clearcoat,
            clearcoat_gloss,
            flatness,
            eta,
            sampling_rates: rates,
        })))
    }

    /// GGX α from `alpha` (or `alpha_u`/`alpha_v`), warning about Beckmann and anisotropy.
    fn roughness(&mut self, props: &Props<'a>) -> Result<Roughness, LoadError> {
        let at = props.el.at();
        // Mitsuba's default is Beckmann; the name is case-insensitive there.
        let distribution = match props.string("distribution")? {
            None => Distribution::Beckmann,
            Some(d) => match d.to_ascii_lowercase().as_str() {
                "beckmann" => Distribution::Beckmann,
                "ggx" => Distribution::Ggx,
                _ => {
                    return Err(LoadError::invalid(
                        at,
                        format!("unknown microfacet distribution {d:?}; use beckmann or ggx"),
                    ))
                }
            },
        };
        // Visible-normal sampling is all lumo does; it changes only the noise.
        props.accept(&["sample_visible"]);
        let (u, v, isotropic) = if props.has("alpha_u") || props.has("alpha_v") {
            if props.has("alpha") || !(props.has("alpha_u") && props.has("alpha_v")) {
                return Err(LoadError::invalid(
                    at,
                    "give either alpha or both alpha_u and alpha_v (as Mitsuba requires)",
                ));
            }
            (
                self.texture_param(props, "alpha_u", Vec3::splat(0.1))?,
                self.texture_param(props, "alpha_v", Vec3::splat(0.1))?,
                false,
            )
        } else {
            let a = self.texture_param(props, "alpha", Vec3::splat(0.1))?;
            (a.clone(), a, true)
        };
        // A grey value exactly as written (luminance would round it); a colour's luminance.
        let number = |t: &Texture| match t {
            Texture::Constant(c) if c.x == c.y && c.y == c.z => Some(c.x),
            Texture::Constant(c) => Some(lumo_image::luminance(c.to_array())),
            _ => None,
        };
        Ok(match (number(&u), number(&v)) {
            (Some(alpha_u), Some(alpha_v)) => Roughness {
                distribution,
                alpha_u,
                alpha_v,
                maps: None,
            },
            // Per-texel α, as Mitsuba's roughconductor and roughdielectric take it.
            _ => Roughness {
                distribution,
                alpha_u: lumo_image::luminance(u.average().to_array()),
                alpha_v: lumo_image::luminance(v.average().to_array()),
                maps: Some(Arc::new(RoughnessMaps {
                    alpha_u: u,
                    alpha_v: v,
                    isotropic,
                })),
            },
        })
    }

    /// `int_ior / ext_ior`, each a number or a named medium.
    fn ior(&mut self, props: &Props<'a>) -> Result<f32, LoadError> {
        let int = medium_index(props, "int_ior", 1.5046)?;
        let ext = medium_index(props, "ext_ior", AIR)?;
        let ior = int / ext;
        if !(ior.is_finite() && ior > 0.0) {
            return Err(LoadError::invalid(
                props.el.at(),
                format!("int_ior / ext_ior = {int} / {ext} is not a positive ratio"),
            ));
        }
        Ok(ior)
    }

    /// The dispersive glass named by `int_ior` (if lumo knows its dispersion) and the exterior
    /// index the relative index is divided by.
    fn dispersion(&self, props: &Props<'a>) -> Option<(Glass, f32)> {
        let int = props.value("int_ior").filter(|v| v.tag == "string")?;
        let glass = Glass::named(int.attr("value")?.trim())?;
        let ext = medium_index(props, "ext_ior", AIR).ok()?;
        Some((glass, ext))
    }

    /// A scale factor parameter lumo does not model; warns unless it is 1.
    fn unit_scale(&mut self, props: &Props<'a>, name: &str) -> Result<(), LoadError> {
        if props.has(name) {
            let v = self.color_param(props, name, Vec3::ONE)?;
            if v != Vec3::ONE {
                self.diag.warn(
                    props.el.at(),
                    format!("{name} = {v} is not supported (lumo uses 1); ignored"),
                )?;
            }
        }
        Ok(())
    }

    /// A colour parameter; a texture there is replaced by its average with a warning.
    pub(super) fn color_param(
        &mut self,
        props: &Props<'a>,
        name: &str,
        default: Vec3,
    ) -> Result<Vec3, LoadError> {
        let t = self.texture_param(props, name, default)?;
        if let Texture::Constant(c) = t {
            return Ok(c);
        }
        let avg = t.average();
        self.diag.warn(
            props.el.at(),
            format!("a texture for {name} is not supported; using its average {avg}"),
        )?;
        Ok(avg)
    }

    /// A reflectance slot: a value (`<rgb>`, `<spectrum>`, `<float>`) or a nested/referenced
    /// texture.
    pub(super) fn texture_param(
        &mut self,
        props: &Props<'a>,
        name: &str,
        default: Vec3,
    ) -> Result<Texture, LoadError> {
        if let Some(c) = props.color(name)? {
            return Ok(Texture::Constant(c));
        }
        if let Some(el) = props.named_plugin(name) {
            let target = self.resolve(el)?;
            if target.tag != "texture" {
                return Err(LoadError::invalid(
                    el.at(),
                    format!(
                        "{name} must be a colour or a <texture>, not {}",
                        target.describe()
                    ),
                ));
            }
            let texture = self.texture(target)?;
            return self.bounded_reflectance(el, name, texture);
        }
        Ok(Texture::Constant(default))
    }

    /// `texture` as parameter `name`: a reflectance texture (`*reflectance`, `base_color`)
    /// with texels above 1 is read with them at 1, with a warning. Texels of 1e9–3e38 gave
    /// infinite radiance after a few bounces, and black or NaN pixels, without a word (a
    /// constant above 1 is kept, with its own warning: it cannot overflow that way).
    fn bounded_reflectance(
        &mut self,
        el: &Element,
        name: &str,
        texture: Texture,
    ) -> Result<Texture, LoadError> {
        let reflectance = name.ends_with("reflectance") || name == "base_color";
        let Texture::Bitmap {
            image,
            uv_scale,
            filter,
            wrap,
        } = &texture
        else {
            return Ok(texture);
        };
        let max = image.data.iter().copied().fold(0.0f32, f32::max);
        if !reflectance || max <= 1.0 {
            return Ok(texture);
        }
        let above = image.data.iter().filter(|&&v| v > 1.0).count();
        self.diag.warn(
            el.at(),
            format!(
                "{name}: its texture has {above} value(s) above 1 (up to {max:e}); a reflectance \
                 above 1 creates energy and overflows, so they are read as 1"
            ),
        )?;
        let mut clamped = (**image).clone();
        clamped.data.iter_mut().for_each(|v| *v = v.min(1.0));
        Ok(Texture::Bitmap {
            image: Arc::new(clamped),
            uv_scale: *uv_scale,
            filter: *filter,
            wrap: *wrap,
        })
    }

    /// Converts a `<texture>` (cached).
    pub(super) fn texture(&mut self, el: &'a Element) -> Result<Texture, LoadError> {
        let key = el as *const Element as usize;
        if let Some(t) = self.textures.get(&key) {
            return Ok(t.clone());
        }
        let texture = self.nested(el, |b| b.convert_texture(el))?;
        self.textures.insert(key, texture.clone());
        Ok(texture)
    }

    fn convert_texture(&mut self, el: &'a Element) -> Result<Texture, LoadError> {
        let props = Props::new(el);
        let at = el.at();
        let texture = match props.kind() {
            "bitmap" => {
                let file = props.string("filename")?.ok_or_else(|| {
                    LoadError::invalid(at.clone(), "bitmap texture needs a filename")
                })?;
                let raw = props.bool("raw", false)?;
                props.accept(&["format"]);
                let filter = match props.string("filter_type")?.as_deref() {
                    None | Some("bilinear") => TextureFilter::Bilinear,
                    Some("nearest") => TextureFilter::Nearest,
                    Some(other) => {
                        return Err(LoadError::invalid(
                            at.clone(),
                            format!(
                                "filter_type {other:?} is not one of \"bilinear\", \"nearest\""
                            ),
                        ))
                    }
                };
                let wrap = match props.string("wrap_mode")?.as_deref() {
                    None | Some("repeat") => WrapMode::Repeat,
                    Some("mirror") => WrapMode::Mirror,
                    Some("clamp") => WrapMode::Clamp,
                    Some(other) => {
                        return Err(LoadError::invalid(
                            at.clone(),
                            format!(
                            "wrap_mode {other:?} is not one of \"repeat\", \"mirror\", \"clamp\""
                        ),
                        ))
                    }
                };
                let path = self.file_path(el, &file)?;
                let image = self.images.load(&path, raw, &at)?;
                // Mitsuba puts v = 0 at the image's top row, lumo at its bottom row.
                Texture::Bitmap {
                    image: Arc::new(flip_rows(&image)),
                    uv_scale: Vec2::ONE,
                    filter,
                    wrap,
                }
            }
            "checkerboard" => Texture::Checkerboard {
                color0: self.color_param(&props, "color0", Vec3::splat(0.4))?,
                color1: self.color_param(&props, "color1", Vec3::splat(0.2))?,
                // Mitsuba's squares are half a uv unit.
                scale: 2.0,
            },
            other => {
                self.diag.warn(
                    at.clone(),
                    format!("texture {other:?} is not supported; using grey 0.5"),
                )?;
                mark_all(&props);
                Texture::Constant(Vec3::splat(0.5))
            }
        };
        let to_uv = props.transform("to_uv")?;
        props.finish(self.diag)?;
        Ok(if to_uv == Mat4::IDENTITY {
            texture
        } else {
            Texture::Transformed {
                texture: Arc::new(texture),
                uv: uv_affine(&to_uv),
            }
        })
    }
}

/// The (u, v) part of a 4×4 texture transform: uv' = M · (u, v, 0, 1).
fn uv_affine(m: &Mat4) -> Affine2 {
    Affine2::from_cols(
        Vec2::new(m.x_axis.x, m.x_axis.y),
        Vec2::new(m.y_axis.x, m.y_axis.y),
        Vec2::new(m.w_axis.x, m.w_axis.y),
    )
}

fn flip_rows(img: &lumo_image::Image) -> lumo_image::Image {
    let row = img.width * img.channels;
    let mut data = Vec::with_capacity(img.data.len());
    for r in img.data.chunks_exact(row.max(1)).rev() {
        data.extend_from_slice(r);
    }
    lumo_image::Image::from_vec(img.width, img.height, img.channels, data)
}

fn mark_all(props: &Props) {
    for (i, _) in props.el.children.iter().enumerate() {
        props.mark(i);
    }
}

/// The index of refraction `name` (`int_ior` / `ext_ior`): a number or a named medium;
/// `default` where the file gives none.
fn medium_index(props: &Props<'_>, name: &str, default: f32) -> Result<f32, LoadError> {
    let Some(v) = props.value(name) else {
        return Ok(default);
    };
    let text = v.required("value")?;
    if v.tag == "float" {
        return text
            .trim()
            .parse::<f32>()
            .map_err(|_| LoadError::invalid(v.at(), format!("{name}: {text:?} is not a number")));
    }
    presets::dielectric(text).ok_or_else(|| {
        let names: Vec<&str> = presets::DIELECTRICS.iter().map(|d| d.0).collect();
        LoadError::invalid(
            v.at(),
            format!(
                "unknown medium {text:?}; use a number or one of {}",
                names.join(", ")
            ),
        )
    })
}

/// Whether `b` transmits light (a dielectric under any adapters).
fn transmits(b: &BsdfSpec) -> bool {
    match b {
        BsdfSpec::Dielectric { .. } | BsdfSpec::ThinDielectric { .. } => true,
        BsdfSpec::Principled(p) => p.transmits(),
        BsdfSpec::Mask { nested, .. }
        | BsdfSpec::NormalMap { nested, .. }
        | BsdfSpec::BumpMap { nested, .. } => transmits(nested),
        _ => false,
    }
}
