//! The light search on small synthetic frames.

use super::*;

/// A ceiling lit only by one bright uniform patch, at one sample per pixel: 30 % of the
/// pixels found the patch and carry exactly its value (1.0), the rest almost nothing.
fn bounce_clusters(w: usize, h: usize) -> Image {
    let mut img = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            // A well-mixed hash (splitmix64) of the pixel: independent samples.
            let mut z = (y * w + x) as u64 + 0x9e37_79b9_7f4a_7c15;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            let u = ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32;
            let v = if u < 0.3 { 1.0 } else { 0.01 * u };
            img.pixel_mut(x, y).fill(v);
        }
    }
    img
}

/// A noisy grey wall (deterministic hash noise of relative amplitude `amp`) with a
/// light of radiance `le` in the rectangle [x0, x1) × [y0, y1).
fn wall_with_light(w: usize, h: usize, amp: f32, le: f32, rect: [usize; 4]) -> Image {
    let mut img = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            let u = (((x * 73856093) ^ (y * 19349663)) % 1000) as f32 / 1000.0;
            let v = if (rect[0]..rect[1]).contains(&x) && (rect[2]..rect[3]).contains(&y) {
                le
            } else {
                0.4 * (1.0 + amp * (2.0 * u - 1.0))
            };
            img.pixel_mut(x, y).fill(v);
        }
    }
    img
}

#[test]
fn finds_a_large_light_and_its_rim_and_nothing_else() {
    let img = wall_with_light(64, 48, 0.9, 30.0, [10, 40, 5, 30]);
    let found = detect_emitters(&img, &Features::default(), &EmitterParams::default()).unwrap();
    let m: Vec<bool> = (0..64 * 48)
        .map(|i| found.light[i] || found.rim[i])
        .collect();
    for y in 0..48 {
        for x in 0..64 {
            let inside = (10..40).contains(&x) && (5..30).contains(&y);
            let rim = (9..41).contains(&x) && (4..31).contains(&y);
            assert!(!inside || m[y * 64 + x], "light pixel ({x}, {y}) missed");
            assert!(rim || !m[y * 64 + x], "wall pixel ({x}, {y}) marked");
        }
    }
}

#[test]
fn an_isolated_firefly_and_a_constant_frame_are_not_lights() {
    let mut img = wall_with_light(32, 32, 0.9, 0.4, [0, 0, 0, 0]);
    img.pixel_mut(16, 16).fill(500.0);
    let m = detect_emitters(&img, &Features::default(), &EmitterParams::default()).unwrap();
    assert!(m.light.iter().chain(&m.rim).all(|&b| !b));
    let flat = Image::new(32, 32, 3, 2.0);
    let m = detect_emitters(&flat, &Features::default(), &EmitterParams::default()).unwrap();
    assert!(m.light.iter().chain(&m.rim).all(|&b| !b));
}

#[test]
fn clusters_of_equal_bounce_samples_are_not_lights_but_a_light_among_them_is() {
    // A ceiling lit only by one bright uniform patch, at one sample per pixel: 30 % of
    // the pixels found the patch and carry exactly its value (1.0), the rest almost
    // nothing. Neighbouring hits are flat and far above the window's geometric mean.
    let (w, h) = (64, 64);
    let mut img = bounce_clusters(w, h);
    let count = |m: &EmitterMask| m.light.iter().filter(|&&b| b).count();
    let keep_all = EmitterParams {
        region_contrast: 0.0,
        ..EmitterParams::default()
    };
    let f = Features::default();
    let before = count(&detect_emitters(&img, &f, &keep_all).unwrap());
    let after = count(&detect_emitters(&img, &f, &EmitterParams::default()).unwrap());
    // (A cluster at the border, where its surroundings are few, may survive by chance.)
    assert!(before > 200 && after * 10 < before, "{before} → {after}");
    // A light of radiance 20 on the same ceiling is still found, whole.
    for y in 20..32 {
        for x in 24..40 {
            img.pixel_mut(x, y).fill(20.0);
        }
    }
    let found = detect_emitters(&img, &f, &EmitterParams::default()).unwrap();
    let mut outside = 0;
    for y in 0..h {
        for x in 0..w {
            let inside = (24..40).contains(&x) && (20..32).contains(&y);
            assert!(
                !inside || found.light[y * w + x],
                "light pixel ({x}, {y}) missed"
            );
            outside += usize::from(!inside && found.light[y * w + x]);
        }
    }
    assert!(outside * 10 < before, "{outside} ceiling pixels marked");
}

