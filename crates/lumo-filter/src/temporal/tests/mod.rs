//! Tests of the temporal filter: invariants, convergence, reprojection, disocclusion, resets,
//! sanitising and thread-count independence.

use glam::Vec3;
use lumo_image::Image;

use super::*;
use crate::bench::synthetic::{splitmix, synthetic_frame, SyntheticFrame};
use crate::{atrous, spatial_variance, AtrousParams};

mod rejection;
mod resample;

/// A flat G-buffer: every pixel faces the camera at depth 2, positions on the plane z = −2.
struct Flat {
    normal: Image,
    depth: Image,
    position: Image,
}

fn flat(w: usize, h: usize) -> Flat {
    let mut position = Image::new(w, h, 3, -2.0);
    for y in 0..h {
        for x in 0..w {
            let p = position.pixel_mut(x, y);
            p[0] = x as f32 * 0.01;
            p[1] = y as f32 * 0.01;
        }
    }
    let mut normal = Image::new(w, h, 3, 0.0);
    for n in normal.data.chunks_exact_mut(3) {
        n[2] = 1.0;
    }
    Flat {
        normal,
        depth: Image::new(w, h, 1, 2.0),
        position,
    }
}

fn frame<'a>(color: &'a Image, g: &'a Flat) -> TemporalFrame<'a> {
    TemporalFrame {
        color,
        albedo: None,
        normal: &g.normal,
        depth: &g.depth,
        position: Some(&g.position),
        ids: None,
        motion: None,
    }
}

/// A synthetic frame's noisy image and G-buffer as the temporal filter's input, with no motion
/// (a still camera over a static scene).
pub(super) fn still_input(fr: &SyntheticFrame) -> TemporalFrame<'_> {
    TemporalFrame {
        color: &fr.noisy,
        albedo: Some(&fr.albedo),
        normal: &fr.normal,
        depth: &fr.depth,
        position: Some(&fr.position),
        ids: None,
        motion: None,
    }
}

/// Colour, normals and depth alone as the temporal filter's input (no albedo, positions, ids
/// or motion).
pub(super) fn bare_input<'a>(
    color: &'a Image,
    normal: &'a Image,
    depth: &'a Image,
) -> TemporalFrame<'a> {
    TemporalFrame {
        color,
        albedo: None,
        normal,
        depth,
        position: None,
        ids: None,
        motion: None,
    }
}

fn random_image(w: usize, h: usize, seed: u64) -> Image {
    let mut s = seed;
    Image::from_vec(w, h, 3, (0..w * h * 3).map(|_| splitmix(&mut s)).collect())
}

fn mse(a: &Image, b: &Image) -> f64 {
    let s: f64 = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| ((x - y) as f64).powi(2))
        .sum();
    s / a.data.len() as f64
}

#[test]
fn constant_image_stays_constant_over_frames_and_motion() {
    let (w, h) = (40, 30);
    let g = flat(w, h);
    let color = Image::new(w, h, 3, 0.6);
    let albedo = Image::new(w, h, 3, 0.5);
    let mut motion = Image::new(w, h, 2, 0.0);
    let mut f = TemporalFilter::new(TemporalParams::default()).unwrap();
    for k in 0..6 {
        // Frames 3.. move by a fractional offset: bilinear history of a constant is constant.
        if k >= 3 {
            for m in motion.data.chunks_exact_mut(2) {
                m[0] = 1.25;
                m[1] = -0.5;
            }
        }
        let fr = TemporalFrame {
            albedo: Some(&albedo),
            motion: Some(&motion),
            ..frame(&color, &g)
        };
        let out = f.filter(&fr).unwrap();
        for (i, v) in out.image.data.iter().enumerate() {
            assert!((v - 0.6).abs() < 1e-5, "frame {k}, value {i}: {v}");
        }
        assert!(f.variance().data.iter().all(|&v| v < 1e-6));
    }
    // Interior pixels have a full history; pixels whose history fell off the image restart.
    let len = f.history_length();
    assert_eq!(len[15 * w + 20], 6);
    assert_eq!(len[15 * w + w - 1], 1, "its taps left the image");
}

