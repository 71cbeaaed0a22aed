//! A procedural test scene for tests, benchmarks and the parameter sweep (docs/filters.md),
//! standing in for a renderer: a small room with two boxes, a checkerboard floor, a point light
//! casting hard shadows, a smooth fake indirect term and sky above the walls, ray cast at one
//! primary ray per pixel. The "noisy" image mimics a 1–4 spp path tracer: the direct term gets
//! mild multiplicative noise (area-light sampling), the indirect term a heavy-tailed one
//! (mostly dark samples, a few bright ones, rare fireflies), both with mean 1, so the noise-free
//! image is the exact expectation.

use lumo_image::{luminance, Image};
use rayon::prelude::*;

use crate::common::boxsum::box_mean;

/// A synthetic frame: noise-free reference, noisy estimate and its G-buffer.
#[derive(Clone, Debug)]
pub struct SyntheticFrame {
    /// Expected value of `noisy` (what a converged render would show).
    pub reference: Image,
    /// Mean of `spp` noisy samples per pixel.
    pub noisy: Image,
    /// Diffuse albedo (0 on background).
    pub albedo: Image,
    /// World-space normal (0 on background).
    pub normal: Image,
    /// World-space position (+Inf on background).
    pub position: Image,
    /// Camera distance, 1 channel (+Inf on background).
    pub depth: Image,
    /// Luminance variance estimated from the noisy image (7×7 spatial variance / spp, as SVGF
    /// does before it has a temporal history).
    pub variance: Image,
}

#[derive(Clone, Copy)]
struct Hit {
    t: f32,
    n: [f32; 3],
    albedo: [f32; 3],
}

type V3 = [f32; 3];

fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn mul(a: V3, s: f32) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn dot(a: V3, b: V3) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn norm(a: V3) -> V3 {
    mul(a, 1.0 / dot(a, a).sqrt())
}

const BOXES: [([f32; 3], [f32; 3]); 2] = [
    ([-0.9, 0.0, -1.3], [-0.2, 0.9, -0.6]),
    ([0.2, 0.0, -0.5], [0.9, 0.5, 0.2]),
];
const LIGHT: V3 = [0.4, 1.8, 0.6];
const LIGHT_POWER: f32 = 6.0;
const SKY: V3 = [0.3, 0.4, 0.6];

/// Closest hit of the ray o + t·d (t > tmin) with the room and boxes.
fn trace(o: V3, d: V3, tmin: f32) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    let mut consider = |t: f32, n: V3, albedo: V3| {
        if t > tmin && best.is_none_or(|b| t < b.t) {
            best = Some(Hit { t, n, albedo });
        }
    };
    // Axis-aligned rectangles: (axis, value, normal sign, bounds on the other two axes).
    let rects: [(usize, f32, f32, [f32; 4], V3); 4] = [
        (1, 0.0, 1.0, [-1.5, 1.5, -2.0, 1.5], [0.8, 0.8, 0.8]), // floor (x, z), checker
        (2, -2.0, 1.0, [-1.5, 1.5, 0.0, 2.0], [0.7, 0.7, 0.7]), // back wall (x, y)
        (0, -1.5, 1.0, [0.0, 2.0, -2.0, 1.5], [0.7, 0.15, 0.1]), // left wall (y, z)
        (0, 1.5, -1.0, [0.0, 2.0, -2.0, 1.5], [0.15, 0.6, 0.15]), // right wall (y, z)
    ];
    for (axis, v, s, b, alb) in rects {
        if d[axis].abs() < 1e-9 {
            continue;
        }
        let t = (v - o[axis]) / d[axis];
        let p = add(o, mul(d, t));
        let (u, w) = match axis {
            0 => (p[1], p[2]),
            1 => (p[0], p[2]),
            _ => (p[0], p[1]),
        };
        if u >= b[0] && u <= b[1] && w >= b[2] && w <= b[3] {
            let mut n = [0.0; 3];
            n[axis] = s;
            let albedo = if axis == 1 {
                let c = ((p[0] * 4.0).floor() + (p[2] * 4.0).floor()) as i64 & 1;
                if c == 0 {
                    [0.8, 0.8, 0.75]
                } else {
                    [0.3, 0.3, 0.35]
                }
            } else {
                alb
            };
            consider(t, n, albedo);
        }
    }
    for (lo, hi) in BOXES {
        // Slab test, remembering the entry axis for the normal.
        let (mut t0, mut t1, mut axis, mut sign) = (f32::NEG_INFINITY, f32::INFINITY, 0, 1.0);
        for a in 0..3 {
            let inv = 1.0 / d[a];
            let (mut ta, mut tb) = ((lo[a] - o[a]) * inv, (hi[a] - o[a]) * inv);
            let mut s = -1.0;
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
                s = 1.0;
            }
            if ta > t0 {
                t0 = ta;
                axis = a;
                sign = s;
            }
            t1 = t1.min(tb);
        }
        if t0 <= t1 && t0 > tmin {
            let mut n = [0.0; 3];
            n[axis] = sign;
            consider(t0, n, [0.75, 0.7, 0.6]);
        }
    }
    best
}

/// SplitMix64: a tiny, stateless-seedable generator so every pixel's noise is reproducible.
pub(crate) fn splitmix(state: &mut u64) -> f32 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    ((z >> 40) as f32 + 0.5) / (1u64 << 24) as f32
}

