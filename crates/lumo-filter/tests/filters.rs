//! Behavioural tests of every filter against brute-force references and invariants.
#![allow(clippy::needless_range_loop)]

use lumo_filter::*;
use lumo_image::Image;

/// Deterministic pseudo-random values in [0, 1).
fn rng(seed: u64) -> impl FnMut() -> f32 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 40) as f32) / (1u64 << 24) as f32
    }
}

fn noise_image(w: usize, h: usize, c: usize, seed: u64) -> Image {
    let mut r = rng(seed);
    Image::from_vec(w, h, c, (0..w * h * c).map(|_| r()).collect())
}

/// A G-buffer with a vertical geometry edge at x = w/2: left faces +z at depth 2, right faces
/// +x at depth 5; positions consistent with that.
struct Split {
    normal: Image,
    depth: Image,
    position: Image,
    albedo: Image,
}

fn split(w: usize, h: usize) -> Split {
    let mut normal = Image::new(w, h, 3, 0.0);
    let mut depth = Image::new(w, h, 1, 0.0);
    let mut position = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            let left = x < w / 2;
            normal.pixel_mut(x, y).copy_from_slice(if left {
                &[0.0, 0.0, 1.0]
            } else {
                &[1.0, 0.0, 0.0]
            });
            let d = if left { 2.0 } else { 5.0 };
            depth.pixel_mut(x, y)[0] = d;
            position
                .pixel_mut(x, y)
                .copy_from_slice(&[x as f32 * 0.01, y as f32 * 0.01, -d]);
        }
    }
    Split {
        normal,
        depth,
        position,
        albedo: Image::new(w, h, 3, 0.5),
    }
}

fn features(s: &Split) -> Features<'_> {
    Features {
        normal: Some(&s.normal),
        position: Some(&s.position),
        depth: Some(&s.depth),
        albedo: Some(&s.albedo),
        variance: None,
    }
}

fn max_abs_diff(a: &Image, b: &Image) -> f32 {
    assert_eq!(
        (a.width, a.height, a.channels),
        (b.width, b.height, b.channels)
    );
    a.data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

fn all_guides(s: &Split) -> Vec<Guide> {
    let f = features(s);
    [GuideKind::Grey, GuideKind::Normal, GuideKind::NormalDepth]
        .into_iter()
        .map(|k| build_guide(k, &f, DepthNorm::Range, 0.01, 0.01).unwrap())
        .collect()
}

#[test]
fn constant_image_stays_constant_under_every_filter() {
    let (w, h) = (40, 32);
    let s = split(w, h);
    let f = features(&s);
    let c = Image::from_vec(w, h, 3, [0.25f32, 0.5, 2.0].repeat(w * h));
    let mut outs = vec![
        atrous(&c, &f, &AtrousParams::default()).unwrap().image,
        atrous(
            &c,
            &f,
            &AtrousParams {
                demodulate: true,
                sparse: 2,
                ..AtrousParams::default()
            },
        )
        .unwrap()
        .image,
        bilateral(&c, &f, &BilateralParams::default())
            .unwrap()
            .image,
    ];
    let var = Image::new(w, h, 1, 0.1);
    let fv = Features {
        variance: Some(&var),
        ..f
    };
    outs.push(atrous(&c, &fv, &AtrousParams::default()).unwrap().image);
    for g in all_guides(&s) {
        for sub in [1, 2, 3] {
            let p = GuidedParams {
                radius: 4,
                fast_subsample: sub,
            };
            outs.push(guided(&c, &g, &p).unwrap().image);
        }
    }
    for (i, o) in outs.iter().enumerate() {
        let d = max_abs_diff(o, &c);
        assert!(d < 1e-4, "filter #{i}: max deviation {d}");
    }
}

/// Piecewise-constant colour that follows the geometry edge.
fn edge_color(w: usize, h: usize) -> Image {
    let mut c = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            let v = if x < w / 2 {
                [0.2, 0.3, 0.1]
            } else {
                [1.0, 0.8, 0.9]
            };
            c.pixel_mut(x, y).copy_from_slice(&v);
        }
    }
    c
}

