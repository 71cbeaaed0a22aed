//! The À-Trous filter against the plain B3 convolution, with demodulation, variance guidance
//! and sparse input.

use lumo_filter::*;
use lumo_image::Image;

use crate::support::*;

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