/// Renders the scene at `width`×`height` with `spp` noisy samples per pixel.
pub fn synthetic_frame(width: usize, height: usize, spp: usize, seed: u64) -> SyntheticFrame {
    let (w, h) = (width.max(1), height.max(1));
    let spp = spp.max(1);
    let eye: V3 = [0.0, 1.1, 3.6];
    let fov = 55f32.to_radians();
    let aspect = w as f32 / h as f32;
    let tan = (fov * 0.5).tan();
    let mut refd = vec![0.0f32; w * h * 3];
    let mut noisy = vec![0.0f32; w * h * 3];
    let mut albedo = vec![0.0f32; w * h * 3];
    let mut normal = vec![0.0f32; w * h * 3];
    let mut position = vec![0.0f32; w * h * 3];
    let mut depth = vec![0.0f32; w * h];
    let rows: Vec<_> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut out = vec![[0.0f32; 3]; w * 5];
            let mut dep = vec![0.0f32; w];
            for x in 0..w {
                let sx = ((x as f32 + 0.5) / w as f32 * 2.0 - 1.0) * tan * aspect;
                let sy = (1.0 - (y as f32 + 0.5) / h as f32 * 2.0) * tan;
                let dir = norm([sx, sy - 0.12, -1.0]);
                let (reference, direct, indirect, alb, n, pos, d);
                match trace(eye, dir, 1e-4) {
                    None => {
                        reference = SKY;
                        direct = SKY;
                        indirect = [0.0; 3];
                        alb = [0.0; 3];
                        n = [0.0; 3];
                        pos = [f32::INFINITY; 3];
                        d = f32::INFINITY;
                    }
                    Some(hit) => {
                        let p = add(eye, mul(dir, hit.t));
                        let tl = sub(LIGHT, p);
                        let r2 = dot(tl, tl);
                        let l = mul(tl, 1.0 / r2.sqrt());
                        let cos = dot(hit.n, l).max(0.0);
                        let shadow_o = add(p, mul(hit.n, 1e-3));
                        let vis = match trace(shadow_o, l, 1e-4) {
                            Some(s) if s.t * s.t < r2 => 0.0,
                            _ => 1.0,
                        };
                        let e_dir = LIGHT_POWER * cos * vis / (std::f32::consts::PI * r2);
                        // Smooth fake indirect light: brighter up high and near the walls.
                        let e_ind =
                            0.35 + 0.15 * (p[1] / 2.0) + 0.1 * (0.5 + 0.5 * (1.3 * p[0]).sin());
                        direct = mul(hit.albedo, e_dir);
                        indirect = mul(hit.albedo, e_ind);
                        reference = add(direct, indirect);
                        alb = hit.albedo;
                        n = hit.n;
                        pos = p;
                        d = hit.t;
                    }
                }
                let mut state = seed ^ ((y * w + x) as u64).wrapping_mul(0x2545_F491_4F6C_DD1D);
                let mut acc = [0.0f32; 3];
                for _ in 0..spp {
                    let sample = if d.is_finite() {
                        // Direct: area-light sampling noise, mean 1, variance 1/4.
                        let e = -splitmix(&mut state).ln();
                        let dm = 0.5 + 0.5 * e;
                        // Indirect: 1 in 4 paths finds light (mean-1 exponential × 4), and 1 in
                        // 500 a caustic-like firefly (×100); mean kept at 1.
                        let u = splitmix(&mut state);
                        let e2 = -splitmix(&mut state).ln();
                        let im = if u < 0.002 {
                            100.0 * e2
                        } else if u < 0.25 {
                            (1.0 - 0.2) / 0.248 * e2
                        } else {
                            0.0
                        };
                        add(mul(direct, dm), mul(indirect, im))
                    } else {
                        direct
                    };
                    acc = add(acc, sample);
                }
                out[x * 5] = reference;
                out[x * 5 + 1] = mul(acc, 1.0 / spp as f32);
                out[x * 5 + 2] = alb;
                out[x * 5 + 3] = n;
                out[x * 5 + 4] = pos;
                dep[x] = d;
            }
            (out, dep)
        })
        .collect();
    for (y, (out, dep)) in rows.into_iter().enumerate() {
        for x in 0..w {
            let i = y * w + x;
            for (k, dst) in [
                &mut refd,
                &mut noisy,
                &mut albedo,
                &mut normal,
                &mut position,
            ]
            .into_iter()
            .enumerate()
            {
                dst[i * 3..i * 3 + 3].copy_from_slice(&out[x * 5 + k]);
            }
            depth[i] = dep[x];
        }
    }
    // Spatial variance of luminance in a 7×7 window, divided by spp.
    let mut ll = vec![0.0f32; w * h * 2];
    for i in 0..w * h {
        let l = luminance([noisy[i * 3], noisy[i * 3 + 1], noisy[i * 3 + 2]]);
        ll[i * 2] = l;
        ll[i * 2 + 1] = l * l;
    }
    let m = box_mean(&ll, w, h, 2, 3);
    let variance: Vec<f32> = (0..w * h)
        .map(|i| (m[i * 2 + 1] - m[i * 2] * m[i * 2]).max(0.0) / spp as f32)
        .collect();
    SyntheticFrame {
        reference: Image::from_vec(w, h, 3, refd),
        noisy: Image::from_vec(w, h, 3, noisy),
        albedo: Image::from_vec(w, h, 3, albedo),
        normal: Image::from_vec(w, h, 3, normal),
        position: Image::from_vec(w, h, 3, position),
        depth: Image::from_vec(w, h, 1, depth),
        variance: Image::from_vec(w, h, 1, variance),
    }
}
