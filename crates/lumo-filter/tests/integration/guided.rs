//! The guided filter against a direct implementation, the fast variant against the exact
//! one, and the geometry-aware lookup.

use lumo_filter::*;
use lumo_image::Image;

use crate::support::*;

/// Direct O(r²) guided filter in f64 with clipped windows (He et al.'s boxfilter/N).
fn guided_direct(p: &Image, g: &Guide, r: usize) -> Image {
    let (w, h, d) = (p.width, p.height, g.dims);
    let gi = |x: usize, y: usize, i: usize| g.data[(y * w + x) * d + i] as f64;
    let pc = |x: usize, y: usize, c: usize| p.data[(y * w + x) * 3 + c] as f64;
    let win = |x: usize, y: usize| {
        let xs = x.saturating_sub(r)..=(x + r).min(w - 1);
        let ys = y.saturating_sub(r)..=(y + r).min(h - 1);
        ys.flat_map(move |yy| xs.clone().map(move |xx| (xx, yy)))
    };
    // Per-window coefficients a (3×d) and b (3).
    let mut coef = vec![vec![0.0f64; 3 * d + 3]; w * h];
    for y in 0..h {
        for x in 0..w {
            let pts: Vec<_> = win(x, y).collect();
            let n = pts.len() as f64;
            let mi: Vec<f64> = (0..d)
                .map(|i| pts.iter().map(|&(a, b)| gi(a, b, i)).sum::<f64>() / n)
                .collect();
            let mp: Vec<f64> = (0..3)
                .map(|c| pts.iter().map(|&(a, b)| pc(a, b, c)).sum::<f64>() / n)
                .collect();
            for c in 0..3 {
                // Augmented system (Σ + εI | cov).
                let mut m = vec![vec![0.0f64; d + 1]; d];
                for i in 0..d {
                    for j in 0..d {
                        m[i][j] = pts
                            .iter()
                            .map(|&(a, b)| gi(a, b, i) * gi(a, b, j))
                            .sum::<f64>()
                            / n
                            - mi[i] * mi[j];
                    }
                    m[i][i] += g.eps[i] as f64;
                    m[i][d] = pts
                        .iter()
                        .map(|&(a, b)| gi(a, b, i) * pc(a, b, c))
                        .sum::<f64>()
                        / n
                        - mi[i] * mp[c];
                }
                // Gauss-Jordan without pivoting (SPD).
                for k in 0..d {
                    let piv = m[k][k];
                    for j in k..=d {
                        m[k][j] /= piv;
                    }
                    for i in 0..d {
                        if i != k {
                            let f = m[i][k];
                            for j in k..=d {
                                m[i][j] -= f * m[k][j];
                            }
                        }
                    }
                }
                let mut b = mp[c];
                for i in 0..d {
                    coef[y * w + x][c * d + i] = m[i][d];
                    b -= m[i][d] * mi[i];
                }
                coef[y * w + x][3 * d + c] = b;
            }
        }
    }
    let mut out = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            let pts: Vec<_> = win(x, y).collect();
            let n = pts.len() as f64;
            let mean: Vec<f64> = (0..3 * d + 3)
                .map(|k| pts.iter().map(|&(a, b)| coef[b * w + a][k]).sum::<f64>() / n)
                .collect();
            for c in 0..3 {
                let mut q = mean[3 * d + c];
                for i in 0..d {
                    q += mean[c * d + i] * gi(x, y, i);
                }
                out.pixel_mut(x, y)[c] = q as f32;
            }
        }
    }
    out
}