#[test]
fn a_nan_or_negative_region_contrast_is_an_error() {
    let img = Image::new(8, 8, 3, 1.0);
    for bad in [f32::NAN, -1.0, f32::INFINITY] {
        let p = EmitterParams {
            region_contrast: bad,
            ..EmitterParams::default()
        };
        let e = detect_emitters(&img, &Features::default(), &p).unwrap_err();
        assert!(e.to_string().contains("region_contrast"), "{e}");
    }
}

#[test]
fn a_bright_texture_explained_by_its_albedo_is_not_a_light() {
    // White squares (albedo 0.9) on a black floor (albedo 0.005) under even light: 180×
    // brighter, flat — and fully explained by the albedo.
    let (w, h) = (48, 48);
    let mut albedo = Image::new(w, h, 3, 0.0);
    let mut color = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            let a = if (x / 8 + y / 8) % 2 == 0 { 0.9 } else { 0.005 };
            albedo.pixel_mut(x, y).fill(a);
            color.pixel_mut(x, y).fill(a * 0.7);
        }
    }
    let f = Features {
        albedo: Some(&albedo),
        ..Features::default()
    };
    let m = detect_emitters(&color, &f, &EmitterParams::default()).unwrap();
    assert!(m.light.iter().all(|&b| !b));
    // Without the albedo the same frame's white squares would pass for lights.
    let m = detect_emitters(&color, &Features::default(), &EmitterParams::default()).unwrap();
    assert!(m.light.iter().any(|&b| b));
}

/// `frame`'s noisy colour with a light pasted in: radiance `le` (its albedo 0.75) on the
/// rectangle [x0, x1) × [y0, y1), and its anti-aliased rim half covered.
fn with_light(frame: &crate::SyntheticFrame, le: f32, rect: [usize; 4]) -> (Image, Image) {
    let (mut color, mut albedo) = (frame.noisy.clone(), frame.albedo.clone());
    for y in rect[2].saturating_sub(1)..rect[3] + 1 {
        for x in rect[0].saturating_sub(1)..rect[1] + 1 {
            let inside = (rect[0]..rect[1]).contains(&x) && (rect[2]..rect[3]).contains(&y);
            let c = color.pixel_mut(x, y);
            for v in c.iter_mut() {
                *v = if inside { le } else { 0.5 * (*v + le) };
            }
            albedo.pixel_mut(x, y).fill(0.75);
        }
    }
    (color, albedo)
}

