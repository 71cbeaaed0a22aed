//! A procedural hall lit mostly indirectly (being written).

use crate::Scene;

/// Builds the atrium scene.
pub(crate) fn atrium() -> Scene {
    let mut scene = super::cornell::cornell();
    scene.name = "atrium".into();
    scene
}
