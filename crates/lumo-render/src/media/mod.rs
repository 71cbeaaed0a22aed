//! Participating media in transport: free-flight sampling (closed form in homogeneous media,
//! delta tracking over a majorant grid in heterogeneous ones), transmittance along shadow
//! rays (closed form / ratio tracking) and phase functions. The volumetric path tracer that
//! uses them is `integrators/path/volume.rs`; docs/media.md explains the choices.

pub mod phase;
pub mod tracking;

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
