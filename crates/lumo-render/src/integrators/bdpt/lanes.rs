//! Helpers of the bidirectional lane loops ([`super::diffuse_walk`], [`super::diffuse_connect`],
//! [`super::diffuse_nee`], [`super::diffuse_splat`]): per-lane arithmetic written as the scalar code writes it (glam's
//! operand order, selects for branches) and a Lambertian surface vertex gathered into lanes.

use glam::Vec3;

use super::connect::ShadowRay;
use super::mis::Near;
use super::vertex::{Kind, Vertex};
use crate::accel::packet::LANES;
use crate::geometry::cosine_pdf;

const N: usize = LANES;

/// Fewest live lanes for which the lane loops run; below it the scalar code does the same work
/// (the same bits) for less, since a lane loop costs sixteen lanes however few are live. The
/// server's streams trace one sample at a time, so their walks and strategies stay scalar.
pub(super) const MIN_VECTOR_LANES: usize = 4;

/// One `f32` per lane.
pub(super) type L = [f32; N];
/// Three components, each one `f32` per lane.
pub(super) type L3 = [L; 3];

/// `a · b` in glam's order.
#[inline(always)]
pub(super) fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    (a[0] * b[0]) + (a[1] * b[1]) + (a[2] * b[2])
}

/// Lane `i` of a three-component array.
#[inline(always)]
pub(super) fn at(v: &L3, i: usize) -> [f32; 3] {
    [v[0][i], v[1][i], v[2][i]]
}

/// Lane `i` of a three-component array as a vector.
#[inline(always)]
pub(super) fn vec3_at(v: &L3, i: usize) -> Vec3 {
    Vec3::new(v[0][i], v[1][i], v[2][i])
}

/// Lane `i`'s shadow ray, from its origin, direction and largest parameter in lanes.
#[inline(always)]
pub(super) fn ray_at(origin: &L3, dir: &L3, tmax: &L, i: usize) -> ShadowRay {
    ShadowRay {
        origin: vec3_at(origin, i),
        dir: vec3_at(dir, i),
        tmax: tmax[i],
    }
}

/// `x` if `c`, else `y` (written as a select for the vectoriser).
#[inline(always)]
pub(super) fn sel(c: bool, x: f32, y: f32) -> f32 {
    if c {
        x
    } else {
        y
    }
}

/// A Lambertian density from the two cosines (`vertex::lambert_pdf`).
#[inline(always)]
pub(super) fn lambert_pdf(zo: f32, zi: f32) -> f32 {
    let neg = zo < 0.0;
    let (zo, zi) = (sel(neg, -zo, zo), sel(neg, -zi, zi));
    sel(zo <= 0.0, 0.0, cosine_pdf(zi))
}

/// The scalar factor of a Lambertian value `albedo · cosine_pdf(zi)` (`vertex::lambert_eval`),
/// 0 where it is black.
#[inline(always)]
pub(super) fn lambert_factor(zo: f32, zi: f32) -> (bool, f32) {
    let neg = zo < 0.0;
    let (zo, zi) = (sel(neg, -zo, zo), sel(neg, -zi, zi));
    (!(zo <= 0.0 || zi <= 0.0), cosine_pdf(zi))
}

/// `|ng · w|`, 1 for a vertex without a normal (`Vertex::arrival_cos`).
#[inline(always)]
pub(super) fn arrival_cos(ng: [f32; 3], w: [f32; 3]) -> f32 {
    let zero = ng[0] == 0.0 && ng[1] == 0.0 && ng[2] == 0.0;
    sel(zero, 1.0, dot(ng, w).abs())
}

/// Whether `v` is a plain Lambertian surface vertex that is not black: the vertices the lane
/// loops of strategies take.
#[inline(always)]
pub(super) fn is_lambertian(v: &Vertex) -> bool {
    matches!(
        v.kind,
        Kind::Surface {
            lambert: Some(_),
            black: false,
            ..
        }
    )
}

