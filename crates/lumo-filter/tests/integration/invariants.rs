//! Invariants every filter keeps: constants stay constant, guide edges stay sharp, broken
//! inputs give finite outputs or typed errors, and noise goes down on the synthetic scene.

use lumo_filter::*;
use lumo_image::Image;

use crate::support::*;

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

/// Sky above a noisy wall, crossed by a wire thinner than a pixel: at 4 spp a sky pixel the
/// wire crosses off-centre is darker than the sky and has a quarter of the wire's albedo (the
/// renderers average albedo over samples, misses counting 0). Every demodulating filter must
/// pass such background pixels through: divided by that small albedo they were tens of times
/// brighter than their neighbours, and filtering them erased the wire and spread its pixels'
/// light (`tune-wires`, docs/filters.md "Background pixels"). The temporal filter too, on its
/// first frame and with a history.
#[test]
fn background_pixels_with_a_partial_albedo_are_passed_through_by_demodulating_filters() {
    let (w, h) = (48, 32);
    let sky = [0.8f32, 1.0, 1.4];
    let mut next = rng(7);
    let mut normal = Image::new(w, h, 3, 0.0);
    let mut depth = Image::new(w, h, 1, f32::INFINITY);
    let mut position = Image::new(w, h, 3, f32::NAN);
    let mut albedo = Image::new(w, h, 3, 0.0);
    let mut color = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            if y >= h / 2 {
                normal.pixel_mut(x, y).copy_from_slice(&[0.0, 1.0, 0.0]);
                depth.pixel_mut(x, y)[0] = 3.0;
                let p = [x as f32 * 0.05, 0.0, y as f32 * 0.05];
                position.pixel_mut(x, y).copy_from_slice(&p);
                albedo.pixel_mut(x, y).fill(0.5);
                let v = 0.5 * (0.2 + 0.4 * next());
                color.pixel_mut(x, y).fill(v);
            } else {
                let wire = y == x / 3 % (h / 2);
                let (k, a) = if wire {
                    (0.55 + 0.1 * next(), 0.025)
                } else {
                    (1.0, 0.0)
                };
                for c in 0..3 {
                    color.pixel_mut(x, y)[c] = sky[c] * k;
                }
                albedo.pixel_mut(x, y).fill(a);
            }
        }
    }
    let f = Features {
        normal: Some(&normal),
        position: Some(&position),
        depth: Some(&depth),
        albedo: Some(&albedo),
        variance: None,
    };
    let mut filters: Vec<Box<dyn Denoiser>> = vec![
        Box::new(AutoDenoiser::default()),
        Box::new(GuidedDenoiser {
            demodulate: true,
            ..GuidedDenoiser::default()
        }),
        Box::new(BilateralDenoiser {
            params: BilateralParams::default(),
            demodulate: true,
        }),
        Box::new(AtrousDenoiser::new(AtrousParams {
            demodulate: true,
            ..AtrousParams::default()
        })),
        // The temporal filter's first frame (no history yet) and a second one.
        Box::new(TemporalFilter::new(TemporalParams::default()).unwrap()),
    ];
    let second = filters.len() - 1;
    filters.push(Box::new(
        TemporalFilter::new(TemporalParams::default()).unwrap(),
    ));
    let _ = filters[second + 1]
        .denoise(&FilterInput::new(&color, f))
        .unwrap();
    for d in filters.iter_mut() {
        let out = d.denoise(&FilterInput::new(&color, f)).unwrap().image;
        for i in 0..w * h / 2 {
            for c in 0..3 {
                let (o, v) = (out.data[i * 3 + c], color.data[i * 3 + c]);
                assert_eq!(
                    o,
                    v,
                    "{}: background pixel {i} channel {c} changed",
                    d.name()
                );
            }
        }
    }
}

/// A depth plane is 1 channel or 3 equal ones; a plane whose channels differ (a normal or
/// position plane given as depth) is refused by every filter, naming the first pixel that
/// differs, instead of steering the filter with one coordinate.
#[test]
fn a_depth_plane_whose_channels_differ_is_refused() {
    let (w, h) = (6, 5);
    let color = Image::new(w, h, 3, 0.5);
    let normal = Image::new(w, h, 3, 0.577);
    let one = Image::new(w, h, 1, 2.0);
    let mut equal = Image::new(w, h, 3, 2.0);
    // Background: NaN in every channel is not a difference.
    equal.pixel_mut(0, 0).fill(f32::NAN);
    assert!(check_depth_plane(&one).is_ok());
    assert!(check_depth_plane(&equal).is_ok());
    let mut differ = equal.clone();
    differ.pixel_mut(4, 3)[2] = 2.5;
    let e = check_depth_plane(&differ).unwrap_err();
    assert!(
        matches!(
            e,
            FilterError::DepthChannelsDiffer {
                x: 4,
                y: 3,
                channels: 3,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(
        e.to_string().contains("normal or the position plane"),
        "{e}"
    );
    for mut f in [
        Box::new(GuidedDenoiser::default()) as Box<dyn Denoiser>,
        Box::new(AutoDenoiser::default()),
        Box::new(BilateralDenoiser::default()),
    ] {
        let features = Features {
            normal: Some(&normal),
            depth: Some(&differ),
            ..Features::default()
        };
        let input = FilterInput::new(&color, features);
        let e = f.denoise(&input).unwrap_err();
        assert!(
            matches!(e, FilterError::DepthChannelsDiffer { .. }),
            "{}: {e:?}",
            f.name()
        );
    }
}

/// Beside a bright edge the guided filter's linear model overshoots below zero (a step in the
/// colour over a ramp in the guide is fitted by a line); as denoisers of light the guided
/// filter and `auto` clamp such values at 0, while the pure `guided` keeps them.
#[test]
fn guided_and_auto_denoisers_give_no_negative_light() {
    let (w, h) = (48, 8);
    let mut color = Image::new(w, h, 3, 0.0);
    let mut normal = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            // Noisy on both sides, so that `auto` prefers wide windows there too.
            let n = (((x * 7 + y * 13) * 2654435761usize) % 1000) as f32 / 1000.0;
            let v = if x < w / 2 {
                0.02 * n
            } else {
                100.0 * (0.5 + n)
            };
            color.pixel_mut(x, y).fill(v);
            // A ramp across the whole frame: every window sees the step as a slope.
            let t = x as f32 / w as f32;
            normal
                .pixel_mut(x, y)
                .copy_from_slice(&[t, 0.0, (1.0 - t * t).sqrt()]);
        }
    }
    let guide = build_guide(
        GuideKind::Normal,
        &Features {
            normal: Some(&normal),
            ..Features::default()
        },
        DepthNorm::Range,
        0.001,
        0.001,
    )
    .unwrap();
    let params = GuidedParams {
        radius: 8,
        ..GuidedParams::default()
    };
    let raw = guided(&color, &guide, &params).unwrap();
    let min = raw.image.data.iter().copied().fold(f32::INFINITY, f32::min);
    assert!(min < 0.0, "the case must overshoot: min {min}");
    for mut f in [
        Box::new(GuidedDenoiser {
            guide: GuideKind::Normal,
            params,
            ..GuidedDenoiser::default()
        }) as Box<dyn Denoiser>,
        Box::new(AutoDenoiser::default()),
    ] {
        let features = Features {
            normal: Some(&normal),
            ..Features::default()
        };
        let out = f.denoise(&FilterInput::new(&color, features)).unwrap();
        let min = out.image.data.iter().copied().fold(f32::INFINITY, f32::min);
        assert!(min >= 0.0, "{}: min {min}", f.name());
    }
}