#[test]
fn piecewise_constant_image_is_not_blurred_across_guide_edges() {
    let (w, h) = (48, 24);
    let s = split(w, h);
    let c = edge_color(w, h);
    // Geometry only, so no filter can lean on colour: the geometry must keep the edge.
    // (À-Trous divides the normal distance by stepwidth², so at coarse levels it relies on
    // positions, as in the paper.)
    let f = Features {
        normal: Some(&s.normal),
        depth: Some(&s.depth),
        ..Features::default()
    };
    let fp = Features {
        position: Some(&s.position),
        ..f
    };
    let a = atrous(
        &c,
        &fp,
        &AtrousParams {
            sigma_color: None,
            sigma_luminance: None,
            ..AtrousParams::default()
        },
    )
    .unwrap()
    .image;
    assert!(
        max_abs_diff(&a, &c) < 1e-3,
        "atrous {}",
        max_abs_diff(&a, &c)
    );
    let b = bilateral(
        &c,
        &f,
        &BilateralParams {
            radius: 6,
            sigma_spatial: 3.0,
            sigma_normal: Some(0.1),
            sigma_depth: None,
            sigma_position: None,
            sigma_color: None,
        },
    )
    .unwrap()
    .image;
    assert!(
        max_abs_diff(&b, &c) < 1e-3,
        "bilateral {}",
        max_abs_diff(&b, &c)
    );
    let g = build_guide(GuideKind::NormalDepth, &f, DepthNorm::Range, 1e-4, 1e-4).unwrap();
    let q = guided(
        &c,
        &g,
        &GuidedParams {
            radius: 4,
            fast_subsample: 1,
        },
    )
    .unwrap()
    .image;
    assert!(
        max_abs_diff(&q, &c) < 8e-3,
        "guided {}",
        max_abs_diff(&q, &c)
    );
    // The same image through a guide without the edge (all normals equal) must blur: this is
    // what makes the assertions above meaningful.
    let flat = Image::from_vec(w, h, 3, [0.0f32, 0.0, 1.0].repeat(w * h));
    let ff = Features {
        normal: Some(&flat),
        ..Features::default()
    };
    let g = build_guide(GuideKind::Normal, &ff, DepthNorm::Range, 1e-4, 1e-4).unwrap();
    let blurred = guided(
        &c,
        &g,
        &GuidedParams {
            radius: 4,
            fast_subsample: 1,
        },
    )
    .unwrap();
    assert!(max_abs_diff(&blurred.image, &c) > 0.1);
}

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

/// Direct à-trous convolution: N levels of the 5×5 B3 kernel with taps 2^i apart, taps outside
/// the image skipped and the kernel renormalised.
fn atrous_direct(c: &Image, iterations: usize) -> Image {
    let (w, h) = (c.width, c.height);
    let mut cur = c.clone();
    for it in 0..iterations {
        let step = 1isize << it;
        let mut next = Image::new(w, h, 3, 0.0);
        for y in 0..h as isize {
            for x in 0..w as isize {
                let (mut s, mut k) = ([0.0f64; 3], 0.0f64);
                for (j, hy) in B3.iter().enumerate() {
                    for (i, hx) in B3.iter().enumerate() {
                        let (xx, yy) = (x + (i as isize - 2) * step, y + (j as isize - 2) * step);
                        if xx < 0 || yy < 0 || xx >= w as isize || yy >= h as isize {
                            continue;
                        }
                        let wt = (hx * hy) as f64;
                        let v = cur.pixel(xx as usize, yy as usize);
                        for ch in 0..3 {
                            s[ch] += wt * v[ch] as f64;
                        }
                        k += wt;
                    }
                }
                for ch in 0..3 {
                    next.pixel_mut(x as usize, y as usize)[ch] = (s[ch] / k) as f32;
                }
            }
        }
        cur = next;
    }
    cur
}

#[test]
fn atrous_without_edge_weights_is_the_b3_atrous_convolution() {
    let c = noise_image(45, 38, 3, 5);
    for iterations in [1, 3, 5] {
        let p = AtrousParams {
            iterations,
            sigma_color: None,
            sigma_luminance: None,
            sigma_normal: None,
            sigma_position: None,
            ..AtrousParams::default()
        };
        let got = atrous(&c, &Features::default(), &p).unwrap();
        let want = atrous_direct(&c, iterations);
        let d = max_abs_diff(&got.image, &want);
        assert!(d < 1e-5, "{iterations} iterations: {d}");
    }
}