/// The fast search finds the same mask as the plain version it replaced (which may differ
/// only for a pixel within a few 1e-7 of the brightness threshold, where the two forms of the
/// test round differently), on frames with lights large and small, sky, missing pixels, converged and 1-spp noise, bounce
/// clusters, and with other settings; and on each the mask is not trivial.
#[test]
fn same_mask_as_the_plain_search() {
    let mut cases: Vec<(String, Image, Option<Image>, Option<crate::SyntheticFrame>)> = Vec::new();
    for (spp, seed) in [(1, 3), (4, 5), (64, 9)] {
        let f = crate::synthetic_frame(160, 120, spp, seed);
        let (mut color, albedo) = with_light(&f, 20.0, [30, 70, 10, 25]);
        let (c2, _) = with_light(&f, 5.0, [120, 123, 60, 62]);
        for y in 60..62 {
            for x in 120..123 {
                color.pixel_mut(x, y).copy_from_slice(c2.pixel(x, y));
            }
        }
        if spp == 4 {
            // Missing pixels, inside the light and out.
            color.pixel_mut(40, 15)[1] = f32::NAN;
            color.pixel_mut(100, 100)[0] = f32::INFINITY;
        }
        cases.push((format!("synthetic {spp} spp"), color, Some(albedo), Some(f)));
        let conv = crate::synthetic_frame(160, 120, 1, seed);
        let conv = crate::SyntheticFrame {
            noisy: conv.reference.clone(),
            ..conv
        };
        let (color, albedo) = with_light(&conv, 200.0, [20, 40, 70, 85]);
        cases.push((format!("converged {seed}"), color, Some(albedo), Some(conv)));
    }
    // Tall enough for eight bands of rows at the default radius (the search takes one band
    // where the 2r + 2 rows it keeps would be as tall as a band, as on the frames above).
    let tall = crate::synthetic_frame(200, 272, 4, 11);
    let (color, albedo) = with_light(&tall, 30.0, [40, 90, 150, 190]);
    cases.push(("synthetic 200×272".into(), color, Some(albedo), Some(tall)));
    cases.push((
        "wall".into(),
        wall_with_light(97, 61, 0.9, 30.0, [10, 40, 5, 30]),
        None,
        None,
    ));
    let mut img = bounce_clusters(96, 80);
    for y in 20..32 {
        for x in 24..40 {
            img.pixel_mut(x, y).fill(20.0);
        }
    }
    cases.push(("bounce clusters".into(), img, None, None));
    let settings = [
        EmitterParams::default(),
        EmitterParams {
            dilate: 3,
            radius: 3,
            flat_neighbours: 2,
            ..EmitterParams::default()
        },
        EmitterParams {
            region_contrast: 0.0,
            dilate: 0,
            ..EmitterParams::default()
        },
        // A radius whose ring is as tall as a band: the whole frame is one band.
        EmitterParams {
            radius: 20,
            ..EmitterParams::default()
        },
    ];
    for (name, color, albedo, frame) in &cases {
        let f = Features {
            albedo: albedo.as_ref(),
            normal: frame.as_ref().map(|f| &f.normal),
            position: frame.as_ref().map(|f| &f.position),
            depth: frame.as_ref().map(|f| &f.depth),
            variance: None,
        };
        for p in &settings {
            let fast = detect_emitters(color, &f, p).unwrap();
            let plain = super::reference::detect_emitters_reference(color, &f, p).unwrap();
            let lights = fast.light.iter().filter(|&&b| b).count();
            let rims = fast.rim.iter().filter(|&&b| b).count();
            assert!(
                lights > 0 && (rims > 0 || p.dilate == 0),
                "{name}: nothing found"
            );
            assert!(fast == plain, "{name}, {p:?}: masks differ");
        }
    }
}

/// An emission plane's rim is the plain per-pixel dilation over non-background pixels, less
/// the lights, at one and two rings (a light touching the sky, which gets no rim).
#[test]
fn emission_rim_is_the_plain_dilation() {
    let (w, h) = (24, 16);
    let mut emission = Image::new(w, h, 3, 0.0);
    let mut depth = Image::new(w, h, 1, 2.0);
    for y in 0..h {
        for x in 0..w {
            if (5..9).contains(&x) && (4..7).contains(&y) || (x, y) == (15, 12) {
                emission.pixel_mut(x, y)[1] = 3.0;
            }
            if y < 5 && x >= 7 {
                depth.pixel_mut(x, y)[0] = f32::INFINITY;
            }
        }
    }
    let f = Features {
        depth: Some(&depth),
        ..Features::default()
    };
    let bg = |x: usize, y: usize| !depth.pixel(x, y)[0].is_finite();
    for steps in [1, 2] {
        let m = EmitterMask::from_emission(&emission, &f, steps).unwrap();
        let mut grown: Vec<bool> = (0..w * h)
            .map(|i| emission.data[i * 3 + 1] != 0.0 && !bg(i % w, i / w))
            .collect();
        for _ in 0..steps {
            grown = (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as isize, (i / w) as isize);
                    grown[i]
                        || !bg(i % w, i / w)
                            && (-1..=1).any(|dy| {
                                (-1..=1).any(|dx| {
                                    let (xx, yy) = (x + dx, y + dy);
                                    (0..w as isize).contains(&xx)
                                        && (0..h as isize).contains(&yy)
                                        && grown[yy as usize * w + xx as usize]
                                })
                            })
                })
                .collect();
        }
        let want: Vec<bool> = (0..w * h).map(|i| grown[i] && !m.light[i]).collect();
        assert!(want.iter().filter(|&&b| b).count() > 10);
        assert_eq!(m.rim, want, "{steps} rings");
    }
}