#[test]
fn static_noisy_scene_converges_below_single_frame_atrous() {
    // Fresh 1-spp noise every frame of a static scene. The synthetic noise has fireflies
    // (1 in 500 samples ×100), so one sequence's MSE can rise from a frame to the next with
    // its input: the MSE per frame is averaged over independent sequences.
    let (w, h, runs) = (96, 96, 6u64);
    let mut errors = [0.0f64; 8];
    let mut single = 0.0f64;
    for run in 0..runs {
        let mut f = TemporalFilter::new(TemporalParams::default()).unwrap();
        for k in 0..8u64 {
            let fr = synthetic_frame(w, h, 1, 1000 * run + k);
            let out = f.filter(&still_input(&fr)).unwrap();
            assert!(out.image.data.iter().all(|v| v.is_finite()));
            errors[k as usize] += mse(&out.image, &fr.reference) / runs as f64;
            // The spatial filter on one frame alone, as the À-Trous pipeline runs it.
            let var = spatial_variance(&fr.noisy);
            let features = Features {
                normal: Some(&fr.normal),
                position: Some(&fr.position),
                depth: Some(&fr.depth),
                albedo: Some(&fr.albedo),
                variance: Some(&var),
            };
            let p = AtrousParams {
                demodulate: true,
                ..AtrousParams::default()
            };
            let e = mse(
                &atrous(&fr.noisy, &features, &p).unwrap().image,
                &fr.reference,
            );
            single += e / (8 * runs) as f64;
        }
    }
    eprintln!("temporal MSE per frame {errors:?}; single-frame À-Trous {single}");
    for k in 1..8 {
        assert!(
            errors[k] < errors[k - 1],
            "MSE rose from frame {} to {}: {errors:?}",
            k - 1,
            k
        );
    }
    assert!(errors[7] < 0.5 * errors[0], "{errors:?}");
    assert!(errors[7] < 0.4 * single, "{} vs {single}", errors[7]);
}

#[test]
fn translated_image_reprojects_history_exactly() {
    let (w, h) = (48, 40);
    let g = flat(w, h);
    let mut f = TemporalFilter::new(TemporalParams::default()).unwrap();
    let a = random_image(w, h, 3);
    f.filter(&frame(&a, &g)).unwrap();
    let prev = f.history_color().unwrap().clone();
    // The content moves by (+3, +2) px: pixel (x, y) shows what (x − 3, y − 2) showed.
    let (sx, sy) = (3usize, 2usize);
    let mut b = Image::new(w, h, 3, 0.0);
    for y in sy..h {
        for x in sx..w {
            b.pixel_mut(x, y).copy_from_slice(a.pixel(x - sx, y - sy));
        }
    }
    let mut motion = Image::new(w, h, 2, 0.0);
    for m in motion.data.chunks_exact_mut(2) {
        m[0] = -(sx as f32);
        m[1] = -(sy as f32);
    }
    let fr = TemporalFrame {
        motion: Some(&motion),
        ..frame(&b, &g)
    };
    f.filter(&fr).unwrap();
    let re = f.reprojected_history();
    for y in 0..h {
        for x in 0..w {
            let got = re.pixel(x, y);
            if x >= sx && y >= sy {
                assert_eq!(got, prev.pixel(x - sx, y - sy), "pixel ({x}, {y})");
                assert_eq!(f.history_length()[y * w + x], 2);
            } else {
                assert!(got.iter().all(|v| v.is_nan()), "({x}, {y}) has no history");
                assert_eq!(f.history_length()[y * w + x], 1);
            }
        }
    }
    // Half-pixel motion: the bilinear mean of the two neighbours.
    let prev = f.history_color().unwrap().clone();
    for m in motion.data.chunks_exact_mut(2) {
        m[0] = 0.5;
        m[1] = 0.0;
    }
    let fr = TemporalFrame {
        motion: Some(&motion),
        ..frame(&b, &g)
    };
    f.filter(&fr).unwrap();
    let re = f.reprojected_history();
    for y in 0..h {
        for x in 0..w - 1 {
            for k in 0..3 {
                let want = 0.5 * (prev.pixel(x, y)[k] + prev.pixel(x + 1, y)[k]);
                assert!((re.pixel(x, y)[k] - want).abs() < 1e-6, "({x}, {y})");
            }
        }
    }
}

