//! Shadow rays through opacity masks (alpha-masked leaves, glTF alpha, Mitsuba's `mask`).
//!
//! Why: a mask's cut-outs pass light straight through, but a shadow ray that meets the mask's
//! geometry used to stop there, so the light reaching a floor through the gaps between leaves
//! was found only by BSDF samples crossing the mask (noisy: 13× Cycles' relMSE on
//! scenes/assets/foliage.glb). A shadow ray now crosses each masked surface it meets with
//! transmittance 1 − opacity at that point, and stops at anything else.
//!
//! The BSDF samples that cross a mask on their way to a light are then weighed by MIS
//! against this light sample from the vertex before the mask (the path keeps that vertex's
//! BSDF density and position across the crossing, `PathState::scatter`), and both strategies
//! cover the same paths: a crossing counts as a bounce, as it does for the BSDF sample, so a
//! shadow ray from a vertex of depth `d` may cross at most `max_depth − d − 1` masks.
//! Scenes with media keep opaque shadows (their volumetric path has its own crossings).

use crate::integrators::path::ShadowRay;
use crate::render_scene::RenderScene;

/// Transmittance of the shadow ray `sh`, which the caller found blocked, through the masks
/// on its way (0 when something opaque blocks it or it would cross more than `max_crossings`
/// masks).
pub(crate) fn transmittance(rs: &RenderScene, sh: &ShadowRay, max_crossings: u32) -> f32 {
    let end = sh.origin + sh.dir * sh.tmax;
    let (mut origin, mut tmax) = (sh.origin, sh.tmax);
    let mut t_all = 1.0f32;
    for _ in 0..=max_crossings {
        let Some(hit) = rs.accel.intersect(origin, sh.dir, 0.0, tmax) else {
            return t_all;
        };
        let s = rs.surface(&hit, origin, sh.dir);
        let opacity = rs.bsdf(&s).opacity();
        if opacity >= 1.0 {
            return 0.0;
        }
        t_all *= 1.0 - opacity;
        if t_all <= 0.0 {
            return 0.0;
        }
        origin = rs.offset(&s, sh.dir);
        tmax = (end - origin).dot(sh.dir);
        if tmax <= 0.0 {
            return t_all;
        }
    }
    0.0
}

/// How many masks a shadow ray of `sh` may cross: the crossings count as bounces
/// (see the module's doc), and `sh.depth` is already the depth of the light vertex.
#[inline]
pub(crate) fn max_crossings(sh: &ShadowRay, max_depth: u32) -> u32 {
    max_depth.saturating_sub(sh.depth)
}

/// Whether shadow rays of `rs` look through masks.
#[inline]
pub(crate) fn applies(rs: &RenderScene) -> bool {
    rs.has_masks() && !rs.scene.media.is_active()
}

/// Adds `sh` to `path` scaled by its transmittance through masks, when it was blocked.
#[inline]
pub(crate) fn credit_blocked(
    rs: &RenderScene,
    path: &mut crate::integrators::path::PathState,
    sh: &ShadowRay,
    max_depth: u32,
) {
    let t = transmittance(rs, sh, max_crossings(sh, max_depth));
    if t > 0.0 {
        path.add_shadow(sh, t);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn crossings_leave_room_for_the_light_vertex() {
        let sh = ShadowRay {
            origin: Vec3::ZERO,
            dir: Vec3::Z,
            tmax: 1.0,
            contribution: Vec3::ONE,
            depth: 3,
        };
        // Vertex at depth 2, light at 3: with max depth 3 no mask may be crossed (the BSDF
        // sample through one would reach the light at depth 4).
        assert_eq!(max_crossings(&sh, 3), 0);
        assert_eq!(max_crossings(&sh, 5), 2);
        assert_eq!(max_crossings(&sh, 2), 0);
    }
}