#[test]
fn bilateral_with_infinite_range_sigma_is_its_spatial_kernel() {
    let (w, h) = (33, 27);
    let c = noise_image(w, h, 3, 9);
    let s = split(w, h);
    let f = features(&s);
    let (r, sigma) = (4usize, 2.5f32);
    let p = BilateralParams {
        radius: r,
        sigma_spatial: sigma,
        sigma_normal: Some(f32::INFINITY),
        sigma_depth: Some(f32::INFINITY),
        sigma_position: Some(f32::INFINITY),
        sigma_color: Some(f32::INFINITY),
    };
    let got = bilateral(&c, &f, &p).unwrap().image;
    let mut want = Image::new(w, h, 3, 0.0);
    for y in 0..h as isize {
        for x in 0..w as isize {
            let (mut acc, mut k) = ([0.0f64; 3], 0.0f64);
            for dy in -(r as isize)..=r as isize {
                for dx in -(r as isize)..=r as isize {
                    let (xx, yy) = (x + dx, y + dy);
                    if xx < 0 || yy < 0 || xx >= w as isize || yy >= h as isize {
                        continue;
                    }
                    let wt = (-((dx * dx + dy * dy) as f64) / (2.0 * (sigma as f64).powi(2))).exp();
                    for ch in 0..3 {
                        acc[ch] += wt * c.pixel(xx as usize, yy as usize)[ch] as f64;
                    }
                    k += wt;
                }
            }
            for ch in 0..3 {
                want.pixel_mut(x as usize, y as usize)[ch] = (acc[ch] / k) as f32;
            }
        }
    }
    let d = max_abs_diff(&got, &want);
    assert!(d < 1e-5, "{d}");
}

#[test]
fn upsampling_a_constant_gives_the_constant() {
    let (w, h) = (50, 36);
    let s = split(w, h);
    let f = Features {
        normal: Some(&s.normal),
        depth: Some(&s.depth),
        ..Features::default()
    };
    for k in [4usize, 8, 16] {
        let low = Image::from_vec(
            w.div_ceil(k),
            h.div_ceil(k),
            3,
            [0.7f32, 0.1, 3.0].repeat(w.div_ceil(k) * h.div_ceil(k)),
        );
        for prefilter in [false, true] {
            let p = JbuParams {
                factor: k,
                prefilter,
                ..JbuParams::default()
            };
            let out = jbu(&low, &f, &p).unwrap();
            assert_eq!((out.image.width, out.image.height), (w, h));
            let want = Image::from_vec(w, h, 3, [0.7f32, 0.1, 3.0].repeat(w * h));
            assert!(max_abs_diff(&out.image, &want) < 1e-5, "k={k}");
        }
    }
}

#[test]
fn jbu_keeps_geometry_edges_and_falls_back_when_weights_vanish() {
    let (w, h) = (64, 32);
    let s = split(w, h);
    let f = Features {
        normal: Some(&s.normal),
        depth: Some(&s.depth),
        ..Features::default()
    };
    let k = 8;
    let (lw, lh) = (w / k, h / k);
    // Low-res samples follow the full-res surface they were taken on.
    let mut low = Image::new(lw, lh, 3, 0.0);
    for j in 0..lh {
        for i in 0..lw {
            let v = if i * k + k / 2 < w / 2 { 0.2 } else { 1.0 };
            low.pixel_mut(i, j).fill(v);
        }
    }
    let p = JbuParams {
        factor: k,
        outlier_sigma: None,
        ..JbuParams::default()
    };
    let out = jbu(&low, &f, &p).unwrap().image;
    let want = edge_color(w, h);
    for y in 0..h {
        for x in 0..w {
            let v = out.pixel(x, y)[0];
            let t = if x < w / 2 { 0.2 } else { 1.0 };
            assert!(
                (v - t).abs() < 1e-3,
                "({x},{y}) {v} vs {t} ({:?})",
                want.pixel(x, y)
            );
        }
    }
    // A full-res surface no low-res sample saw: range weights vanish, spatial fallback.
    let mut odd = s.normal.clone();
    odd.pixel_mut(3, 3).copy_from_slice(&[0.0, 1.0, 0.0]);
    let mut dep = s.depth.clone();
    dep.pixel_mut(3, 3)[0] = 1000.0;
    let f2 = Features {
        normal: Some(&odd),
        depth: Some(&dep),
        ..Features::default()
    };
    let out = jbu(&low, &f2, &p).unwrap().image;
    let v = out.pixel(3, 3)[0];
    assert!(v.is_finite() && (0.2..=1.0).contains(&v), "{v}");
}

