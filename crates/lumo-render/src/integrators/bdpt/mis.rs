//! Multiple importance weights of bidirectional strategies with the power heuristic (β = 2),
//! in Veach's ratio form: walking from the connection edge towards either end, each step
//! multiplies the density ratio of the strategy one vertex further along by
//! `(pdf_rev / pdf_fwd)²` of the vertex it moves across, so a weight needs no strategy's
//! full density. Only the two vertices on either side of the connection take densities that
//! depend on it; the products beyond them are the subpaths' own and are summed once per
//! subpath ([`Vertex::tail`]), so each weight is O(1).

use glam::Vec3;

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
    /// The four reverse densities next to the connection where the caller computed them
    /// ([`Reverse`]); `None`: the weight computes them.
    pub reverse: Option<Reverse>,
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
#[inline]
fn ratio(rev: f32, fwd: f32) -> f32 {
    if fwd > 0.0 && rev.is_finite() {
        let r = rev / fwd;
        r * r
    } else {
        0.0
    }
}

/// Stores in every vertex of a camera subpath the squared ratio of its reverse to its
/// forward density and its [`Vertex::tail`], which the weights of all strategies that do
/// not connect next to it share. Call once the subpath's densities are final.
pub(super) fn set_camera_ratios(path: &mut [Vertex]) {
    // The camera's own vertex starts no strategy (t = 0 does not exist): its tail is empty.
    let mut tail = 0.0f32;
    for i in 0..path.len() {
        let r = ratio(path[i].pdf_rev, path[i].pdf_fwd);
        if i > 0 {
            let counts = !path[i].delta && !path[i - 1].delta;
            tail = r * (f32::from(u8::from(counts)) + tail);
        }
        path[i].ratio = r;
        path[i].tail = tail;
    }
}

/// [`set_camera_ratios`] for a light subpath (its first vertex is the light: the strategy
/// with no light vertex exists where the light is not a Dirac delta).
pub(super) fn set_light_ratios(path: &mut [Vertex]) {
    let mut tail = 0.0f32;
    for i in 0..path.len() {
        let r = ratio(path[i].pdf_rev, path[i].pdf_fwd);
        let before = if i > 0 {
            path[i - 1].delta
        } else {
            path[0].is_delta_light()
        };
        let counts = !path[i].delta && !before;
        tail = r * (f32::from(u8::from(counts)) + tail);
        path[i].ratio = r;
        path[i].tail = tail;
    }
}

/// The power-heuristic weight of strategy (s, t) = (`c.light.len()`, `c.camera.len()`) for
/// the path its vertices form. Pure function of the vertices.
pub(super) fn weight(ctx: &Context, c: &Connection) -> f32 {
    let (light, camera) = (c.light, c.camera);
    if let Some(reverse) = c.reverse {
        return sum_weight(light, camera, reverse);
    }
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
fn sum_weight(
    light: &[Vertex],
    camera: &[Vertex],
    [pt_rev, pt_minus_rev, qs_rev, qs_minus_rev]: Reverse,
) -> f32 {
    let (s, t) = (light.len(), camera.len());
    let mut sum = 0.0f32;
    // Strategies with fewer camera vertices: the two next to the connection with the
    // recomputed densities, the others with the subpath's own ratios ([`set_camera_ratios`], [`set_light_ratios`]).
    let mut r = 1.0f32;
    if t >= 2 {
        r *= ratio(pt_rev, camera[t - 1].pdf_fwd);
        if !camera[t - 2].delta {
            sum += r;
        }
    }
    if t >= 3 {
        r *= ratio(pt_minus_rev, camera[t - 2].pdf_fwd);
        if !camera[t - 2].delta && !camera[t - 3].delta {
            sum += r;
        }
    }
    // The farther ones: the running product times the subpath's tail where it reaches them
    // ([`Vertex::tail`]; an empty tail is skipped, so that an infinite product adds nothing).
    if t >= 4 && camera[t - 3].tail != 0.0 {
        sum += r * camera[t - 3].tail;
    }
    // Strategies with fewer light vertices.
    let delta_before = |i: usize| {
        if i > 0 {
            light[i - 1].delta
        } else {
            light[0].is_delta_light()
        }
    };
    let mut r = 1.0f32;
    if s >= 1 {
        r *= ratio(qs_rev, light[s - 1].pdf_fwd);
        if !delta_before(s - 1) {
            sum += r;
        }
    }
    if s >= 2 {
        r *= ratio(qs_minus_rev, light[s - 2].pdf_fwd);
        if !light[s - 2].delta && !delta_before(s - 2) {
            sum += r;
        }
    }
    if s >= 3 && light[s - 3].tail != 0.0 {
        sum += r * light[s - 3].tail;
    }
    let w = 1.0 / (1.0 + sum);
    if w.is_finite() {
        w
    } else {
        0.0
    }
}
