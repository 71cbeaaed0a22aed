//! Multiple importance weights of bidirectional strategies with the power heuristic (β = 2),
//! in Veach's ratio form: walking from the connection edge towards either end, each step
//! multiplies the density ratio of the strategy one vertex further along by
//! `(pdf_rev / pdf_fwd)²` of the vertex it moves across, so a weight needs no strategy's
//! full density. Only the two vertices on either side of the connection take densities that
//! depend on it; the products beyond them are the subpaths' own and are summed once per
//! subpath ([`Vertex::tail`]), so each weight is O(1).

use glam::Vec3;

use super::lanes::sel;
use super::vertex::{Context, Vertex};

/// The two subpaths of strategy (s, t), as connected: for `s = 1` the light vertex is the
/// one next-event estimation chose. The four reverse densities next to the connection edge
/// are recomputed from them; the others are the subpaths' own.
pub(super) struct Connection<'a> {
    /// Light vertices `0..s` (for `s = 1`, the light point next-event estimation chose).
    pub light: &'a [Vertex],
    /// Camera vertices `0..t`.
    pub camera: &'a [Vertex],
    /// The connection's geometry where the caller has it.
    pub segment: Option<Segment>,
}

/// The reverse densities of the four vertices next to a strategy's connection, in the order
/// `pt`, `pt−1`, `qs`, `qs−1` (0 where a vertex does not exist): what a weight needs beyond
/// the subpaths' own densities. The lane loops compute them with the strategy's value.
pub(super) type Reverse = [f32; 4];

/// The edge between the last camera vertex `pt` and the last light vertex `qs` of a
/// strategy, as computed for its value.
#[derive(Clone, Copy, Debug)]
pub(super) struct Segment {
    /// Unit direction from `pt` to `qs` (what [`Vertex::towards`] returns).
    pub w: Vec3,
    /// Their squared distance.
    pub dist2: f32,
    /// `pt.local(w)` ([`Vertex::local`]).
    pub w_pt: Vec3,
    /// `qs.local(-w)`.
    pub w_q: Vec3,
}

/// The ratio of a vertex's reverse to forward density; 0 where the forward density is 0
/// (a vertex no strategy could have made that way).
#[inline(always)]
fn ratio(rev: f32, fwd: f32) -> f32 {
    // Computed either way and selected, for the lane loops (the quotient of a rejected pair
    // is never used).
    let r = rev / fwd;
    sel(fwd > 0.0 && rev.is_finite(), r * r, 0.0)
}

/// Stores in every vertex of a camera subpath its [`Vertex::tail`] (built from the squared
/// ratios of reverse to forward density), which the weights of all strategies that do not
/// connect next to it share. Call once the subpath's densities are final.
pub(super) fn set_camera_ratios(path: &mut [Vertex]) {
    // The camera's own vertex starts no strategy (t = 0 does not exist): its tail is empty.
    let mut tail = 0.0f32;
    for i in 0..path.len() {
        let r = ratio(path[i].pdf_rev, path[i].pdf_fwd);
        if i > 0 {
            let counts = !path[i].delta && !path[i - 1].delta;
            tail = r * (f32::from(u8::from(counts)) + tail);
        }
        path[i].tail = tail;
    }
}

/// [`set_camera_ratios`] for a light subpath (its first vertex is the light: the strategy
/// with no light vertex exists where the light is not a Dirac delta).
pub(super) fn set_light_ratios(path: &mut [Vertex]) {
    let mut tail = 0.0f32;
    for i in 0..path.len() {
        let r = ratio(path[i].pdf_rev, path[i].pdf_fwd);
        let counts = !path[i].delta && !delta_before(path, i);
        tail = r * (f32::from(u8::from(counts)) + tail);
        path[i].tail = tail;
    }
}