#[test]
fn disoccluded_pixels_drop_their_history() {
    let (w, h) = (32, 24);
    let mut g = flat(w, h);
    let color = random_image(w, h, 5);
    let ids = vec![7u32; w * h];
    let mut f = TemporalFilter::new(TemporalParams::default()).unwrap();
    for _ in 0..3 {
        let fr = TemporalFrame {
            ids: Some(&ids),
            ..frame(&color, &g)
        };
        f.filter(&fr).unwrap();
    }
    assert!(f.history_length().iter().all(|&n| n == 3));
    // A box appears in front (depth 1.5 < 2 by 25 %) in a block; a tilted patch (normal 60°
    // away) elsewhere; another object id in a third block; the depth within tolerance (5 %)
    // in a fourth.
    let mut ids2 = ids.clone();
    for y in 2..8 {
        for x in 2..8 {
            g.depth.pixel_mut(x, y)[0] = 1.5;
            g.normal
                .pixel_mut(x + 10, y)
                .copy_from_slice(&[0.866, 0.0, 0.5]);
            ids2[y * w + x + 20] = 8;
            g.depth.pixel_mut(x, y + 10)[0] = 2.1;
        }
    }
    let fr = TemporalFrame {
        ids: Some(&ids2),
        ..frame(&color, &g)
    };
    f.filter(&fr).unwrap();
    let len = f.history_length();
    for y in 0..h {
        for x in 0..w {
            let block = (2..8).contains(&y) && [2, 12, 22].iter().any(|&b| (b..b + 6).contains(&x));
            let want = if block { 1 } else { 4 };
            assert_eq!(len[y * w + x], want, "pixel ({x}, {y})");
        }
    }
    assert!(f.reprojected_history().pixel(4, 4)[0].is_nan());
}

#[test]
fn resolution_change_and_reset_start_afresh() {
    let g = flat(16, 16);
    let c = random_image(16, 16, 1);
    let mut f = TemporalFilter::new(TemporalParams::default()).unwrap();
    f.filter(&frame(&c, &g)).unwrap();
    f.filter(&frame(&c, &g)).unwrap();
    assert!(f.history_length().iter().all(|&n| n == 2));
    let g2 = flat(20, 12);
    let c2 = random_image(20, 12, 2);
    let out = f.filter(&frame(&c2, &g2)).unwrap();
    assert_eq!((out.image.width, out.image.height), (20, 12));
    assert_eq!(f.history_size(), Some((20, 12)));
    assert!(f.history_length().iter().all(|&n| n == 1));
    f.filter(&frame(&c2, &g2)).unwrap();
    assert!(f.history_length().iter().all(|&n| n == 2));
    f.reset();
    assert_eq!(f.history_size(), None);
    f.filter(&frame(&c2, &g2)).unwrap();
    assert!(f.history_length().iter().all(|&n| n == 1));
    // A plane of the wrong size is an error, not a reset.
    let small = Image::new(4, 4, 3, 0.0);
    let bad = TemporalFrame {
        normal: &small,
        ..frame(&c2, &g2)
    };
    assert!(matches!(
        f.filter(&bad),
        Err(FilterError::SizeMismatch { .. })
    ));
    assert_eq!(f.history_size(), Some((20, 12)));
}

#[test]
fn non_finite_inputs_do_not_propagate() {
    let (w, h) = (32, 32);
    let mut g = flat(w, h);
    let mut color = random_image(w, h, 9);
    let mut albedo = Image::new(w, h, 3, 0.5);
    let mut motion = Image::new(w, h, 2, 0.0);
    let mut f = TemporalFilter::new(TemporalParams::default()).unwrap();
    f.filter(&TemporalFrame {
        albedo: Some(&albedo),
        motion: Some(&motion),
        ..frame(&color, &g)
    })
    .unwrap();
    color.pixel_mut(5, 5)[0] = f32::NAN;
    color.pixel_mut(6, 5)[1] = f32::INFINITY;
    color.pixel_mut(7, 5)[2] = f32::NEG_INFINITY;
    color.pixel_mut(20, 20)[0] = 1e30; // finite, but its l² is not
    albedo.pixel_mut(9, 9).fill(f32::NAN);
    g.normal.pixel_mut(12, 12)[1] = f32::NAN;
    g.depth.pixel_mut(14, 14)[0] = f32::NAN;
    g.position.pixel_mut(16, 16)[2] = f32::INFINITY;
    motion.pixel_mut(18, 18)[0] = f32::NAN;
    motion.pixel_mut(19, 18)[1] = f32::INFINITY;
    for k in 0..4 {
        let out = f
            .filter(&TemporalFrame {
                albedo: Some(&albedo),
                motion: Some(&motion),
                ..frame(&color, &g)
            })
            .unwrap();
        assert_eq!(out.missing, 3);
        assert!(out.image.data.iter().all(|v| v.is_finite()), "frame {k}");
        let hist = f.history_color().unwrap();
        assert!(
            hist.data.iter().all(|v| v.is_finite()),
            "history, frame {k}"
        );
        assert!(f.variance().data.iter().all(|v| v.is_finite() && *v >= 0.0));
        let len = f.history_length();
        // Missing samples keep their history without counting a frame.
        assert_eq!(len[5 * w + 5], 1, "frame {k}");
        assert_eq!(len[20 * w + 20], 1);
        // Pass-through (no usable albedo): no history, output 0 for its NaN-free colour.
        assert_eq!(len[9 * w + 9], 0);
        assert_eq!(out.image.pixel(9, 9), color.pixel(9, 9));
        // No usable normal or motion: no history; non-finite depth is background.
        assert_eq!(len[12 * w + 12], 1);
        assert_eq!(len[18 * w + 18], 1);
        assert_eq!(len[18 * w + 19], 1);
        assert_eq!(len[10 * w + 10], k as u32 + 2);
    }
}

