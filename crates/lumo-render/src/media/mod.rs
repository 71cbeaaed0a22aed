//! Participating media in transport: free-flight sampling (closed form in homogeneous media,
//! delta tracking over a majorant grid in heterogeneous ones), transmittance along shadow
//! rays (closed form / ratio tracking) and phase functions. The volumetric path tracer that
//! uses them is `integrators/path/volume.rs`; docs/media.md explains the choices.

pub mod phase;
pub mod tracking;
pub(crate) mod walk;

pub use tracking::{free_flight, transmittance_in, Coefficients, Flight};

/// The integrators, as `lumo render` and `lumo serve` name them, that transport light through
/// media and null boundaries: the path tracer, the light tracer, and `lumo serve`'s `both`
/// (the two together).
pub const RENDER_MEDIA: [&str; 3] = ["path", "light", "both"];

/// Whether `integrator` (named as in [`RENDER_MEDIA`]) renders scenes with media.
pub fn renders_media(integrator: &str) -> bool {
    RENDER_MEDIA.contains(&integrator)
}

/// Why `integrator` cannot render this scene (`None` where it can): BDPT and photon mapping
/// do not transport light through media and null boundaries yet, and refuse such a scene
/// rather than render it wrong. `integrator` names it as the user chose it.
pub fn refusal(scene: &lumo_scene::Scene, integrator: &str) -> Option<String> {
    if renders_media(integrator) || !scene.media.is_active() {
        return None;
    }
    Some(format!(
        "{}: the scene has participating media or null (invisible) boundaries, which the \
         {integrator} integrator does not render; use the path tracer (--integrator path, \
         --spectral included) or the light tracer (--integrator light; `both` in lumo serve)",
        scene.name
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumo_scene::{Camera, FovAxis, Medium, PhaseFunction, Scene, Vec3};

    #[test]
    fn bdpt_and_photon_mapping_refuse_media() {
        let mut scene = Scene::empty(Camera {
            origin: Vec3::Z,
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov: 40.0,
            fov_axis: FovAxis::X,
            lens: Default::default(),
            filter: Default::default(),
        });
        assert_eq!(refusal(&scene, "bdpt"), None);
        scene.media.media.push(Medium {
            name: "fog".into(),
            sigma_t: Vec3::ONE,
            albedo: Vec3::ONE,
            density: lumo_scene::media::Density::Homogeneous,
            phase: PhaseFunction::Isotropic,
            spectra: Default::default(),
        });
        for taker in RENDER_MEDIA {
            assert_eq!(refusal(&scene, taker), None);
        }
        for other in ["bdpt", "ppm"] {
            let why = refusal(&scene, other).unwrap();
            assert!(
                why.contains(other) && why.contains("--integrator path"),
                "{why}"
            );
        }
    }
}