/// One side of a join, gathered: the vertex and what its neighbour on its own subpath
/// contributes.
#[derive(Default)]
pub(super) struct Side {
    /// Position.
    pub p: L3,
    /// Unit geometric normal.
    pub ng: L3,
    /// Shading normal.
    pub n: L3,
    /// Throughput up to the vertex.
    pub beta: L3,
    /// Lambertian reflectance.
    pub albedo: L3,
    /// Cosine of the direction back along its own subpath (`wo_local.z`).
    pub wo_z: L,
    /// Cosine of the direction to its predecessor (`wp_local.z`).
    pub wp_z: L,
    /// `|ng · wo|`.
    pub cos_ng_wo: L,
    /// Ray-offset scale.
    pub off: L,
    /// Unit direction to its predecessor.
    pub w_prev: L3,
    /// Squared distance to its predecessor.
    pub d2_prev: L,
    /// The predecessor's normal.
    pub prev_ng: L3,
}

impl Side {
    /// Loads vertex `v` (a Lambertian surface) and its predecessor's normal into lane `i`.
    #[inline(always)]
    pub fn load(&mut self, i: usize, v: &Vertex, prev: &Vertex) {
        let Kind::Surface {
            ref s,
            wo_local,
            wp_local,
            cos_ng_wo,
            lambert,
            ..
        } = v.kind
        else {
            return;
        };
        let albedo = lambert.unwrap_or(Vec3::ZERO);
        for a in 0..3 {
            self.p[a][i] = v.p[a];
            self.ng[a][i] = v.ng[a];
            self.n[a][i] = s.frame.n[a];
            self.beta[a][i] = v.beta[a];
            self.albedo[a][i] = albedo[a];
            self.w_prev[a][i] = v.w_prev[a];
            self.prev_ng[a][i] = prev.ng[a];
        }
        self.wo_z[i] = wo_local.z;
        self.wp_z[i] = wp_local.z;
        self.cos_ng_wo[i] = cos_ng_wo;
        self.off[i] = v.off_scale;
        self.d2_prev[i] = v.d2_prev;
    }

    /// `Vertex::origin_off` of lane `i` towards `w`.
    #[inline(always)]
    pub fn origin_off(&self, i: usize, w: [f32; 3]) -> [f32; 3] {
        let (p, ng) = (at(&self.p, i), at(&self.ng, i));
        let k = sel(dot(ng, w) >= 0.0, self.off[i], -self.off[i]);
        [p[0] + ng[0] * k, p[1] + ng[1] * k, p[2] + ng[2] * k]
    }
}

/// [`Near`] in lanes, one array per field (so that the weight loops vectorise).
#[derive(Default)]
pub(super) struct NearLanes {
    /// [`Near::fwd`].
    pub fwd: L,
    /// [`Near::prev_fwd`].
    pub prev_fwd: L,
    /// [`Near::far_tail`].
    pub far_tail: L,
    /// [`Near::first`].
    pub first: [bool; N],
    /// [`Near::first_counts`].
    pub first_counts: [bool; N],
    /// [`Near::second`].
    pub second: [bool; N],
    /// [`Near::second_counts`].
    pub second_counts: [bool; N],
}

impl NearLanes {
    /// Stores `n` in lane `i`.
    #[inline(always)]
    pub fn set(&mut self, i: usize, n: Near) {
        self.fwd[i] = n.fwd;
        self.prev_fwd[i] = n.prev_fwd;
        self.far_tail[i] = n.far_tail;
        self.first[i] = n.first;
        self.first_counts[i] = n.first_counts;
        self.second[i] = n.second;
        self.second_counts[i] = n.second_counts;
    }

    /// Lane `i`.
    #[inline(always)]
    pub fn at(&self, i: usize) -> Near {
        Near {
            fwd: self.fwd[i],
            prev_fwd: self.prev_fwd[i],
            far_tail: self.far_tail[i],
            first: self.first[i],
            first_counts: self.first_counts[i],
            second: self.second[i],
            second_counts: self.second_counts[i],
        }
    }
}