#[test]
fn result_does_not_depend_on_the_thread_count() {
    let (w, h) = (80, 56);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut f = TemporalFilter::new(TemporalParams::default()).unwrap();
            let mut bits = vec![];
            let mut motion = Image::new(w, h, 2, 0.0);
            for k in 0..5u64 {
                let fr = synthetic_frame(w, h, 1, 40 + k);
                for (i, m) in motion.data.chunks_exact_mut(2).enumerate() {
                    m[0] = 0.3 * ((i % 7) as f32 - 3.0);
                    m[1] = 0.2 * k as f32;
                }
                let out = f
                    .filter(&TemporalFrame {
                        motion: Some(&motion),
                        ..still_input(&fr)
                    })
                    .unwrap();
                bits.extend(out.image.data.iter().map(|v| v.to_bits()));
            }
            bits
        })
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
}

/// A point on an object that moved right by one unit comes from one unit left: its motion
/// vector points there, while a static point under the same camera has none.
#[test]
fn object_motion_follows_the_object() {
    let (w, h) = (64, 64);
    let vp = pinhole_view_projection(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, [0.5, 0.5]);
    let back = object_motion(
        &[glam::Mat4::IDENTITY, glam::Mat4::IDENTITY],
        &[glam::Mat4::IDENTITY, glam::Mat4::from_translation(Vec3::X)],
    );
    assert_eq!(
        back[0],
        glam::Mat4::IDENTITY,
        "an unmoved object is the identity"
    );
    let mut position = Image::new(w, h, 3, f32::NAN);
    let centre = 32 * w + 32;
    for i in [centre, centre + 1, centre + 2] {
        position.data[i * 3..i * 3 + 3].copy_from_slice(&[0.5, 0.0, 0.0]);
    }
    let mut ids = vec![NO_OBJECT; w * h];
    ids[centre] = 1;
    ids[centre + 1] = 0;
    let m = object_motion_vectors(&vp, &vp, &position, &ids, &back);
    // One unit at distance 5 with a half extent of 0.5 is 64 / 2 / 0.5 / 5 = 12.8 pixels.
    assert!(
        (m.data[centre * 2] + 12.8).abs() < 1e-3,
        "{}",
        m.data[centre * 2]
    );
    assert!(m.data[centre * 2 + 1].abs() < 1e-4);
    assert_eq!(
        m.data[(centre + 1) * 2],
        0.0,
        "a static object's point does not move"
    );
    assert_eq!(
        m.data[(centre + 2) * 2],
        0.0,
        "a point on no object is static"
    );
    assert!(m.data[0].is_nan(), "background keeps no history");
    // Ids of the wrong size: everything is static, as with `motion_vectors`.
    let static_ = object_motion_vectors(&vp, &vp, &position, &ids[1..], &back);
    assert_eq!(static_.data[centre * 2], 0.0);
    // A different scene (another object count): nothing is carried.
    assert!(object_motion(&[glam::Mat4::IDENTITY], &back)
        .iter()
        .all(|m| *m == glam::Mat4::IDENTITY));
}

