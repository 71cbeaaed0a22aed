//! A mesh's wide BVH in the form this CPU traverses fastest: 8-wide with AVX2 + FMA
//! ([`crate::accel::bvh8`]), else 4-wide ([`crate::accel::bvh4`]).
//!
//! `LUMO_BVH_WIDTH=4` in the environment forces the 4-wide form (for A/B measurements and to
//! reproduce an image made on a CPU without AVX2: the two differ in the last bits of hit
//! distances, so images agree to rounding, not bit for bit).

use std::sync::OnceLock;

use glam::Vec3;
use obvhs::bvh2::Bvh2;

use crate::accel::bvh4::Bvh4;
use crate::accel::bvh8::Bvh8;
use crate::accel::wide::{TriHit, WideBvh};

/// The wide BVH of one mesh.
#[derive(Clone, Debug)]
pub(crate) enum WideBlas {
    /// 4-wide nodes and leaves, SSE traversal.
    Four(Bvh4),
    /// 8-wide nodes and leaves, AVX2 traversal.
    Eight(Bvh8),
}

/// The BVH width to build: 8 where AVX2 and FMA are available, unless `LUMO_BVH_WIDTH=4`.
pub(crate) fn preferred_width() -> usize {
    static WIDTH: OnceLock<usize> = OnceLock::new();
    *WIDTH.get_or_init(|| {
        let forced_four = std::env::var("LUMO_BVH_WIDTH").is_ok_and(|v| v.trim() == "4");
        if !forced_four && Bvh8::available() {
            8
        } else {
            4
        }
    })
}

impl WideBlas {
    /// Collapses `bvh2` over one mesh's triangles into the preferred width.
    pub fn build(bvh2: &Bvh2, positions: &[Vec3], indices: &[[u32; 3]]) -> Self {
        Self::build_width(preferred_width(), bvh2, positions, indices)
    }

    /// Collapses `bvh2` into `width` lanes (8 falls back to 4 without AVX2).
    pub fn build_width(
        width: usize,
        bvh2: &Bvh2,
        positions: &[Vec3],
        indices: &[[u32; 3]],
    ) -> Self {
        if width == 8 {
            if let Some(b) = Bvh8::new(WideBvh::from_bvh2(bvh2, positions, indices)) {
                return WideBlas::Eight(b);
            }
        }
        WideBlas::Four(Bvh4::from_bvh2(bvh2, positions, indices))
    }

    /// The 8-wide form, which also traverses packets of rays.
    #[inline]
    pub fn eight(&self) -> Option<&Bvh8> {
        match self {
            WideBlas::Four(_) => None,
            WideBlas::Eight(b) => Some(b),
        }
    }

    /// Nearest hit of `origin + t·dir` with t in [tmin, tmax].
    #[inline]
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<TriHit> {
        match self {
            WideBlas::Four(b) => b.intersect(origin, dir, tmin, tmax),
            WideBlas::Eight(b) => b.intersect(origin, dir, tmin, tmax),
        }
    }

    /// True if anything hits `origin + t·dir` with t in [tmin, tmax].
    #[inline]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        match self {
            WideBlas::Four(b) => b.occluded(origin, dir, tmin, tmax),
            WideBlas::Eight(b) => b.occluded(origin, dir, tmin, tmax),
        }
    }
}