/// Whether light vertex `i` of `path` was reached through a Dirac delta: the lobe of the
/// vertex before it, or for the light's own vertex a delta light (no strategy joins there).
#[inline(always)]
fn delta_before(path: &[Vertex], i: usize) -> bool {
    if i > 0 {
        path[i - 1].delta
    } else {
        path[0].is_delta_light()
    }
}

/// The power-heuristic weight of strategy (s, t) = (`c.light.len()`, `c.camera.len()`) for
/// the path its vertices form. Pure function of the vertices.
pub(super) fn weight(ctx: &Context, c: &Connection) -> f32 {
    let (light, camera) = (c.light, c.camera);
    let (s, t) = (light.len(), camera.len());
    let pt = &camera[t - 1];
    let qs = s.checked_sub(1).map(|i| &light[i]);
    let pt_minus = t.checked_sub(2).map(|i| &camera[i]);
    let qs_minus = s.checked_sub(2).map(|i| &light[i]);
    // Reverse densities of the vertices next to the connection: the connection's direction
    // and distance computed once, those to the neighbours cached in the vertices.
    let (pt_rev, pt_minus_rev, qs_rev, qs_minus_rev) = match qs {
        Some(q) => {
            let Segment {
                w,
                dist2,
                w_pt,
                w_q,
            } = c.segment.unwrap_or_else(|| {
                let (w, dist2) = pt.towards(q);
                Segment {
                    w,
                    dist2,
                    w_pt: pt.local(w),
                    w_q: q.local(-w),
                }
            });
            let pt_rev = q.pdf_onward(ctx, pt, -w, w_q, dist2);
            let qs_rev = pt.pdf_onward(ctx, q, w, w_pt, dist2);
            let pt_minus_rev = pt_minus.map_or(0.0, |m| pt.pdf_back(ctx, w, w_pt, m));
            let qs_minus_rev = qs_minus.map_or(0.0, |m| q.pdf_back(ctx, -w, w_q, m));
            (pt_rev, pt_minus_rev, qs_rev, qs_minus_rev)
        }
        None => {
            let (pt_rev, pt_minus_rev) =
                pt_minus.map_or((0.0, 0.0), |m| pt.as_light_origin(ctx, m));
            (pt_rev, pt_minus_rev, 0.0, 0.0)
        }
    };
    sum_weight(light, camera, [pt_rev, pt_minus_rev, qs_rev, qs_minus_rev])
}

/// The weight of strategy (s, t) given the reverse densities of the four vertices next to
/// its connection (`pt`, `pt−1`, `qs`, `qs−1`; 0 where a vertex does not exist).
#[inline(always)]
fn sum_weight(light: &[Vertex], camera: &[Vertex], reverse: Reverse) -> f32 {
    let pt = Near::camera(camera, camera.len() - 1);
    let qs = match light.len() {
        0 => Near::NONE,
        s => Near::light(light, s - 1),
    };
    near_weight(&pt, &qs, reverse)
}

/// What a weight needs of one connection vertex's own subpath: the forward densities of the
/// vertex and of the one before it, which of the two strategies that move the connection
/// one and two vertices back along that subpath exist and count (none next to a Dirac
/// lobe), and the farther strategies' share (the [`Vertex::tail`] of the vertex two back).
/// Plain values, so that the lane loops weigh sixteen strategies at once with the scalar
/// weight's operations ([`near_weight`]).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Near {
    /// The vertex's forward density.
    pub fwd: f32,
    /// Its predecessor's forward density (read only where `second`).
    pub prev_fwd: f32,
    /// The tail of the vertex two back (0 where there is none).
    pub far_tail: f32,
    /// The strategy one vertex back exists.
    pub first: bool,
    /// …and counts.
    pub first_counts: bool,
    /// The strategy two vertices back exists.
    pub second: bool,
    /// …and counts.
    pub second_counts: bool,
}

impl Near {
    /// A side with no vertex (s = 0) or none behind it that starts a strategy: no terms.
    pub const NONE: Near = Near {
        fwd: 0.0,
        prev_fwd: 0.0,
        far_tail: 0.0,
        first: false,
        first_counts: false,
        second: false,
        second_counts: false,
    };

