//! Participating media in transport: free-flight sampling (closed form in homogeneous media,
//! delta tracking over a majorant grid in heterogeneous ones), transmittance along shadow
//! rays (closed form / ratio tracking) and phase functions. The volumetric path tracer that
//! uses them is `integrators/path/volume.rs`; docs/media.md explains the choices.

pub mod phase;
pub mod tracking;
pub(crate) mod walk;

pub use tracking::{free_flight, transmittance_in, Coefficients, Flight};

/// Why `integrator` cannot render this scene (`None` where it can): only the path tracer
/// transports light through media and null boundaries; every other integrator refuses such a
/// scene rather than render it wrong. `integrator` names it as the user chose it.
pub fn refusal(scene: &lumo_scene::Scene, integrator: &str) -> Option<String> {
    if integrator == "path" || !scene.media.is_active() {
        return None;
    }
    Some(format!(
        "{}: the scene has participating media or null (invisible) boundaries, which the \
         {integrator} integrator does not render; use the path tracer (--integrator path, \
         which renders them, --spectral included)",
        scene.name
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumo_scene::{Camera, FovAxis, Medium, PhaseFunction, Scene, Vec3};

    #[test]
    fn only_the_path_tracer_takes_media() {
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
        });
        assert_eq!(refusal(&scene, "path"), None);
        for other in ["light", "bdpt", "ppm", "both"] {
            let why = refusal(&scene, other).unwrap();
            assert!(
                why.contains(other) && why.contains("--integrator path"),
                "{why}"
            );
        }
    }
}
