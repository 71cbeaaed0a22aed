//! Participating media: what fills space between surfaces (fog, smoke, the inside of a glass
//! of milk), which shapes bound them, and which medium the camera sits in. See docs/media.md.

mod grid;
mod vol;

pub use grid::{DensityGrid, MAJORANT_BLOCK, MAX_GRID_VOXELS};
pub use vol::read_vol;

use std::sync::Arc;

use glam::{Mat4, Vec3};

/// How a medium scatters light: the distribution of the new direction given the old one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PhaseFunction {
    /// Every direction equally likely (1/4π).
    Isotropic,
    /// Henyey–Greenstein with mean cosine `g` in (-1, 1): g > 0 scatters forwards.
    HenyeyGreenstein {
        /// Mean cosine between the incoming and the scattered direction.
        g: f32,
    },
}

/// Where the extinction of a medium comes from.
#[derive(Clone, Debug)]
pub enum Density {
    /// The same everywhere.
    Homogeneous,
    /// A voxel grid (scalar density, multiplied by the medium's `sigma_t`) filling the unit
    /// cube of its own space; zero outside it.
    Grid {
        /// The voxels, their trilinear lookup and their majorant grid.
        grid: Arc<DensityGrid>,
        /// World space → the grid's unit cube (Mitsuba's `to_world` inverted).
        to_local: Mat4,
    },
}

/// A participating medium: extinction σ_t = density · `sigma_t`, scattering σ_s = `albedo` ·
/// σ_t, no emission.
#[derive(Clone, Debug)]
pub struct Medium {
    /// Name used in messages (the file's id).
    pub name: String,
    /// Extinction per unit length per RGB channel (at density 1 for grids; `scale` folded in).
    pub sigma_t: Vec3,
    /// Single-scattering albedo σ_s / σ_t per channel, in [0, 1].
    pub albedo: Vec3,
    /// Homogeneous or a grid.
    pub density: Density,
    /// The phase function.
    pub phase: PhaseFunction,
    /// What the file gave as spectra, for spectral rendering (RGB rendering reads the fields
    /// above, which hold their colours).
    pub spectra: MediumSpectra,
}

/// A medium's coefficients as tabulated spectra where the file gave Mitsuba `<spectrum>`
/// wavelength:value pairs; everything absent is upsampled from the RGB values.
#[derive(Clone, Debug, Default)]
pub struct MediumSpectra {
    /// Extinction per unit length (per unit density for grids), before `sigma_t_scale`.
    pub sigma_t: Option<Arc<lumo_spectrum::Tabulated>>,
    /// Multiplier of `sigma_t` (Mitsuba's `scale`).
    pub sigma_t_scale: f32,
    /// Single-scattering albedo.
    pub albedo: Option<Arc<lumo_spectrum::Tabulated>>,
}

impl Medium {
    /// The largest extinction anywhere in the medium, per channel.
    pub fn max_sigma_t(&self) -> Vec3 {
        match &self.density {
            Density::Homogeneous => self.sigma_t,
            Density::Grid { grid, .. } => self.sigma_t * grid.max(),
        }
    }
}

/// The media on the two sides of a shape, as Mitsuba defines them: `interior` behind the
/// geometric normal, `exterior` in front of it. A ray crossing such a shape enters the medium
/// on the side it goes to; shapes without an interface leave the current medium unchanged.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MediumInterface {
    /// Medium inside (index into [`SceneMedia::media`]; `None`: vacuum).
    pub interior: Option<usize>,
    /// Medium outside.
    pub exterior: Option<usize>,
}

/// What a mesh is to the media: an invisible boundary (Mitsuba's `null` BSDF) and/or a change
/// of medium.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Boundary {
    /// The surface has no BSDF: rays pass straight through it, it neither reflects nor blocks.
    pub null: bool,
    /// The media on its sides (`None`: crossing it does not change the medium).
    pub interface: Option<MediumInterface>,
}

/// The media of a scene; empty (the default) for scenes of surfaces only.
#[derive(Clone, Debug, Default)]
pub struct SceneMedia {
    /// The media.
    pub media: Vec<Medium>,
    /// The medium the camera sits in.
    pub camera: Option<usize>,
    /// Per mesh (index into [`crate::Scene::meshes`]), its boundary role; meshes past the end
    /// are ordinary opaque surfaces.
    pub boundaries: Vec<Boundary>,
}

impl SceneMedia {
    /// Whether the scene needs the volumetric path tracer: it has a medium or an invisible
    /// (null) surface.
    pub fn is_active(&self) -> bool {
        !self.media.is_empty() || self.boundaries.iter().any(|b| b.null)
    }

    /// The boundary role of `mesh`.
    #[inline]
    pub fn boundary(&self, mesh: usize) -> Boundary {
        self.boundaries.get(mesh).copied().unwrap_or_default()
    }

    /// Sets the boundary role of `mesh`.
    pub fn set_boundary(&mut self, mesh: usize, boundary: Boundary) {
        if self.boundaries.len() <= mesh {
            self.boundaries.resize(mesh + 1, Boundary::default());
        }
        self.boundaries[mesh] = boundary;
    }

    /// Checks indices and coefficients so the renderer can trust them.
    pub fn validate(&self, meshes: usize) -> Result<(), crate::SceneError> {
        let bad = |what: String| Err(crate::SceneError::Invalid(what));
        let n = self.media.len();
        let check = |m: Option<usize>, what: &str| match m {
            Some(i) if i >= n => bad(format!(
                "{what} refers to medium {i}, but the scene has {n}"
            )),
            _ => Ok(()),
        };
        check(self.camera, "the camera")?;
        for (i, b) in self.boundaries.iter().enumerate() {
            if i >= meshes && *b != Boundary::default() {
                return bad(format!(
                    "a medium boundary refers to mesh {i}, but the scene has {meshes}"
                ));
            }
            if let Some(f) = b.interface {
                check(f.interior, "a shape's interior")?;
                check(f.exterior, "a shape's exterior")?;
            }
        }
        for m in &self.media {
            if !(m.sigma_t.is_finite() && m.sigma_t.min_element() >= 0.0) {
                return bad(format!(
                    "medium {:?}: sigma_t {} must be finite and ≥ 0 in every channel",
                    m.name, m.sigma_t
                ));
            }
            if !(m.albedo.min_element() >= 0.0 && m.albedo.max_element() <= 1.0) {
                return bad(format!(
                    "medium {:?}: albedo {} must lie in [0, 1] in every channel",
                    m.name, m.albedo
                ));
            }
            if let PhaseFunction::HenyeyGreenstein { g } = m.phase {
                if !(g > -1.0 && g < 1.0) {
                    return bad(format!(
                        "medium {:?}: Henyey–Greenstein g = {g} must lie strictly between -1 \
                         and 1",
                        m.name
                    ));
                }
            }
            if let Density::Grid { to_local, .. } = &m.density {
                if !to_local.is_finite() || to_local.determinant() == 0.0 {
                    return bad(format!(
                        "medium {:?}: the grid's to_world is singular or not finite",
                        m.name
                    ));
                }
            }
        }
        Ok(())
    }
}