    /// A light vertex with nothing behind it on its subpath (of a light subpath or a light
    /// point next-event estimation chose), of forward density `fwd`: only the strategy one
    /// vertex back, which counts unless the vertex was reached through a Dirac delta.
    #[inline(always)]
    pub fn light_origin(fwd: f32, delta_before: bool) -> Near {
        Near {
            fwd,
            first: true,
            first_counts: !delta_before,
            ..Near::NONE
        }
    }

    /// Camera vertex `j` (t = j + 1) of `path`, whose ratios are set
    /// ([`set_camera_ratios`]): strategies with one and two camera vertices fewer exist from
    /// t ≥ 2 and t ≥ 3.
    #[inline(always)]
    pub fn camera(path: &[Vertex], j: usize) -> Near {
        let mut n = Near {
            fwd: path[j].pdf_fwd,
            ..Near::NONE
        };
        if j >= 1 {
            n.first = true;
            n.first_counts = !path[j - 1].delta;
        }
        if j >= 2 {
            n.second = true;
            n.second_counts = !path[j - 1].delta && !path[j - 2].delta;
            n.prev_fwd = path[j - 1].pdf_fwd;
            n.far_tail = path[j - 2].tail;
        }
        n
    }

    /// Light vertex `j` (s = j + 1) of `path`, whose ratios are set ([`set_light_ratios`];
    /// a light point next-event estimation chose is a path of its own): strategies with one
    /// and two light vertices fewer exist from s ≥ 1 and s ≥ 2, the one without light
    /// vertices where the light is not a Dirac delta.
    #[inline(always)]
    pub fn light(path: &[Vertex], j: usize) -> Near {
        let mut n = Near::light_origin(path[j].pdf_fwd, delta_before(path, j));
        if j >= 1 {
            n.second = true;
            n.second_counts = !path[j - 1].delta && !delta_before(path, j - 1);
            n.prev_fwd = path[j - 1].pdf_fwd;
        }
        if j >= 2 {
            n.far_tail = path[j - 2].tail;
        }
        n
    }
}

/// The weight of a strategy from its two connection vertices' [`Near`] and the reverse
/// densities of the four vertices next to its connection (`pt`, `pt−1`, `qs`, `qs−1`; 0
/// where a vertex does not exist). Selects instead of branches, so that a lane loop that
/// calls it per lane vectorises.
#[inline(always)]
pub(super) fn near_weight(
    pt: &Near,
    qs: &Near,
    [pt_rev, pt_minus_rev, qs_rev, qs_minus_rev]: Reverse,
) -> f32 {
    // The camera side's strategies, then the light side's, nearest first.
    let sum = side_sum(0.0, pt, pt_rev, pt_minus_rev);
    let sum = side_sum(sum, qs, qs_rev, qs_minus_rev);
    let w = 1.0 / (1.0 + sum);
    sel(w.is_finite(), w, 0.0)
}

/// Adds to `sum` one side's strategies with fewer vertices on that side: the two next to
/// the connection with its recomputed densities `rev` and `rev_prev` (the running product
/// starts at the first one's ratio, as `1 · ratio` would), then the farther ones as the
/// running product times the subpath's tail (an empty tail is skipped, so that an infinite
/// product adds nothing there).
#[inline(always)]
fn side_sum(sum: f32, n: &Near, rev: f32, rev_prev: f32) -> f32 {
    let r = sel(n.first, ratio(rev, n.fwd), 1.0);
    let sum = sel(n.first && n.first_counts, sum + r, sum);
    let r = sel(n.second, r * ratio(rev_prev, n.prev_fwd), r);
    let sum = sel(n.second && n.second_counts, sum + r, sum);
    sel(n.far_tail != 0.0, sum + r * n.far_tail, sum)
}