#[test]
fn nan_inputs_give_finite_outputs() {
    let (w, h) = (40, 30);
    let s = split(w, h);
    let f = features(&s);
    let mut c = noise_image(w, h, 3, 1);
    for (i, v) in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY]
        .into_iter()
        .enumerate()
    {
        c.pixel_mut(5 + i, 7)[1] = v;
    }
    // A whole missing block bigger than one à-trous level.
    for y in 10..14 {
        for x in 20..24 {
            c.pixel_mut(x, y)[0] = f32::NAN;
        }
    }
    let expect_missing = 3 + 16;
    let var = Image::new(w, h, 1, f32::NAN);
    let fv = Features {
        variance: Some(&var),
        ..f
    };
    let mut results = vec![
        atrous(&c, &f, &AtrousParams::default()).unwrap(),
        atrous(
            &c,
            &fv,
            &AtrousParams {
                demodulate: true,
                ..AtrousParams::default()
            },
        )
        .unwrap(),
        bilateral(
            &c,
            &f,
            &BilateralParams {
                sigma_color: Some(1.0),
                ..BilateralParams::default()
            },
        )
        .unwrap(),
    ];
    for g in all_guides(&s) {
        results.push(
            guided(
                &c,
                &g,
                &GuidedParams {
                    radius: 3,
                    fast_subsample: 1,
                },
            )
            .unwrap(),
        );
        results.push(
            guided(
                &c,
                &g,
                &GuidedParams {
                    radius: 6,
                    fast_subsample: 2,
                },
            )
            .unwrap(),
        );
    }
    let mut low = noise_image(5, 4, 3, 2);
    low.pixel_mut(1, 1)[0] = f32::NAN;
    let jf = Features {
        normal: Some(&s.normal),
        depth: Some(&s.depth),
        ..Features::default()
    };
    let j = jbu(
        &low,
        &jf,
        &JbuParams {
            factor: 8,
            prefilter: true,
            ..JbuParams::default()
        },
    )
    .unwrap();
    assert_eq!(j.missing, 1);
    assert_eq!(j.image.non_finite_count(), 0);
    for (i, r) in results.iter().enumerate() {
        assert_eq!(r.image.non_finite_count(), 0, "filter #{i}");
        assert_eq!(r.missing, expect_missing, "filter #{i}");
        // Missing pixels are filled from their (uniform-noise) neighbourhood.
        let v = r.image.pixel(21, 11);
        assert!(
            v.iter().all(|v| (-0.01..=1.01).contains(v)),
            "filter #{i}: {v:?}"
        );
    }
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

#[test]
fn demodulation_passes_zero_albedo_pixels_through() {
    let (w, h) = (24, 16);
    let s = split(w, h);
    let mut albedo = Image::new(w, h, 3, 0.5);
    albedo.pixel_mut(4, 4).fill(0.0);
    let mut c = Image::new(w, h, 3, 0.25);
    c.pixel_mut(4, 4).fill(50.0); // an emitter with no albedo
    let f = Features {
        albedo: Some(&albedo),
        normal: Some(&s.normal),
        ..Features::default()
    };
    let p = AtrousParams {
        demodulate: true,
        sigma_position: None,
        ..AtrousParams::default()
    };
    let out = atrous(&c, &f, &p).unwrap().image;
    assert_eq!(out.pixel(4, 4), &[50.0, 50.0, 50.0]);
    let mut rest = out.clone();
    rest.pixel_mut(4, 4).fill(0.25);
    assert!(max_abs_diff(&rest, &Image::new(w, h, 3, 0.25)) < 1e-5);
}

#[test]
fn atrous_demodulation_equals_filtering_the_illumination() {
    // À-Trous reads colour / albedo straight into its working layout; that must be the same
    // as demodulating first (with_demodulation) and filtering the illumination, including
    // pass-through pixels (no albedo), a broken albedo and a missing colour pixel.
    let frame = synthetic_frame(96, 64, 2, 11);
    let mut albedo = frame.albedo.clone();
    albedo.pixel_mut(10, 10).fill(0.0);
    albedo.pixel_mut(40, 30)[1] = f32::NAN;
    let mut color = frame.noisy.clone();
    color.pixel_mut(50, 20)[0] = f32::INFINITY;
    let f = Features {
        albedo: Some(&albedo),
        normal: Some(&frame.normal),
        position: Some(&frame.position),
        depth: Some(&frame.depth),
        ..Features::default()
    };
    let p = AtrousParams {
        sigma_color: Some(4.0),
        demodulate: true,
        ..AtrousParams::default()
    };
    let fused = atrous(&color, &f, &p).unwrap();
    let plain = AtrousParams {
        demodulate: false,
        ..p.clone()
    };
    let two_step = with_demodulation(&color, &albedo, |c| atrous(c, &f, &plain)).unwrap();
    assert_eq!(fused.missing, 1);
    assert_eq!(two_step.missing, 1);
    let d = max_abs_diff(&fused.image, &two_step.image);
    assert!(d < 1e-5, "max difference {d}");
    assert_eq!(fused.image.pixel(10, 10), color.pixel(10, 10));
}

