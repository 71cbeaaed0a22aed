//! The one filter interface: for every filter in `FILTERS`, the `Denoiser` path gives the same
//! image bit for bit as calling the filter's function directly; a missing plane is an error
//! that names it; the list itself has no duplicates and its names round-trip.

use lumo_filter::*;
use lumo_image::Image;

/// The synthetic frame's full G-buffer.
fn all_planes(fr: &SyntheticFrame) -> Features<'_> {
    Features {
        normal: Some(&fr.normal),
        position: Some(&fr.position),
        depth: Some(&fr.depth),
        albedo: Some(&fr.albedo),
        variance: Some(&fr.variance),
    }
}

/// The noisy image sampled every `k` pixels (at the block centres `jbu` expects).
fn low_res(img: &Image, k: usize) -> Image {
    let (lw, lh) = (img.width.div_ceil(k), img.height.div_ceil(k));
    let mut low = Image::new(lw, lh, 3, 0.0);
    for j in 0..lh {
        for i in 0..lw {
            let x = (i * k + k / 2).min(img.width - 1);
            let y = (j * k + k / 2).min(img.height - 1);
            low.pixel_mut(i, j).copy_from_slice(img.pixel(x, y));
        }
    }
    low
}

fn bits(f: &Filtered) -> Vec<u32> {
    f.image.data.iter().map(|v| v.to_bits()).collect()
}

/// The same image bit for bit, and the same missing count.
fn assert_identical(a: &Filtered, b: &Filtered, what: &str) {
    assert_eq!(
        (a.image.width, a.image.height, a.image.channels),
        (b.image.width, b.image.height, b.image.channels),
        "{what}"
    );
    assert!(bits(a) == bits(b), "{what}: images differ");
    assert_eq!(a.missing, b.missing, "{what}");
}

/// Three frames of one scene with different noise (seeds 1–3) and two broken pixels.
fn frames(w: usize, h: usize) -> Vec<SyntheticFrame> {
    (1..=3)
        .map(|seed| {
            let mut f = synthetic_frame(w, h, 1, seed);
            f.noisy.data[7] = f32::NAN;
            f.noisy.data[3 * (w + 5)] = f32::INFINITY;
            f
        })
        .collect()
}

#[test]
fn every_listed_filter_gives_its_direct_result_bit_for_bit() {
    let frs = frames(70, 45);
    for info in FILTERS {
        let mut d = (info.new)();
        assert_eq!(d.name(), info.name);
        // Direct calls with the defaults the list's constructor promises. The match is
        // exhaustive: a filter added to the list needs a reference here.
        let mut temporal = TemporalFilter::new(TemporalParams::default()).unwrap();
        for (n, fr) in frs.iter().enumerate() {
            let f = all_planes(fr);
            let (input_color, want) = match info.kind {
                FilterKind::Atrous => (
                    fr.noisy.clone(),
                    atrous(&fr.noisy, &f, &AtrousParams::default()).unwrap(),
                ),
                FilterKind::Guided => {
                    let g = build_guide(
                        GuideKind::NormalDepth,
                        &f,
                        DepthNorm::Range,
                        DEFAULT_EPS_NORMAL,
                        DEFAULT_EPS_DEPTH,
                    )
                    .unwrap();
                    (
                        fr.noisy.clone(),
                        guided(&fr.noisy, &g, &GuidedParams::default()).unwrap(),
                    )
                }
                FilterKind::Bilateral => (
                    fr.noisy.clone(),
                    bilateral(&fr.noisy, &f, &BilateralParams::default()).unwrap(),
                ),
                FilterKind::Jbu => {
                    let p = JbuParams::default();
                    let low = low_res(&fr.noisy, p.factor);
                    let want = jbu(&low, &f, &p).unwrap();
                    (low, want)
                }
                FilterKind::Temporal => {
                    let frame = TemporalFrame {
                        color: &fr.noisy,
                        albedo: f.albedo,
                        normal: &fr.normal,
                        depth: &fr.depth,
                        position: f.position,
                        ids: None,
                        motion: None,
                    };
                    (fr.noisy.clone(), temporal.filter(&frame).unwrap())
                }
                FilterKind::Auto => (
                    fr.noisy.clone(),
                    auto(&fr.noisy, &f, &AutoParams::default()).unwrap(),
                ),
            };
            let got = d.denoise(&FilterInput::new(&input_color, f)).unwrap();
            assert_identical(&got, &want, &format!("{} frame {n}", info.name));
        }
        // After a reset the temporal filter starts afresh, as a new one does; the others
        // keep giving the same result.
        if info.kind != FilterKind::Jbu {
            d.reset();
            let fr = &frs[0];
            let input = FilterInput::new(&fr.noisy, all_planes(fr));
            let again = d.denoise(&input).unwrap();
            let fresh = (info.new)().denoise(&input).unwrap();
            assert_identical(&again, &fresh, &format!("{} after reset", info.name));
        }
    }
}