/// A deformed point's own step back wins over its object's transform; a NaN step falls back
/// to the transform, bit for bit as `object_motion_vectors`.
#[test]
fn a_deformed_point_follows_its_own_step() {
    let (w, h) = (64, 64);
    let vp = pinhole_view_projection(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, [0.5, 0.5]);
    let back = object_motion(
        &[glam::Mat4::IDENTITY],
        &[glam::Mat4::from_translation(Vec3::X)],
    );
    let mut position = Image::new(w, h, 3, f32::NAN);
    let centre = 32 * w + 32;
    for i in [centre, centre + 1] {
        position.data[i * 3..i * 3 + 3].copy_from_slice(&[0.5, 0.0, 0.0]);
    }
    let ids = vec![0; w * h];
    let mut steps = vec![Vec3::NAN; w * h];
    steps[centre] = Vec3::new(0.0, 0.5, 0.0);
    let m = surface_motion_vectors(&vp, &vp, &position, &ids, &back, &steps);
    // Half a unit up at distance 5 is 6.4 pixels up (y down on the image).
    assert!(
        (m.data[centre * 2 + 1] + 6.4).abs() < 1e-3,
        "{}",
        m.data[centre * 2 + 1]
    );
    assert!(m.data[centre * 2].abs() < 1e-4);
    let rigid = object_motion_vectors(&vp, &vp, &position, &ids, &back);
    assert_eq!(
        m.data[(centre + 1) * 2].to_bits(),
        rigid.data[(centre + 1) * 2].to_bits()
    );
    assert!((m.data[(centre + 1) * 2] + 12.8).abs() < 1e-3);
    // Steps of the wrong size are ignored.
    let short = surface_motion_vectors(&vp, &vp, &position, &ids, &back, &steps[1..]);
    assert_eq!(
        short.data[centre * 2].to_bits(),
        rigid.data[centre * 2].to_bits()
    );
}

#[test]
fn motion_vectors_of_a_sideways_camera_step() {
    let (w, h) = (64, 48);
    // 90° horizontal field of view: half extents 1 and 0.75 at distance 1.
    let half = [1.0, 0.75];
    let eye = Vec3::new(0.0, 0.0, 0.0);
    let cur = pinhole_view_projection(eye, Vec3::new(0.0, 0.0, -1.0), Vec3::Y, half);
    // The previous eye was 0.25 to the right: points at distance 2 appeared 0.25 / 2 of the
    // half width (32 px) = 4 px further left.
    let prev = pinhole_view_projection(
        Vec3::new(0.25, 0.0, 0.0),
        Vec3::new(0.25, 0.0, -1.0),
        Vec3::Y,
        half,
    );
    let mut position = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            // The pixel centre's ray (lumo's PinholeCamera) hits the plane z = −2.
            let sx = ((x as f32 + 0.5) / w as f32 * 2.0 - 1.0) * half[0];
            let sy = (1.0 - (y as f32 + 0.5) / h as f32 * 2.0) * half[1];
            let p = Vec3::new(sx, sy, -1.0) * 2.0;
            position.pixel_mut(x, y).copy_from_slice(&p.to_array());
            let px = project_to_pixel(&cur, p, w, h).unwrap();
            assert!((px[0] - (x as f32 + 0.5)).abs() < 1e-4);
            assert!((px[1] - (y as f32 + 0.5)).abs() < 1e-4);
        }
    }
    position.pixel_mut(3, 3).fill(f32::INFINITY);
    let mv = motion_vectors(&prev, &cur, &position);
    assert_eq!(mv.channels, 2);
    for y in 0..h {
        for x in 0..w {
            let m = mv.pixel(x, y);
            if (x, y) == (3, 3) {
                assert!(m[0].is_nan() && m[1].is_nan());
            } else {
                assert!((m[0] + 4.0).abs() < 1e-3 && m[1].abs() < 1e-3, "{m:?}");
            }
        }
    }
    // No camera motion: no motion. Behind the previous camera: none either.
    let still = motion_vectors(&cur, &cur, &position);
    assert!(still.data.iter().all(|v| v.is_nan() || *v == 0.0));
    let behind = pinhole_view_projection(
        Vec3::new(0.0, 0.0, -5.0),
        Vec3::new(0.0, 0.0, -6.0),
        Vec3::Y,
        half,
    );
    assert!(motion_vectors(&behind, &cur, &position)
        .data
        .iter()
        .all(|v| v.is_nan()));
}

