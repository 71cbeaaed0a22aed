//! Scenes that are the merged static mesh plus a few exact shapes (a sphere on a floor, small
//! spherical lamps in a room): their rays skip the instance tree.
//!
//! Why: with one placement a ray goes straight into the static BVH, and sixteen rays go
//! through it as a packet. One exact shape beside it made a second placement, and then every
//! ray walked the instance tree and every packet fell back to single rays — on the Cornell-like
//! `small-lights` scene (three sphere lights) a quarter of the render (issue 50,
//! docs/results/peers.md). Here the static BVH is queried as if it were alone (packets
//! included) and each shape is then tested behind its padded box, the box and shape tests the
//! instance tree would make. The nearest hit is the same: the instance tree too keeps the
//! nearest of the placements' hits. Only a hit at exactly equal distance on the static mesh and
//! a shape may resolve differently (the instance tree takes whichever it visits first).

use glam::Vec3;
use obvhs::ray::Ray;

use crate::accel::packet::{RayPacket, LANES};
use crate::accel::{lane_ray, Accel, Hit, Placement, Target};

/// The most exact shapes a scene may have to skip the instance tree: each ray pays a box test
/// per shape, where the tree's walk costs about one per level.
pub(super) const MAX_SHAPES: usize = 8;

/// Whether `placements` are the static BVH (if any, first) and 1 to [`MAX_SHAPES`] exact
/// shapes, nothing else.
pub(super) fn applies(placements: &[Placement]) -> bool {
    let statics = placements
        .iter()
        .take(1)
        .filter(|p| matches!(p.target, Target::Static))
        .count();
    let shapes = placements
        .iter()
        .filter(|p| matches!(p.target, Target::Analytic { .. }))
        .count();
    (1..=MAX_SHAPES).contains(&shapes) && statics + shapes == placements.len()
}

impl Accel {
    /// Whether the scene is flat (the static BVH and a few exact shapes, see [`applies`]): it
    /// then keeps each placement's box.
    #[inline]
    pub(super) fn flat(&self) -> bool {
        !self.flat_boxes.is_empty()
    }

    /// [`Accel::intersect`] of a flat scene.
    pub(super) fn intersect_flat(
        &self,
        origin: Vec3,
        dir: Vec3,
        tmin: f32,
        tmax: f32,
    ) -> Option<Hit> {
        let best = self.static_closest(origin, dir, tmin, tmax);
        self.shapes_closest(origin, dir, tmin, tmax, best)
    }

    /// [`Accel::occluded`] of a flat scene.
    pub(super) fn occluded_flat(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        let blocked_static = match self.placements.first() {
            Some(p) if matches!(p.target, Target::Static) => {
                self.occluded_placement(p, origin, dir, tmin, tmax)
            }
            _ => false,
        };
        blocked_static || self.shapes_occlude(origin, dir, tmin, tmax)
    }

    /// The nearest hit on the static BVH alone (none if the scene has none).
    #[inline]
    fn static_closest(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        let p = self.placements.first()?;
        if !matches!(p.target, Target::Static) {
            return None;
        }
        let h = self.intersect_placement(p, origin, dir, tmin, tmax)?;
        if h.t < tmax {
            self.scene_hit(0, h)
        } else {
            None
        }
    }

    /// `best` (the static BVH's hit, or none) replaced by the nearest shape hit before it.
    #[inline]
    pub(super) fn shapes_closest(
        &self,
        origin: Vec3,
        dir: Vec3,
        tmin: f32,
        tmax: f32,
        mut best: Option<Hit>,
    ) -> Option<Hit> {
        let ray = Ray::new(origin.into(), dir.into(), tmin, tmax);
        for (pi, p) in self.placements.iter().enumerate() {
            if !matches!(p.target, Target::Analytic { .. }) {
                continue;
            }
            let limit = best.map_or(tmax, |h| h.t);
            // The instance tree's leaf test: a shape whose box is entered at or past the
            // current hit is not tried.
            if self.flat_boxes[pi].intersect_ray(&ray) >= limit {
                continue;
            }
            if let Some(h) = self.intersect_placement(p, origin, dir, tmin, limit) {
                if h.t < limit {
                    best = self.scene_hit(pi, h);
                }
            }
        }
        best
    }

    /// Whether a shape blocks `origin + t·dir` for t in [tmin, tmax].
    #[inline]
    fn shapes_occlude(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        let ray = Ray::new(origin.into(), dir.into(), tmin, tmax);
        self.placements.iter().enumerate().any(|(pi, p)| {
            matches!(p.target, Target::Analytic { .. })
                && self.flat_boxes[pi].intersect_ray(&ray) < tmax
                && self.occluded_placement(p, origin, dir, tmin, tmax)
        })
    }

    /// The shapes' part of a packet query, after the static BVH's packet: `out` (its hits)
    /// takes the nearer shape hits.
    pub(super) fn shapes_closest_packet(&self, rays: &RayPacket, out: &mut [Option<Hit>; LANES]) {
        for (i, o) in out.iter_mut().enumerate().take(rays.count) {
            let (origin, dir) = lane_ray(rays, i);
            *o = self.shapes_closest(origin, dir, rays.tmin[i], rays.tmax[i], *o);
        }
    }

    /// The shapes' part of a packet occlusion query: `blocked` (the static BVH's mask) with
    /// the bits of the rays a shape blocks set.
    pub(super) fn shapes_occlude_packet(&self, rays: &RayPacket, mut blocked: u32) -> u32 {
        for i in 0..rays.count {
            if blocked >> i & 1 == 0 {
                let (origin, dir) = lane_ray(rays, i);
                if self.shapes_occlude(origin, dir, rays.tmin[i], rays.tmax[i]) {
                    blocked |= 1 << i;
                }
            }
        }
        blocked
    }
}

#[cfg(test)]
#[path = "flat_tests.rs"]
mod tests;