#[test]
fn denoisers_with_settings_match_their_direct_calls() {
    let fr = &frames(64, 40)[0];
    let f = all_planes(fr);
    let input = FilterInput::new(&fr.noisy, f);
    // À-Trous: sparse, demodulated, fixed colour σ.
    let p = AtrousParams {
        iterations: 4,
        sigma_color: Some(2.0),
        sigma_luminance: None,
        sparse: 2,
        demodulate: true,
        use_variance: false,
        ..AtrousParams::default()
    };
    let want = atrous(&fr.noisy, &f, &p).unwrap();
    let got = AtrousDenoiser::new(p).denoise(&input).unwrap();
    assert_identical(&got, &want, "atrous");
    // Guided: every guide, a depth scale, the fast variant, demodulated.
    for guide in [GuideKind::Grey, GuideKind::Normal, GuideKind::NormalDepth] {
        let d = GuidedDenoiser {
            guide,
            depth_norm: DepthNorm::Scale(6.0),
            eps_normal: 0.01,
            eps_depth: 0.02,
            params: GuidedParams {
                radius: 5,
                fast_subsample: 2,
            },
            demodulate: true,
        };
        let g = build_guide(guide, &f, DepthNorm::Scale(6.0), 0.01, 0.02).unwrap();
        let want = with_demodulation(&fr.noisy, &fr.albedo, |c| guided(c, &g, &d.params));
        let got = d.clone().denoise(&input).unwrap();
        assert_identical(&got, &want.unwrap(), &format!("guided {guide:?}"));
    }
    // Bilateral, demodulated, with a colour term.
    let d = BilateralDenoiser {
        params: BilateralParams {
            radius: 4,
            sigma_spatial: 2.0,
            sigma_color: Some(1.0),
            ..BilateralParams::default()
        },
        demodulate: true,
    };
    let want = with_demodulation(&fr.noisy, &fr.albedo, |c| bilateral(c, &f, &d.params));
    let got = d.clone().denoise(&input).unwrap();
    assert_identical(&got, &want.unwrap(), "bilateral");
    // JBU with outlier removal off and the pre-filter on.
    let p = JbuParams {
        factor: 4,
        outlier_sigma: None,
        prefilter: true,
        ..JbuParams::default()
    };
    let low = low_res(&fr.noisy, 4);
    let want = jbu(&low, &f, &p).unwrap();
    let got = JbuDenoiser { params: p }
        .denoise(&FilterInput::new(&low, f))
        .unwrap();
    assert_identical(&got, &want, "jbu");
}

#[test]
fn the_temporal_denoiser_reads_motion_and_ids() {
    let frs = frames(48, 32);
    let (w, h) = (48, 32);
    // A constant one-pixel shift and two objects, as a moving camera would give.
    let motion = Image::new(w, h, 2, 1.0);
    let ids: Vec<u32> = (0..w * h).map(|i| (i % w < w / 2) as u32).collect();
    let mut direct = TemporalFilter::new(TemporalParams::default()).unwrap();
    let mut seam = FilterKind::Temporal.denoiser();
    for (n, fr) in frs.iter().enumerate() {
        let frame = TemporalFrame {
            color: &fr.noisy,
            albedo: Some(&fr.albedo),
            normal: &fr.normal,
            depth: &fr.depth,
            position: Some(&fr.position),
            ids: Some(&ids),
            motion: Some(&motion),
        };
        let want = direct.filter(&frame).unwrap();
        let input = FilterInput {
            motion: Some(&motion),
            ids: Some(&ids),
            ..FilterInput::new(&fr.noisy, all_planes(fr))
        };
        let got = seam.denoise(&input).unwrap();
        assert_identical(&got, &want, &format!("frame {n}"));
    }
}