#[test]
fn variance_guided_atrous_leaves_converged_regions_alone() {
    let (w, h) = (32, 32);
    let c = noise_image(w, h, 3, 4);
    let zero = Image::new(w, h, 1, 0.0);
    let f = Features {
        variance: Some(&zero),
        ..Features::default()
    };
    let p = AtrousParams {
        sigma_luminance: Some(4.0),
        sigma_normal: None,
        sigma_position: None,
        ..AtrousParams::default()
    };
    let out = atrous(&c, &f, &p).unwrap().image;
    assert!(max_abs_diff(&out, &c) < 1e-4);
    // With a large variance the same image is smoothed.
    let big = Image::new(w, h, 1, 1.0);
    let fb = Features {
        variance: Some(&big),
        ..Features::default()
    };
    let out = atrous(&c, &fb, &p).unwrap().image;
    assert!(max_abs_diff(&out, &c) > 0.1);
}

#[test]
fn sparse_input_is_inpainted() {
    let frame = synthetic_frame(64, 48, 64, 1);
    let f = Features {
        normal: Some(&frame.normal),
        position: Some(&frame.position),
        depth: Some(&frame.depth),
        ..Features::default()
    };
    for n in [2, 4] {
        // Garbage off the grid must not leak into the result.
        let mut c = frame.noisy.clone();
        for y in 0..c.height {
            for x in 0..c.width {
                if x % n != 0 || y % n != 0 {
                    c.pixel_mut(x, y).fill(1e6);
                }
            }
        }
        let out = atrous(
            &c,
            &f,
            &AtrousParams {
                sparse: n,
                ..AtrousParams::default()
            },
        )
        .unwrap();
        assert_eq!(out.image.non_finite_count(), 0);
        let max = out.image.data.iter().fold(0.0f32, |m, v| m.max(*v));
        assert!(max < 10.0, "n={n}: {max}");
    }
}

fn mse(a: &Image, b: &Image) -> f64 {
    a.data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| ((x - y) as f64).powi(2))
        .sum::<f64>()
        / a.data.len() as f64
}

#[test]
fn every_filter_reduces_error_on_the_synthetic_scene() {
    let frame = synthetic_frame(96, 72, 1, 42);
    let f = Features {
        normal: Some(&frame.normal),
        position: Some(&frame.position),
        depth: Some(&frame.depth),
        albedo: Some(&frame.albedo),
        variance: None,
    };
    let before = mse(&frame.noisy, &frame.reference);
    let g = build_guide(GuideKind::NormalDepth, &f, DepthNorm::Range, 0.01, 0.01).unwrap();
    let outs = [
        (
            "atrous",
            atrous(
                &frame.noisy,
                &f,
                &AtrousParams {
                    demodulate: true,
                    ..AtrousParams::default()
                },
            )
            .unwrap(),
        ),
        (
            "guided",
            with_demodulation(&frame.noisy, &frame.albedo, |c| {
                guided(c, &g, &GuidedParams::default())
            })
            .unwrap(),
        ),
        (
            "bilateral",
            with_demodulation(&frame.noisy, &frame.albedo, |c| {
                bilateral(c, &f, &BilateralParams::default())
            })
            .unwrap(),
        ),
    ];
    for (name, o) in outs {
        let after = mse(&o.image, &frame.reference);
        assert!(after < before / 5.0, "{name}: {before} -> {after}");
    }
}

#[test]
fn bad_inputs_are_typed_errors() {
    let c = Image::new(8, 8, 3, 1.0);
    let small = Image::new(4, 8, 3, 0.0);
    let f = Features {
        normal: Some(&small),
        ..Features::default()
    };
    let e = atrous(&c, &f, &AtrousParams::default()).unwrap_err();
    assert!(
        matches!(e, FilterError::SizeMismatch { name: "normal", .. }),
        "{e}"
    );
    assert!(
        e.to_string().contains("4x8") && e.to_string().contains("8x8"),
        "{e}"
    );
    let e = build_guide(
        GuideKind::Normal,
        &Features::default(),
        DepthNorm::Range,
        0.01,
        0.01,
    )
    .unwrap_err();
    assert!(matches!(e, FilterError::MissingFeature { .. }), "{e}");
    let e = atrous(
        &c,
        &Features::default(),
        &AtrousParams {
            demodulate: true,
            sigma_normal: None,
            sigma_position: None,
            ..AtrousParams::default()
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("albedo"), "{e}");
    let e = atrous(
        &Image::new(8, 8, 2, 0.0),
        &Features::default(),
        &AtrousParams::default(),
    )
    .unwrap_err();
    assert!(matches!(e, FilterError::Channels { .. }));
}
