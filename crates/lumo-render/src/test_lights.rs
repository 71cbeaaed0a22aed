//! Test fixture: one light of each kind that is not an emissive surface, placed to light the
//! built-in Cornell box beside its area light (shared by tests that must see every light kind).

use glam::Vec3;
use lumo_scene::Light;

/// A point, a spot, a sun and a constant environment for the Cornell box.
pub(crate) fn every_other_light_kind() -> [Light; 4] {
    [
        Light::Point {
            position: Vec3::new(0.3, 0.5, 0.2),
            intensity: Vec3::splat(2.0),
            range: None,
        },
        Light::Spot {
            position: Vec3::new(-0.4, 0.8, 0.0),
            direction: Vec3::new(0.2, -1.0, 0.1),
            intensity: Vec3::new(3.0, 2.0, 1.0),
            beam_width: 20.0,
            cutoff: 35.0,
            falloff: Default::default(),
            range: None,
        },
        Light::Directional {
            direction: Vec3::new(0.3, -1.0, -0.2),
            irradiance: Vec3::splat(1.5),
        },
        Light::Constant {
            radiance: Vec3::splat(0.2),
        },
    ]
}
