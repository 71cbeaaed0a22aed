//! Joint bilateral upsampling: constants, geometry edges and its fallback.

use lumo_filter::*;
use lumo_image::Image;

use crate::support::*;

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
