//! Mitsuba `<medium>` (homogeneous and heterogeneous), `<phase>`, the media of shapes
//! (`interior` / `exterior`) and of the sensor, and the `null` BSDF that bounds a medium
//! without being seen. See docs/media.md.

use std::sync::Arc;

use glam::Vec3;

use super::props::Props;
use super::xml::Element;
use super::Builder;
use crate::load::LoadError;
use crate::media::{
    read_vol, Boundary, Density, Medium, MediumInterface, MediumSpectra, PhaseFunction,
};

impl<'a> Builder<'a, '_> {
    /// The medium of `<medium>` element `el` (converted once, however often referenced):
    /// its index in the scene's media.
    pub(super) fn medium(&mut self, el: &'a Element) -> Result<usize, LoadError> {
        let key = el as *const Element as usize;
        if let Some(&m) = self.media.get(&key) {
            return Ok(m);
        }
        let props = Props::new(el);
        let at = el.at();
        let name = el.attr("id").unwrap_or(props.kind()).to_string();
        let scale = props.float("scale", 1.0)?;
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(LoadError::invalid(
                at,
                format!("medium {name:?}: scale {scale} must be finite and ≥ 0"),
            ));
        }
        let mut spectra = MediumSpectra {
            sigma_t_scale: scale,
            ..MediumSpectra::default()
        };
        let (sigma_t, albedo, density) = match props.kind() {
            "homogeneous" => {
                let (sigma_t, albedo) = if props.has("sigma_a") || props.has("sigma_s") {
                    // Mitsuba 0.6's parameters: absorption and scattering.
                    if props.tabulated("sigma_a")?.is_some()
                        || props.tabulated("sigma_s")?.is_some()
                    {
                        self.diag.warn(
                            at.clone(),
                            format!(
                                "medium {name:?}: sigma_a / sigma_s given as spectra are read \
                                 as their RGB colours (--spectral upsamples those); give \
                                 sigma_t and albedo to keep the spectra"
                            ),
                        )?;
                    }
                    let a = self.medium_color(&props, "sigma_a", Vec3::ZERO)?;
                    let s = self.medium_color(&props, "sigma_s", Vec3::ZERO)?;
                    let t = a + s;
                    let albedo = Vec3::select(t.cmpgt(Vec3::ZERO), s / t, Vec3::ZERO);
                    (t, albedo)
                } else {
                    spectra.sigma_t = props.tabulated("sigma_t")?.map(Arc::new);
                    (
                        self.medium_color(&props, "sigma_t", Vec3::ONE)?,
                        self.medium_color(&props, "albedo", Vec3::splat(0.75))?,
                    )
                };
                (sigma_t, albedo, Density::Homogeneous)
            }
            "heterogeneous" => {
                let grid_el = props.named_plugin("sigma_t").ok_or_else(|| {
                    LoadError::invalid(
                        at.clone(),
                        format!(
                            "heterogeneous medium {name:?} needs <volume name=\"sigma_t\" \
                             type=\"gridvolume\"> with a .vol filename"
                        ),
                    )
                })?;
                let grid_el = self.resolve(grid_el)?;
                let (density, sigma_t) = self.grid_volume(grid_el)?;
                (
                    sigma_t,
                    self.medium_color(&props, "albedo", Vec3::splat(0.75))?,
                    density,
                )
            }
            other => {
                return Err(LoadError::invalid(
                    at,
                    format!(
                        "medium type {other:?} is not supported; lumo reads homogeneous and \
                         heterogeneous (gridvolume) media"
                    ),
                ))
            }
        };
        spectra.albedo = props.tabulated("albedo")?.map(Arc::new);
        let sigma_t = sigma_t * scale;
        if !sigma_t.is_finite() {
            return Err(LoadError::invalid(
                at,
                format!(
                    "medium {name:?}: sigma_t × scale = {sigma_t} is not finite; give a finite \
                     extinction (an opaque medium is a surface)"
                ),
            ));
        }
        if albedo.max_element() > 1.0 {
            return Err(LoadError::invalid(
                at,
                format!(
                    "medium {name:?}: albedo {albedo} is above 1 (a medium cannot scatter more \
                     than it extinguishes); use values in [0, 1]"
                ),
            ));
        }
        if sigma_t == Vec3::ZERO {
            self.diag.warn(
                at.clone(),
                format!("medium {name:?} has sigma_t = 0: it neither scatters nor absorbs"),
            )?;
        }
        let mut phase = PhaseFunction::Isotropic;
        for (i, c) in props.nested() {
            let r = self.resolve(c)?;
            if r.tag == "phase" {
                props.mark(i);
                phase = self.phase(r)?;
            }
        }
        if !props.bool("sample_emitters", true)? {
            self.diag.warn(
                at.clone(),
                "sample_emitters = false is ignored: lumo always samples emitters from media",
            )?;
        }
        props.finish(self.diag)?;
        let index = self.scene.media.media.len();
        self.scene.media.media.push(Medium {
            name,
            sigma_t,
            albedo,
            density,
            phase,
            spectra,
        });
        self.media.insert(key, index);
        Ok(index)
    }

    /// A colour parameter of a medium: `<rgb>`, `<float>`, `<spectrum>` or a `constvolume`
    /// holding one.
    fn medium_color(
        &mut self,
        props: &Props<'a>,
        name: &str,
        default: Vec3,
    ) -> Result<Vec3, LoadError> {
        if let Some(v) = props.color(name)? {
            return Ok(v);
        }
        let Some(el) = props.named_plugin(name) else {
            return Ok(default);
        };
        let el = self.resolve(el)?;
        let inner = Props::new(el);
        if el.tag != "volume" || inner.kind() != "constvolume" {
            return Err(LoadError::invalid(
                el.at(),
                format!(
                    "{name}: {} is not supported here; give a number, an <rgb> or a \
                     constvolume",
                    el.describe()
                ),
            ));
        }
        let v = inner.color("value")?.unwrap_or(Vec3::ONE);
        inner.finish(self.diag)?;
        Ok(v)
    }

    /// A `gridvolume`: the density, and the extinction per unit density (1; the medium's
    /// `scale` multiplies it).
    fn grid_volume(&mut self, el: &'a Element) -> Result<(Density, Vec3), LoadError> {
        let props = Props::new(el);
        let at = el.at();
        if el.tag != "volume" || !matches!(props.kind(), "gridvolume" | "grid") {
            return Err(LoadError::invalid(
                at,
                format!(
                    "sigma_t of a heterogeneous medium is {}; lumo reads a <volume \
                     type=\"gridvolume\"> with a .vol filename",
                    el.describe()
                ),
            ));
        }
        let file = props.string("filename")?.ok_or_else(|| {
            LoadError::invalid(at.clone(), "gridvolume needs a filename (a .vol file)")
        })?;
        let path = self.file_path(el, &file)?;
        let grid = read_vol(&path).map_err(|e| {
            LoadError::invalid(
                at.clone(),
                format!("gridvolume file {}: {e}", path.display()),
            )
        })?;
        match props.string("filter_type")?.as_deref() {
            None | Some("trilinear") => {}
            Some(other) => self.diag.warn(
                at.clone(),
                format!("gridvolume filter_type {other:?}: lumo interpolates trilinearly"),
            )?,
        }
        match props.string("wrap_mode")?.as_deref() {
            None | Some("clamp") => {}
            Some(other) => self.diag.warn(
                at.clone(),
                format!("gridvolume wrap_mode {other:?}: lumo clamps lookups to the grid"),
            )?,
        }
        if props.bool("use_grid_bbox", false)? {
            self.diag.warn(
                at.clone(),
                "gridvolume use_grid_bbox is ignored: the grid fills the unit cube of its \
                 to_world, Mitsuba 3's default",
            )?;
        }
        props.accept(&["raw", "accel"]);
        let to_world = props.transform("to_world")?;
        if !to_world.is_finite() || to_world.determinant() == 0.0 {
            return Err(LoadError::invalid(
                at,
                "gridvolume to_world is singular or not finite",
            ));
        }
        props.finish(self.diag)?;
        Ok((
            Density::Grid {
                grid: Arc::new(grid),
                to_local: to_world.inverse(),
            },
            Vec3::ONE,
        ))
    }

    /// A `<phase>` function.
    fn phase(&mut self, el: &'a Element) -> Result<PhaseFunction, LoadError> {
        let props = Props::new(el);
        let phase = match props.kind() {
            "isotropic" => PhaseFunction::Isotropic,
            "hg" => {
                let g = props.float("g", 0.8)?;
                if !(g > -1.0 && g < 1.0) {
                    return Err(LoadError::invalid(
                        el.at(),
                        format!("hg phase function: g = {g} must lie strictly between -1 and 1"),
                    ));
                }
                PhaseFunction::HenyeyGreenstein { g }
            }
            other => {
                self.diag.warn(
                    el.at(),
                    format!("phase function {other:?} is not supported by lumo; using isotropic"),
                )?;
                return Ok(PhaseFunction::Isotropic);
            }
        };
        props.finish(self.diag)?;
        Ok(phase)
    }

    /// The medium nested in (or referenced by) a `<sensor>`: the camera sits in it.
    pub(super) fn sensor_medium(&mut self, props: &Props<'a>) -> Result<(), LoadError> {
        for (i, c) in props.nested() {
            let r = self.resolve(c)?;
            if r.tag == "medium" {
                props.mark(i);
                self.scene.media.camera = Some(self.medium(r)?);
            }
        }
        Ok(())
    }

    /// The boundary role of the `<shape>` being read (`bsdf` its BSDF element): media named
    /// `interior` / `exterior` in it, and whether its BSDF is `null`. Recorded for the mesh
    /// the caller adds next.
    pub(super) fn shape_boundary(
        &mut self,
        props: &Props<'a>,
        bsdf: Option<&'a Element>,
        emits: bool,
    ) -> Result<(), LoadError> {
        let mut interface = MediumInterface::default();
        let mut any = false;
        for (i, c) in props.nested() {
            let r = self.resolve(c)?;
            if r.tag != "medium" {
                continue;
            }
            props.mark(i);
            let m = Some(self.medium(r)?);
            match c.attr("name").or(r.attr("name")) {
                Some("interior") => interface.interior = m,
                Some("exterior") => interface.exterior = m,
                other => {
                    return Err(LoadError::invalid(
                        c.at(),
                        format!(
                            "a medium in a shape needs name=\"interior\" or name=\"exterior\" \
                             (got {other:?})"
                        ),
                    ))
                }
            }
            any = true;
        }
        let null = bsdf.is_some_and(|b| b.attr("type") == Some("null"));
        if null && emits {
            return Err(LoadError::invalid(
                props.el.at(),
                "a shape with a null BSDF and an area emitter: lumo's invisible boundaries do \
                 not emit; give the emitter its own shape",
            ));
        }
        let boundary = Boundary {
            null,
            interface: any.then_some(interface),
        };
        if boundary != Boundary::default() {
            let mesh = self.scene.meshes.len();
            self.scene.media.set_boundary(mesh, boundary);
        }
        Ok(())
    }
}
