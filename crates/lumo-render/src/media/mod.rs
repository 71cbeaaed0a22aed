//! Participating media in transport: free-flight sampling (closed form in homogeneous media,
//! delta tracking over a majorant grid in heterogeneous ones), transmittance along shadow
//! rays (closed form / ratio tracking) and phase functions. The volumetric path tracer that
//! uses them is `integrators/path/volume.rs`; docs/media.md explains the choices.

pub mod phase;
pub mod tracking;
pub(crate) mod walk;

pub use tracking::{free_flight, transmittance_in, Coefficients, Flight};

/// Why `integrator` (named as the user chose it; `renders_media` from its capabilities, see
/// [`crate::Integrator::media_refusal`]) cannot render this scene (`None` where it can): photon
/// mapping does not transport light through media and null boundaries yet, and refuses such a
/// scene rather than render it wrong.
pub fn refusal(scene: &lumo_scene::Scene, integrator: &str, renders_media: bool) -> Option<String> {
    if renders_media || !scene.media.is_active() {
        return None;
    }
    Some(format!(
        "{}: the scene has participating media or null (invisible) boundaries, which the \
         {integrator} integrator does not render; use the path tracer (--integrator path, \
         --spectral included), the light tracer (--integrator light; `both` in lumo serve) or \
         bidirectional path tracing (--integrator bdpt)",
        scene.name
    ))
}

#[cfg(test)]
mod tests {
    use lumo_scene::{Medium, PhaseFunction, Scene, Vec3};

    #[test]
    fn photon_mapping_refuses_media() {
        let mut scene = Scene::empty(crate::test_camera::camera_facing_origin(Vec3::Z));
        let refusal = |scene: &Scene, i: crate::Integrator| i.media_refusal(scene);
        assert_eq!(refusal(&scene, crate::Integrator::Ppm), None);
        scene.media.media.push(Medium {
            name: "fog".into(),
            sigma_t: Vec3::ONE,
            albedo: Vec3::ONE,
            density: lumo_scene::media::Density::Homogeneous,
            phase: PhaseFunction::Isotropic,
            spectra: Default::default(),
        });
        for taker in [
            crate::Integrator::Path,
            crate::Integrator::Light,
            crate::Integrator::Bdpt,
        ] {
            assert_eq!(refusal(&scene, taker), None);
        }
        let why = refusal(&scene, crate::Integrator::Ppm).unwrap();
        assert!(
            why.contains("ppm") && why.contains("--integrator bdpt"),
            "{why}"
        );
    }
}