#[test]
fn camera_step_with_computed_motion_keeps_interior_history() {
    // End to end: a textured plane seen from two camera positions 4 px apart, motion from
    // `motion_vectors`: every pixel whose surface was on screen keeps its history.
    let (w, h) = (64, 48);
    let half = [1.0, 0.75];
    let cam = |ex: f32| {
        pinhole_view_projection(
            Vec3::new(ex, 0.0, 0.0),
            Vec3::new(ex, 0.0, -1.0),
            Vec3::Y,
            half,
        )
    };
    let render = |ex: f32| {
        let mut g = flat(w, h);
        let mut color = Image::new(w, h, 3, 0.0);
        for y in 0..h {
            for x in 0..w {
                let sx = ((x as f32 + 0.5) / w as f32 * 2.0 - 1.0) * half[0];
                let sy = (1.0 - (y as f32 + 0.5) / h as f32 * 2.0) * half[1];
                let p = Vec3::new(ex + 2.0 * sx, 2.0 * sy, -2.0);
                g.position.pixel_mut(x, y).copy_from_slice(&p.to_array());
                let v = 0.5 + 0.4 * (p.x * 7.0).sin() * (p.y * 5.0).cos();
                color.pixel_mut(x, y).fill(v);
            }
        }
        (g, color)
    };
    let mut f = TemporalFilter::new(TemporalParams::default()).unwrap();
    let (g0, c0) = render(0.25);
    f.filter(&frame(&c0, &g0)).unwrap();
    let (g1, c1) = render(0.0);
    let motion = motion_vectors(&cam(0.25), &cam(0.0), &g1.position);
    f.filter(&TemporalFrame {
        motion: Some(&motion),
        ..frame(&c1, &g1)
    })
    .unwrap();
    let len = f.history_length();
    for y in 0..h {
        for x in 0..w {
            let want = if x >= 4 { 2 } else { 1 };
            assert_eq!(len[y * w + x], want, "({x}, {y})");
        }
    }
}

#[test]
fn parameters_are_checked() {
    let bad = |p: TemporalParams| TemporalFilter::new(p).is_err();
    assert!(bad(TemporalParams {
        alpha: 0.0,
        ..TemporalParams::default()
    }));
    assert!(bad(TemporalParams {
        alpha_moments: f32::NAN,
        ..TemporalParams::default()
    }));
    assert!(bad(TemporalParams {
        max_history: 0,
        ..TemporalParams::default()
    }));
    assert!(!bad(TemporalParams::default()));
}

#[test]
fn pass_through_and_background_pixels() {
    let (w, h) = (24, 16);
    let mut g = flat(w, h);
    // The top rows are background (nothing hit), the rest geometry.
    for y in 0..4 {
        for x in 0..w {
            g.depth.pixel_mut(x, y)[0] = f32::INFINITY;
            g.position.pixel_mut(x, y).fill(f32::INFINITY);
            g.normal.pixel_mut(x, y).fill(0.0);
        }
    }
    let color = random_image(w, h, 11);
    // Without an albedo, background accumulates with background.
    let mut f = TemporalFilter::new(TemporalParams::default()).unwrap();
    for _ in 0..3 {
        f.filter(&frame(&color, &g)).unwrap();
    }
    assert!(f.history_length().iter().all(|&n| n == 3));
    // With an albedo of 0 everywhere every pixel is passed through as it is.
    let black = Image::new(w, h, 1, 0.0);
    let mut f = TemporalFilter::new(TemporalParams::default()).unwrap();
    for _ in 0..2 {
        let out = f
            .filter(&TemporalFrame {
                albedo: Some(&black),
                ..frame(&color, &g)
            })
            .unwrap();
        assert_eq!(out.image, color);
        assert!(f.history_length().iter().all(|&n| n == 0));
    }
}

/// With no À-Trous level the output is the accumulated colour itself: the first frame as it
/// is, then the running mean while the history is shorter than 1/α (still camera, no
/// rejection), and no pixel borrows from its neighbours.
#[test]
fn without_levels_the_output_is_the_running_mean() {
    let (w, h) = (9, 7);
    let g = flat(w, h);
    let mut p = TemporalParams {
        alpha: 0.2,
        alpha_moments: 0.2,
        gradient_gain: 0.0,
        ..TemporalParams::default()
    };
    p.atrous.iterations = 0;
    let mut filter = TemporalFilter::new(p).expect("params");
    let frames: Vec<Image> = (0..3).map(|k| random_image(w, h, 7 + k)).collect();
    let mut mean = vec![0.0f32; w * h * 3];
    for (k, c) in frames.iter().enumerate() {
        let out = filter.filter(&frame(c, &g)).expect("filtered").image;
        let a = 1.0 / (k + 1) as f32;
        for (m, v) in mean.iter_mut().zip(&c.data) {
            *m += a * (v - *m);
        }
        for (i, (o, m)) in out.data.iter().zip(&mean).enumerate() {
            assert!(
                (o - m).abs() < 1e-6,
                "frame {k}, value {i}: {o} against {m}"
            );
        }
    }
}
