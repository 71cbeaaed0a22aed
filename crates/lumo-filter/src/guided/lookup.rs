//! Geometry-aware lookup (Bauszat et al. 2011, §3.2 eqs 3–5; papers/README §2): which of the
//! four neighbouring guide samples lies on the same surface as a given sample.

use lumo_image::Image;

fn is_background(d: f32) -> bool {
    !(d.is_finite() && d > 0.0)
}

/// Floor δ of each similarity term (see [`most_similar`]).
pub const LOOKUP_FLOOR: f32 = 0.01;

/// Index (0..4) of the candidate most similar to the sample (`normal`, `depth`):
/// `s_i = sn_i · sd_i`, `sn_i = 1 − ‖Na − Ni‖ / max_j ‖Na − Nj‖`,
/// `sd_i = 1 − |Da − Di| / max_j |Da − Dj|`. A term whose max is 0 (all candidates equal in it)
/// is 1 for everyone. Background (depth 0 or not finite) only matches background; when no
/// candidate matches the sample's class, candidate 0 is returned; ties go to the lowest index.
///
/// One deviation from the paper: each term is floored at `LOOKUP_FLOOR` before the product
/// (`s_i = (δ + (1−δ)·sn_i)·(δ + (1−δ)·sd_i)`). With the paper's plain product the worst
/// candidate in each term scores exactly 0, so at a box corner the right candidate (same
/// normal, largest depth difference) and a wrong one (other normal) both score ≈ 0 and
/// rounding picks; the floor lets the other term decide.
pub fn most_similar(
    normal: [f32; 3],
    depth: f32,
    cand_normal: &[[f32; 3]; 4],
    cand_depth: &[f32; 4],
) -> usize {
    let bg = is_background(depth);
    let fin = |v: f32| if v.is_finite() { v } else { 0.0 };
    let mut dn = [0.0f32; 4];
    let mut dd = [0.0f32; 4];
    let mut same = [false; 4];
    for i in 0..4 {
        same[i] = is_background(cand_depth[i]) == bg;
        let d: f32 = (0..3)
            .map(|c| (fin(normal[c]) - fin(cand_normal[i][c])).powi(2))
            .sum();
        dn[i] = d.sqrt();
        dd[i] = if bg || !same[i] {
            0.0
        } else {
            (depth - cand_depth[i]).abs()
        };
    }
    // The maxima run over the candidates that can match at all, so a background neighbour's
    // (meaningless) distance does not compress the scores of the real ones.
    let (mut max_n, mut max_d) = (0.0f32, 0.0f32);
    for i in 0..4 {
        if same[i] {
            max_n = max_n.max(dn[i]);
            max_d = max_d.max(dd[i]);
        }
    }
    let floor = |t: f32| LOOKUP_FLOOR + (1.0 - LOOKUP_FLOOR) * t;
    let mut best = 0;
    let mut best_s = f32::NEG_INFINITY;
    for i in 0..4 {
        let sn = if max_n > 0.0 {
            1.0 - dn[i] / max_n
        } else {
            1.0
        };
        let sd = if max_d > 0.0 {
            1.0 - dd[i] / max_d
        } else {
            1.0
        };
        let s = if same[i] { floor(sn) * floor(sd) } else { -1.0 };
        if s > best_s {
            best_s = s;
            best = i;
        }
    }
    best
}

/// For a sample at continuous position (`x`, `y`) in the guide grid's pixel units (pixel j
/// covers [j, j+1)), picks among the four guide pixels around it the one most similar in
/// normal and depth ([`most_similar`]) and returns its (column, row). `grid_normal` has 3
/// channels, `grid_depth` 1 (or more: the first is used); both must have the same size and be
/// non-empty, otherwise (0, 0) is returned.
pub fn most_similar_in_grid(
    normal: [f32; 3],
    depth: f32,
    x: f32,
    y: f32,
    grid_normal: &Image,
    grid_depth: &Image,
) -> (usize, usize) {
    let (w, h) = (grid_normal.width, grid_normal.height);
    if w == 0
        || h == 0
        || grid_normal.channels < 3
        || grid_depth.channels == 0
        || grid_depth.width != w
        || grid_depth.height != h
    {
        return (0, 0);
    }
    let cells = neighbour_cells(x, y, w, h);
    let mut cn = [[0.0f32; 3]; 4];
    let mut cd = [0.0f32; 4];
    for (i, &(cx, cy)) in cells.iter().enumerate() {
        let n = grid_normal.pixel(cx, cy);
        cn[i] = [n[0], n[1], n[2]];
        cd[i] = grid_depth.pixel(cx, cy)[0];
    }
    cells[most_similar(normal, depth, &cn, &cd)]
}

/// The four guide pixels around continuous position (`x`, `y`) of a `w`×`h` grid (pixel j
/// covers [j, j+1)), clamped at the border: the candidates of [`most_similar_in_grid`].
/// `w` and `h` must be non-zero.
pub fn neighbour_cells(x: f32, y: f32, w: usize, h: usize) -> [(usize, usize); 4] {
    let clamp = |v: f32, n: usize| {
        if v.is_finite() {
            (v - 0.5).clamp(0.0, (n - 1) as f32) as usize
        } else {
            0
        }
    };
    let (x0, y0) = (clamp(x, w), clamp(y, h));
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    [(x0, y0), (x1, y0), (x0, y1), (x1, y1)]
}