/// The error's message, after checking it is a missing-feature error.
fn missing(r: Result<Filtered, FilterError>) -> String {
    match r {
        Err(e @ FilterError::MissingFeature { .. }) => e.to_string(),
        Err(e) => panic!("not a missing-feature error: {e}"),
        Ok(_) => panic!("filtered without the plane it needs"),
    }
}

#[test]
fn a_missing_plane_is_an_error_that_names_it() {
    let fr = synthetic_frame(40, 32, 1, 5);
    let all = all_planes(&fr);
    let without = |name: &str| {
        let mut f = all;
        match name {
            "normal" => f.normal = None,
            "position" => f.position = None,
            "depth" => f.depth = None,
            "albedo" => f.albedo = None,
            _ => unreachable!(),
        }
        f
    };
    let low = low_res(&fr.noisy, 16);
    for info in FILTERS {
        // The planes each filter needs with its defaults (bilateral needs none: without
        // range planes it is a Gaussian blur).
        let (color, needs): (&Image, &[&str]) = match info.kind {
            FilterKind::Atrous => (&fr.noisy, &["normal", "position"]),
            FilterKind::Guided => (&fr.noisy, &["normal", "depth"]),
            FilterKind::Bilateral => (&fr.noisy, &[]),
            FilterKind::Jbu => (&low, &[]),
            FilterKind::Temporal => (&fr.noisy, &["normal", "depth"]),
            FilterKind::Auto => (&fr.noisy, &["normal"]),
        };
        for &plane in needs {
            let e = missing((info.new)().denoise(&FilterInput::new(color, without(plane))));
            assert!(e.contains(plane), "{}: {e}", info.name);
        }
    }
    // JBU needs depth or normal.
    let f = Features {
        albedo: Some(&fr.albedo),
        ..Features::default()
    };
    let e = missing(
        FilterKind::Jbu
            .denoiser()
            .denoise(&FilterInput::new(&low, f)),
    );
    assert!(e.contains("depth or normal"), "{e}");
    // Demodulation needs the albedo.
    let demod: Vec<Box<dyn Denoiser>> = vec![
        Box::new(AtrousDenoiser::new(AtrousParams {
            demodulate: true,
            ..AtrousParams::default()
        })),
        Box::new(GuidedDenoiser {
            demodulate: true,
            ..GuidedDenoiser::default()
        }),
        Box::new(BilateralDenoiser {
            demodulate: true,
            ..BilateralDenoiser::default()
        }),
    ];
    for mut d in demod {
        let e = missing(d.denoise(&FilterInput::new(&fr.noisy, without("albedo"))));
        assert!(e.contains("albedo"), "{}: {e}", d.name());
    }
}

#[test]
fn the_filter_list_has_no_duplicates_and_its_names_round_trip() {
    for (i, info) in FILTERS.iter().enumerate() {
        assert_eq!(
            info.kind as usize, i,
            "{}: FILTERS is in FilterKind order",
            info.name
        );
        assert_eq!(info.kind.info().name, info.name);
        assert_eq!(FilterKind::from_name(info.name), Some(info.kind));
        assert_eq!(info.kind.to_string(), info.name);
        assert_eq!(info.kind.denoiser().name(), info.name);
        assert!(
            !info.name.is_empty()
                && info
                    .name
                    .bytes()
                    .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-'),
            "{}: a command-line name",
            info.name
        );
        assert!(!info.title.is_empty() && !info.description.is_empty());
        assert!(!info.description.contains('\n'), "{}: one line", info.name);
        for other in &FILTERS[..i] {
            assert_ne!(other.kind, info.kind);
            assert_ne!(other.name, info.name);
            assert_ne!(other.title, info.title);
        }
    }
    assert_eq!(FilterKind::from_name("none"), None);
    assert_eq!(FilterKind::from_name("Atrous"), None);
}

#[test]
fn table2_runs_every_configuration_through_the_interface() {
    let fr = synthetic_frame(40, 24, 1, 7);
    let mut configs = table2::table2_configs();
    assert_eq!(configs.len(), 12 + 1 + 6 + 3);
    for c in &mut configs {
        c.run(&fr).unwrap_or_else(|e| panic!("{}: {e}", c.label));
        c.run(&fr)
            .unwrap_or_else(|e| panic!("{} again: {e}", c.label));
    }
    let listed = configs.iter().filter(|c| c.speed_table).count();
    assert_eq!(
        listed,
        configs.len() - 3,
        "all but the unweighted À-Trous rows"
    );
}