#[test]
fn guided_filter_matches_direct_implementation() {
    let (w, h) = (37, 29);
    let p = noise_image(w, h, 3, 7);
    for d in [1usize, 3, 4, 6] {
        let gimg = noise_image(w, h, d, 11 + d as u64);
        let eps: Vec<f32> = (0..d).map(|i| 0.01 + 0.01 * i as f32).collect();
        let g = Guide::from_image(&gimg, eps).unwrap();
        for r in [2usize, 5] {
            let fast = guided(
                &p,
                &g,
                &GuidedParams {
                    radius: r,
                    fast_subsample: 1,
                },
            )
            .unwrap();
            let direct = guided_direct(&p, &g, r);
            let diff = max_abs_diff(&fast.image, &direct);
            assert!(diff < 1e-4, "d={d} r={r}: {diff}");
        }
    }
}

#[test]
fn guided_filter_matches_direct_implementation_across_row_bands() {
    // Tall enough for several row bands (the filter streams bands of max(128, 4r) rows), with
    // a firefly whose running-sum residue must not leak along rows or columns.
    let (w, h) = (29, 300);
    let mut p = noise_image(w, h, 3, 21);
    p.pixel_mut(14, 140).copy_from_slice(&[1e3, 2e3, 5e2]);
    for d in [1usize, 3] {
        let gimg = noise_image(w, h, d, 31 + d as u64);
        let g = Guide::from_image(&gimg, vec![0.01; d]).unwrap();
        for r in [4usize, 40] {
            let params = GuidedParams {
                radius: r,
                fast_subsample: 1,
            };
            let got = guided(&p, &g, &params).unwrap().image;
            let want = guided_direct(&p, &g, r);
            let worst = got
                .data
                .iter()
                .zip(&want.data)
                .map(|(a, b)| (a - b).abs() / (1.0 + b.abs()))
                .fold(0.0f32, f32::max);
            assert!(worst < 1e-4, "d={d} r={r}: {worst}");
        }
    }
}

#[test]
fn fast_guided_filter_is_close_to_exact_on_smooth_input() {
    let (w, h) = (64, 48);
    let s = split(w, h);
    let f = features(&s);
    let frame = synthetic_frame(w, h, 4, 3);
    let g = build_guide(GuideKind::NormalDepth, &f, DepthNorm::Range, 0.01, 0.01).unwrap();
    let exact = guided(
        &frame.reference,
        &g,
        &GuidedParams {
            radius: 8,
            fast_subsample: 1,
        },
    )
    .unwrap();
    let fast = guided(
        &frame.reference,
        &g,
        &GuidedParams {
            radius: 8,
            fast_subsample: 4,
        },
    )
    .unwrap();
    let mse: f32 = exact
        .image
        .data
        .iter()
        .zip(&fast.image.data)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f32>()
        / exact.image.data.len() as f32;
    assert!(mse < 1e-3, "mse {mse}");
}

#[test]
fn lookup_picks_the_matching_surface_across_a_depth_edge() {
    // A sample on the near surface (depth 2, facing +z) between two near and two far guides.
    let near_n = [0.0, 0.0, 1.0];
    let cn = [near_n, [0.0, 0.0, 1.0], near_n, [0.0, 0.0, 1.0]];
    let cd = [10.0, 2.1, 10.2, 9.9];
    assert_eq!(most_similar(near_n, 2.0, &cn, &cd), 1);
    // Same depths, different normals: the normal decides.
    let cn = [
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, -1.0, 0.0],
    ];
    assert_eq!(most_similar(near_n, 5.0, &cn, &[5.0; 4]), 2);
    // Background only matches background.
    assert_eq!(
        most_similar(
            [0.0; 3],
            f32::INFINITY,
            &[near_n; 4],
            &[2.0, 2.0, f32::INFINITY, 3.0]
        ),
        2
    );
    // In a grid: left half near, right half far; a near sample right at the edge.
    let s = split(8, 4);
    let (gx, _) = most_similar_in_grid([0.0, 0.0, 1.0], 2.0, 4.0, 2.0, &s.normal, &s.depth);
    assert_eq!(gx, 3);
    let (gx, _) = most_similar_in_grid([1.0, 0.0, 0.0], 5.0, 4.0, 2.0, &s.normal, &s.depth);
    assert_eq!(gx, 4);
}
