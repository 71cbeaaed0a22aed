//! Rays through a scene's media: which medium a ray enters at a boundary, the transmittance
//! of a shadow ray across null boundaries, the medium around a point, and the lanes'
//! path-space MIS record. Shared by the volumetric path tracer and the light tracer, so both
//! walk the same media the same way.

use glam::Vec3;
use lumo_scene::{MediumInterface, SceneMedia};
use lumo_spectrum::Wavelengths;

use super::{transmittance_in, Coefficients, Flight};
use crate::accel::Hit;
use crate::render_scene::RenderScene;
use crate::sampler::PixelSampler;

/// Null surfaces a ray may cross before the path (or shadow ray) is ended: a guard against
/// rays caught between coincident boundaries, far above what a scene nests.
pub(crate) const MAX_CROSSINGS: u32 = 256;

/// The medium a ray in direction `d` enters at a surface of geometric normal `ng`.
#[inline]
pub(crate) fn target(f: MediumInterface, ng: Vec3, d: Vec3) -> Option<usize> {
    if d.dot(ng) > 0.0 {
        f.exterior
    } else {
        f.interior
    }
}

/// The mesh a hit belongs to.
#[inline]
pub(crate) fn mesh_of(rs: &RenderScene, hit: &Hit) -> usize {
    rs.scene.instances[hit.instance as usize].mesh
}

/// The transmittance from `o` along unit `d` up to `tmax` (a negative `tmax`: nothing to
/// cross), starting in medium `medium`: zero at the first surface that is not a null
/// boundary, else the product of every medium's transmittance on the way. `wl` are the path's
/// wavelengths under spectral transport; every null crossing adds one to `rays`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn transmittance(
    rs: &RenderScene,
    mut medium: Option<usize>,
    mut o: Vec3,
    mut d: Vec3,
    tmax: f32,
    wl: Option<&Wavelengths>,
    sampler: &mut PixelSampler,
    rays: &mut u32,
) -> Vec3 {
    let media: &SceneMedia = &rs.scene.media;
    let mut tr = Vec3::ONE;
    if tmax.is_nan() || tmax <= 0.0 {
        return tr;
    }
    let end = o + d * tmax;
    let mut left = tmax;
    for _ in 0..MAX_CROSSINGS {
        let hit = rs.accel.intersect(o, d, 0.0, left);
        let seg = hit.map_or(left, |h| h.t);
        if let Some(m) = medium {
            let med = &media.media[m];
            let c = Coefficients::of(med, wl);
            tr *= transmittance_in(med, &c, o, d, seg, sampler);
            if tr == Vec3::ZERO {
                return tr;
            }
        }
        let Some(h) = hit else {
            return tr;
        };
        let b = media.boundary(mesh_of(rs, &h));
        if !b.null {
            return Vec3::ZERO;
        }
        *rays += 1;
        let s = rs.surface(&h, o, d);
        if let Some(f) = b.interface {
            medium = target(f, s.ng, d);
        }
        o = rs.offset(&s, d);
        if tmax.is_finite() {
            // Re-aimed at the end point: the offset moved the origin off the ray's line, and
            // at a grazing angle to a light parallel to the boundary the old line would now
            // reach into the light (a null box just below a ceiling light lost 14 % of it).
            let to_end = end - o;
            left = to_end.length();
            if !(left > 0.0 && to_end.dot(d) > 0.0) {
                return tr;
            }
            d = to_end / left;
        }
    }
    Vec3::ZERO
}

/// The medium around `p` as a path from the camera at `eye` would find it: the camera's
/// medium, changed at every surface with an interface that the segment from `eye` to `p`
/// crosses (Mitsuba's convention: a shape without one leaves the medium as it is). Counts the
/// rays it traces into `rays`.
pub(crate) fn medium_at(rs: &RenderScene, eye: Vec3, p: Vec3, rays: &mut u32) -> Option<usize> {
    let media = &rs.scene.media;
    let mut medium = media.camera;
    let mut o = eye;
    for _ in 0..MAX_CROSSINGS {
        let to_p = p - o;
        let left = to_p.length();
        if left.is_nan() || left <= 0.0 {
            break;
        }
        let d = to_p / left;
        *rays += 1;
        let Some(h) = rs.accel.intersect(o, d, 0.0, left) else {
            break;
        };
        let s = rs.surface(&h, o, d);
        if let Some(f) = media.boundary(mesh_of(rs, &h)).interface {
            medium = target(f, s.ng, d);
        }
        o = rs.offset(&s, d);
        if (p - o).dot(d) <= 0.0 {
            break;
        }
    }
    medium
}

/// The path-space balance heuristic over colour lanes (tracking.rs): the lane whose
/// exponentials sample homogeneous media, and per lane the ratio of the path's density under
/// that lane's choice to its density under this one.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneMis {
    /// The sampling lane (0..3).
    pub lane: usize,
    ratio: Vec3,
}

impl LaneMis {
    /// A path's record, its lane drawn from `u` in [0, 1).
    pub fn new(u: f32) -> Self {
        LaneMis {
            lane: ((u * 3.0) as usize).min(2),
            ratio: Vec3::ONE,
        }
    }

    /// Applies a free flight to `throughput`, which stays f / mean(p_lane): a step that
    /// changes the lanes' ratios rescales it by the old mean over the new.
    pub fn apply(&mut self, throughput: &mut Vec3, flight: &Flight) {
        let (Flight::Scatter {
            weight, ratio: r, ..
        }
        | Flight::Pass { weight, ratio: r }) = *flight;
        let new = self.ratio * r;
        let (before, after) = (self.ratio.element_sum(), new.element_sum());
        *throughput *= if after > 0.0 {
            weight * (before / after)
        } else {
            Vec3::ZERO
        };
        self.ratio = if after > 0.0 {
            new * (3.0 / after)
        } else {
            Vec3::ONE
        };
    }
}
