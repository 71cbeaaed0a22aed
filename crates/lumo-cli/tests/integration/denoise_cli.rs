//! End-to-end tests of `lumo denoise` on small EXR inputs.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use lumo_image::{read_image, write_image, Image};

fn temp_dir(name: &str) -> PathBuf {
    super::common::temp_dir("denoise", name)
}

fn lumo(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lumo"))
        .arg("denoise")
        .args(args)
        .output()
        .expect("run lumo")
}

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Writes a noisy 32×24 G-buffer (left/right halves on different planes) into `dir`.
fn write_scene(dir: &Path, w: usize, h: usize) {
    let mut color = Image::new(w, h, 3, 0.0);
    let mut normal = Image::new(w, h, 3, 0.0);
    let mut position = Image::new(w, h, 3, 0.0);
    let mut depth = Image::new(w, h, 1, 0.0);
    let albedo = Image::new(w, h, 3, 0.5);
    let variance = Image::new(w, h, 1, 0.01);
    let mut s = 12345u64;
    for y in 0..h {
        for x in 0..w {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let r = (s >> 40) as f32 / (1u64 << 24) as f32;
            let left = x < w / 2;
            let base = if left { 0.2 } else { 0.8 };
            color.pixel_mut(x, y).fill(base * (0.5 + r));
            normal.pixel_mut(x, y).copy_from_slice(if left {
                &[0.0, 0.0, 1.0]
            } else {
                &[1.0, 0.0, 0.0]
            });
            let d = if left { 2.0 } else { 4.0 };
            depth.pixel_mut(x, y)[0] = d;
            position
                .pixel_mut(x, y)
                .copy_from_slice(&[x as f32 * 0.05, y as f32 * 0.05, -d]);
        }
    }
    for (name, img) in [
        ("color", &color),
        ("normal", &normal),
        ("position", &position),
        ("depth", &depth),
        ("albedo", &albedo),
        ("variance", &variance),
    ] {
        write_image(&dir.join(format!("{name}.exr")), img).unwrap();
    }
}

#[test]
fn every_filter_runs_from_an_input_dir_and_prints_timings() {
    let dir = temp_dir("ok");
    write_scene(&dir, 32, 24);
    for filter in ["atrous", "guided", "bilateral"] {
        let out = dir.join(format!("out-{filter}.exr"));
        let o = lumo(&[
            "--input-dir",
            dir.to_str().unwrap(),
            "--filter",
            filter,
            "--radius",
            "4",
            "--timings",
            "-o",
            out.to_str().unwrap(),
        ]);
        let (stdout, stderr) = text(&o);
        assert!(o.status.success(), "{filter}: {stderr}");
        for stage in ["read ", "filter ", "write "] {
            assert!(
                stdout
                    .lines()
                    .any(|l| l.starts_with(stage) && l.ends_with(" ms")),
                "{filter}: no '{stage}… ms' line in {stdout:?}"
            );
        }
        let img = read_image(&out).unwrap();
        assert_eq!((img.width, img.height, img.channels), (32, 24, 3));
        assert_eq!(img.non_finite_count(), 0);
    }
    // PNG output and explicit flags.
    let png = dir.join("out.png");
    let o = lumo(&[
        "--color",
        dir.join("color.exr").to_str().unwrap(),
        "--normal",
        dir.join("normal.exr").to_str().unwrap(),
        "--filter",
        "guided",
        "--guide-dims",
        "3",
        "--fast-subsample",
        "2",
        "-o",
        png.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    assert!(png.is_file());
}

#[test]
fn size_mismatch_names_both_files() {
    let dir = temp_dir("size");
    write_scene(&dir, 32, 24);
    let small = dir.join("small-normal.exr");
    write_image(&small, &Image::new(16, 24, 3, 0.0)).unwrap();
    let o = lumo(&[
        "--input-dir",
        dir.to_str().unwrap(),
        "--normal",
        small.to_str().unwrap(),
        "-o",
        dir.join("out.exr").to_str().unwrap(),
    ]);
    let (_, stderr) = text(&o);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("color.exr") && stderr.contains("small-normal.exr"),
        "{stderr}"
    );
    assert!(
        stderr.contains("32x24") && stderr.contains("16x24"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn missing_feature_lists_what_the_filter_needs() {
    let dir = temp_dir("feature");
    write_scene(&dir, 16, 16);
    let o = lumo(&[
        "--color",
        dir.join("color.exr").to_str().unwrap(),
        "--filter",
        "guided",
        "--guide-dims",
        "4",
        "-o",
        dir.join("out.exr").to_str().unwrap(),
    ]);
    let (_, stderr) = text(&o);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("--normal") && stderr.contains("--depth"),
        "{stderr}"
    );
    let o = lumo(&[
        "--color",
        dir.join("color.exr").to_str().unwrap(),
        "--filter",
        "bilateral",
        "-o",
        dir.join("out.exr").to_str().unwrap(),
    ]);
    let (_, stderr) = text(&o);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("--normal") && stderr.contains("--depth") && stderr.contains("--position"),
        "{stderr}"
    );
    let o = lumo(&[
        "--color",
        dir.join("color.exr").to_str().unwrap(),
        "--demodulate",
        "-o",
        dir.join("out.exr").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).1.contains("--albedo"), "{}", text(&o).1);
    // The default filter (auto) names the option and the filter that needs no normals.
    let o = lumo(&[
        "--color",
        dir.join("color.exr").to_str().unwrap(),
        "-o",
        dir.join("out.exr").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let (_, stderr) = text(&o);
    assert!(
        stderr.contains("--normal") && stderr.contains("--filter atrous"),
        "{stderr}"
    );
}

#[test]
fn nan_pixels_warn_with_their_count_and_output_is_finite() {
    let dir = temp_dir("nan");
    write_scene(&dir, 24, 16);
    let mut c = read_image(&dir.join("color.exr")).unwrap();
    c.pixel_mut(3, 3)[0] = f32::NAN;
    c.pixel_mut(10, 5)[2] = f32::INFINITY;
    c.pixel_mut(11, 5).fill(f32::NAN);
    write_image(&dir.join("color.exr"), &c).unwrap();
    for filter in ["atrous", "guided", "bilateral"] {
        let out = dir.join(format!("out-{filter}.pfm"));
        let o = lumo(&[
            "--input-dir",
            dir.to_str().unwrap(),
            "--filter",
            filter,
            "--radius",
            "3",
            "-o",
            out.to_str().unwrap(),
        ]);
        let (_, stderr) = text(&o);
        assert!(o.status.success(), "{stderr}");
        assert!(stderr.contains("warning: 3 pixel(s)"), "{stderr}");
        assert_eq!(read_image(&out).unwrap().non_finite_count(), 0, "{filter}");
    }
}

/// Finite values too large for the filters' sums of squares (1e37 once made `auto` write NaN
/// everywhere and bilateral Inf) are treated as missing with a warning, and the output is
/// finite and no larger than the input's plausible range.
#[test]
fn huge_finite_pixels_are_treated_as_missing_with_a_warning() {
    let dir = temp_dir("huge");
    write_scene(&dir, 24, 16);
    let mut c = read_image(&dir.join("color.exr")).unwrap();
    c.pixel_mut(3, 3)[0] = 1e37;
    c.pixel_mut(12, 7).fill(-3e38);
    write_image(&dir.join("color.pfm"), &c).unwrap();
    std::fs::remove_file(dir.join("color.exr")).unwrap();
    for filter in ["atrous", "guided", "bilateral", "auto"] {
        let out = dir.join(format!("out-{filter}.pfm"));
        let o = lumo(&[
            "--input-dir",
            dir.to_str().unwrap(),
            "--filter",
            filter,
            "-o",
            out.to_str().unwrap(),
        ]);
        let (_, stderr) = text(&o);
        assert!(o.status.success(), "{filter}: {stderr}");
        assert!(
            stderr.contains("warning: 2 pixel(s)") && stderr.contains("beyond ±1e15"),
            "{filter}: {stderr}"
        );
        assert!(!stderr.contains("NaN or infinite"), "{filter}: {stderr}");
        let img = read_image(&out).unwrap();
        assert_eq!(img.non_finite_count(), 0, "{filter}");
        let max = img.data.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        assert!(max < 10.0, "{filter}: max {max}");
    }
}

#[test]
fn unreadable_input_names_the_file_and_reason() {
    let dir = temp_dir("unreadable");
    let bad = dir.join("color.exr");
    std::fs::write(&bad, b"not an exr").unwrap();
    let o = lumo(&[
        "--color",
        bad.to_str().unwrap(),
        "-o",
        dir.join("o.exr").to_str().unwrap(),
    ]);
    let (_, stderr) = text(&o);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr.contains("color.exr") && stderr.starts_with("error:"),
        "{stderr}"
    );
    let o = lumo(&[
        "--color",
        dir.join("nope.exr").to_str().unwrap(),
        "-o",
        dir.join("o.exr").to_str().unwrap(),
    ]);
    let (_, stderr) = text(&o);
    assert!(
        stderr.contains("nope.exr")
            && stderr.contains("no such file")
            && stderr.matches("nope.exr").count() == 1,
        "{stderr}"
    );
}

/// A flat, noise-free wall (colour 0.5) with a bright 4×4 emitter (50) in the same plane.
fn write_wall_with_light(dir: &Path, with_emission: bool) {
    let (w, h) = (24, 24);
    let mut color = Image::new(w, h, 3, 0.5);
    let mut emission = Image::new(w, h, 3, 0.0);
    let normal = {
        let mut n = Image::new(w, h, 3, 0.0);
        for i in 0..w * h {
            n.data[i * 3 + 2] = 1.0;
        }
        n
    };
    let mut position = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            position
                .pixel_mut(x, y)
                .copy_from_slice(&[x as f32 * 0.1, y as f32 * 0.1, -3.0]);
            if (10..14).contains(&x) && (10..14).contains(&y) {
                color.pixel_mut(x, y).fill(50.0);
                emission.pixel_mut(x, y).fill(49.5);
            }
        }
    }
    let depth = Image::new(w, h, 1, 3.0);
    let albedo = Image::new(w, h, 3, 0.7);
    let mut planes = vec![
        ("color", &color),
        ("normal", &normal),
        ("position", &position),
        ("depth", &depth),
        ("albedo", &albedo),
    ];
    if with_emission {
        planes.push(("emission", &emission));
    }
    for (name, img) in planes {
        write_image(&dir.join(format!("{name}.exr")), img).unwrap();
    }
}

#[test]
fn emitters_in_the_emission_plane_stay_sharp_and_do_not_bleed() {
    for filter in ["atrous", "guided", "bilateral"] {
        let worst = |with_emission: bool, detect: bool| {
            let dir = temp_dir(&format!("emit-{filter}-{with_emission}-{detect}"));
            write_wall_with_light(&dir, with_emission);
            let out = dir.join("out.exr");
            let mut args = vec![
                "--input-dir",
                dir.to_str().unwrap(),
                "--filter",
                filter,
                "-o",
                out.to_str().unwrap(),
            ];
            if !detect {
                args.push("--no-detect-emitters");
            }
            let o = lumo(&args);
            assert!(o.status.success(), "{filter}: {:?}", text(&o));
            let img = read_image(&out).unwrap();
            let (mut wall, mut light) = (0.0f32, 0.0f32);
            for y in 0..24 {
                for x in 0..24 {
                    let v = img.pixel(x, y)[1];
                    if (10..14).contains(&x) && (10..14).contains(&y) {
                        light = light.max((v - 50.0).abs());
                    } else {
                        wall = wall.max((v - 0.5).abs());
                    }
                }
            }
            (wall, light)
        };
        let (wall, light) = worst(true, true);
        assert!(wall < 1e-3, "{filter}: light bled into the wall by {wall}");
        assert!(light < 1e-3, "{filter}: the light changed by {light}");
        // Without the plane the light is found in the frame (lumo_filter::detect_emitters):
        // the same result.
        let (wall, light) = worst(false, true);
        assert!(wall < 1e-3, "{filter}, detected: light bled by {wall}");
        assert!(
            light < 1e-3,
            "{filter}, detected: the light changed by {light}"
        );
        // With neither, the same input does bleed into the wall for the filters that have
        // no colour weight (À-Trous' spatial-variance colour weight stops at this noise-free
        // rim by itself): the test sees the difference.
        if filter == "atrous" {
            continue;
        }
        let (wall_without, _) = worst(false, false);
        assert!(
            wall_without > 0.05,
            "{filter}: expected bleeding with no plane and no search, got {wall_without}"
        );
    }
}

#[test]
fn light_mask_shows_what_the_search_passed_through_and_needs_the_search() {
    let dir = temp_dir("light-mask");
    write_wall_with_light(&dir, false);
    let (out, mask) = (dir.join("out.exr"), dir.join("mask.png"));
    let base = [
        "--input-dir",
        dir.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ];
    let o = lumo(&[&base[..], &["--light-mask", mask.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{:?}", text(&o));
    assert!(
        text(&o).1.contains("16 pixel(s) taken for lights"),
        "{:?}",
        text(&o)
    );
    let m = read_image(&mask).unwrap();
    for y in 0..24 {
        for x in 0..24 {
            let want = if (10..14).contains(&x) && (10..14).contains(&y) {
                1.0
            } else if (9..15).contains(&x) && (9..15).contains(&y) {
                0.5
            } else {
                0.0
            };
            assert!((m.pixel(x, y)[0] - want).abs() < 0.01, "({x}, {y})");
        }
    }
    // No search, no mask: said before anything is read or written.
    let o = lumo(
        &[
            &base[..],
            &[
                "--light-mask",
                mask.to_str().unwrap(),
                "--no-detect-emitters",
            ],
        ]
        .concat(),
    );
    assert!(!o.status.success());
    assert!(
        text(&o).1.contains("--no-detect-emitters"),
        "{:?}",
        text(&o)
    );
    write_wall_with_light(&dir, true);
    let o = lumo(&[&base[..], &["--light-mask", mask.to_str().unwrap()]].concat());
    assert!(!o.status.success());
    assert!(text(&o).1.contains("emission plane"), "{:?}", text(&o));
}

#[test]
fn variance_source_plane_without_a_plane_is_an_error() {
    let dir = temp_dir("nosrc");
    write_wall_with_light(&dir, false);
    let o = lumo(&[
        "--input-dir",
        dir.to_str().unwrap(),
        "--variance-source",
        "plane",
        "-o",
        dir.join("o.exr").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{:?}", text(&o));
    assert!(text(&o).1.contains("--variance FILE"), "{:?}", text(&o));
}

/// `auto`'s parameters from the command line: other values give another image, the defaults
/// given explicitly the same one; bad values and flags for another filter are refused by name.
#[test]
fn auto_flags_set_its_parameters_and_are_checked() {
    let dir = temp_dir("auto-flags");
    write_scene(&dir, 32, 24);
    let run = |name: &str, extra: &[&str]| -> (Output, PathBuf) {
        let out = dir.join(format!("{name}.exr"));
        let mut args = vec![
            "--input-dir",
            dir.to_str().unwrap(),
            "--filter",
            "auto",
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        (lumo(&args), out)
    };
    let (o, default) = run("default", &[]);
    assert!(o.status.success(), "{}", text(&o).1);
    let (o, explicit) = run(
        "explicit",
        &[
            "--auto-radii",
            "2,4,8,12,16,24,32",
            "--auto-flat-radii",
            "16,32",
            "--auto-flat-eps",
            "0.01",
            "--auto-error-radius",
            "12",
            "--auto-softness",
            "0.01",
            "--auto-fireflies",
            "16",
            "--auto-firefly-spread",
            "64",
        ],
    );
    assert!(o.status.success(), "{}", text(&o).1);
    let (o, first) = run(
        "first",
        &[
            "--auto-radii",
            "4,8,16,32",
            "--auto-error-radius",
            "4",
            "--auto-softness",
            "0.2",
            "--no-auto-atrous",
            "--auto-flat-radii",
        ],
    );
    assert!(o.status.success(), "{}", text(&o).1);
    let (a, b, c) = (
        read_image(&default).unwrap(),
        read_image(&explicit).unwrap(),
        read_image(&first).unwrap(),
    );
    assert_eq!(a.data, b.data, "the defaults given explicitly");
    assert_ne!(a.data, c.data, "other parameters, another image");
    let (o, _) = run("zero", &["--auto-radii", "0,4"]);
    assert!(!o.status.success());
    assert!(text(&o).1.contains("radii"), "{}", text(&o).1);
    // The flat candidates reach the filter, and a bad ε is refused by name.
    let (o, few) = run("no-flat", &["--auto-flat-radii"]);
    assert!(o.status.success(), "{}", text(&o).1);
    assert_ne!(
        read_image(&few).unwrap().data,
        a.data,
        "--auto-flat-radii did nothing"
    );
    // "" means none too, as --help says; a word is refused with the fix.
    let (o, empty) = run("no-flat-empty", &["--auto-flat-radii", ""]);
    assert!(o.status.success(), "{}", text(&o).1);
    assert_eq!(
        read_image(&empty).unwrap().data,
        read_image(&few).unwrap().data
    );
    let (o, _) = run("flat-word", &["--auto-flat-radii", "16,big"]);
    assert!(!o.status.success());
    assert!(
        text(&o).1.contains("'big' is not a radius"),
        "{}",
        text(&o).1
    );
    let (o, _) = run("flat-eps", &["--auto-flat-eps=0"]);
    assert!(!o.status.success());
    assert!(text(&o).1.contains("flat ε"), "{}", text(&o).1);
    // The firefly threshold reaches the filter (this frame's ±50 % noise has no pixel above
    // the default 16 × its neighbourhood, but many above 1.2 ×); a spread radius of 0 is
    // refused by name.
    let (o, low) = run("low-threshold", &["--auto-fireflies", "1.2"]);
    assert!(o.status.success(), "{}", text(&o).1);
    assert_ne!(
        read_image(&low).unwrap().data,
        a.data,
        "--auto-fireflies did nothing"
    );
    let (o, _) = run("no-spread", &["--auto-firefly-spread", "0"]);
    assert!(!o.status.success());
    assert!(text(&o).1.contains("firefly"), "{}", text(&o).1);
    let o = lumo(&[
        "--input-dir",
        dir.to_str().unwrap(),
        "--filter",
        "guided",
        "--no-auto-atrous",
        "-o",
        dir.join("g.exr").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(text(&o).1.contains("--filter auto only"), "{}", text(&o).1);
}

/// `--light-mask` naming the output, or `-o` naming an input plane, overwrote a file without a
/// word (the denoised image with a black mask, the normal plane with the result). Both are
/// refused before any filtering, naming the option and the plane.
#[test]
fn outputs_that_would_overwrite_an_input_or_each_other_are_refused() {
    let dir = temp_dir("clobber");
    write_scene(&dir, 16, 12);
    let d = |n: &str| dir.join(n).to_str().unwrap().to_owned();
    let input = ["--input-dir".to_owned(), d("")];
    let cases: [(Vec<String>, &str); 3] = [
        (vec!["-o".into(), d("normal.exr")], "the normal plane"),
        (
            vec![
                "-o".into(),
                d("out.exr"),
                "--light-mask".into(),
                d("out.exr"),
            ],
            "the same file as -o",
        ),
        (
            vec![
                "-o".into(),
                d("out.exr"),
                "--light-mask".into(),
                d("color.exr"),
            ],
            "the color plane",
        ),
    ];
    let before = std::fs::read(dir.join("normal.exr")).unwrap();
    for (args, why) in cases {
        let all: Vec<&str> = input.iter().chain(&args).map(String::as_str).collect();
        let o = lumo(&all);
        let (_, stderr) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(why), "{args:?}: {stderr}");
    }
    assert_eq!(std::fs::read(dir.join("normal.exr")).unwrap(), before);
    assert!(!dir.join("out.exr").exists());
}

/// A variance plane of +∞, NaN or −1 used to read as 0 (noise-free): filtering switched off
/// without a word. Such a plane is refused, naming the file and the first bad pixel.
#[test]
fn a_variance_plane_with_impossible_values_is_refused() {
    for bad in [f32::INFINITY, f32::NAN, -1.0] {
        let dir = temp_dir("variance");
        write_scene(&dir, 16, 12);
        let mut v = Image::new(16, 12, 1, 0.01);
        v.pixel_mut(3, 2)[0] = bad;
        write_image(&dir.join("variance.pfm"), &v).unwrap();
        let o = lumo(&[
            "--input-dir",
            dir.to_str().unwrap(),
            "--variance",
            dir.join("variance.pfm").to_str().unwrap(),
            "-o",
            dir.join("out.exr").to_str().unwrap(),
        ]);
        let (_, stderr) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{bad}: {stderr}");
        assert!(
            stderr.contains("variance.pfm") && stderr.contains("(3, 2)"),
            "{bad}: {stderr}"
        );
    }
}

/// An all-black albedo plane (or an emission plane lit everywhere) passes every pixel through
/// unfiltered, and an encoded or NaN normal plane steers the filters by nonsense; each now
/// comes with a warning saying so and how to avoid it.
#[test]
fn planes_that_pass_most_pixels_through_are_warned_about() {
    let dir = temp_dir("passthrough");
    write_scene(&dir, 16, 12);
    write_image(&dir.join("black.exr"), &Image::new(16, 12, 3, 0.0)).unwrap();
    write_image(&dir.join("lit.exr"), &Image::new(16, 12, 3, f32::NAN)).unwrap();
    // An 8-bit normal map's encoding (0.5, 0.5, 1) has length 1.22, a NaN plane none.
    write_image(&dir.join("encoded.exr"), &Image::new(16, 12, 3, 0.75)).unwrap();
    for (option, file, says) in [
        ("--albedo", "black.exr", "--no-demodulate"),
        ("--emission", "lit.exr", "count as emitting"),
        ("--normal", "encoded.exr", "not unit vectors"),
        ("--normal", "lit.exr", "not unit vectors"),
    ] {
        let o = lumo(&[
            "--input-dir",
            dir.to_str().unwrap(),
            option,
            dir.join(file).to_str().unwrap(),
            "-o",
            dir.join("out.exr").to_str().unwrap(),
        ]);
        let (_, stderr) = text(&o);
        assert!(o.status.success(), "{option}: {stderr}");
        assert!(
            stderr.contains("warning") && stderr.contains(file) && stderr.contains(says),
            "{option}: {stderr}"
        );
    }
    // The scene's own albedo (0.5 everywhere) gets no such warning.
    let o = lumo(&[
        "--input-dir",
        dir.to_str().unwrap(),
        "-o",
        dir.join("out.exr").to_str().unwrap(),
    ]);
    let (_, stderr) = text(&o);
    assert!(!stderr.contains("passes them through"), "{stderr}");
    assert!(!stderr.contains("not unit vectors"), "{stderr}");
}

/// A colour plane with nothing to filter (all NaN, all infinite, or negative without any
/// light) wrote a black image with exit 0; each is refused naming the file, and no output is
/// written. One NaN pixel among finite ones is still only a warning (above).
#[test]
fn a_colour_plane_with_nothing_to_filter_is_refused() {
    let dir = temp_dir("nothing");
    for (name, value, says) in [
        ("nan.pfm", f32::NAN, "NaN or infinite"),
        ("inf.pfm", f32::INFINITY, "NaN or infinite"),
        ("neg.pfm", -0.5, "zero or negative"),
    ] {
        let input = dir.join(name);
        write_image(&input, &Image::new(8, 6, 3, value)).unwrap();
        let out = dir.join(format!("out-{name}"));
        let o = lumo(&[
            "--color",
            input.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        let (_, stderr) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{name}: {stderr}");
        assert!(stderr.contains(name) && stderr.contains(says), "{stderr}");
        assert!(!out.exists(), "{name}");
    }
    // An all-black image is a valid (if dull) input.
    let black = dir.join("black.pfm");
    write_image(&black, &Image::new(8, 6, 3, 0.0)).unwrap();
    let out = dir.join("out-black.pfm");
    let o = lumo(&[
        "--color",
        black.to_str().unwrap(),
        "--filter",
        "atrous",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
}

/// A `dirac` plane (the Dirac lights' exact light) skips every filter: with a colour that is
/// that plane plus a flat noisy rest, one-pixel shadow lines in the plane come out exactly as
/// they went in on top of the filtered rest, while without the plane the filter blurs them.
/// A dirac plane of another size is refused naming both files.
#[test]
fn a_dirac_plane_skips_the_filter() {
    let dir = temp_dir("dirac");
    let (w, h) = (32, 24);
    write_scene(&dir, w, h);
    let noisy = read_image(&dir.join("color.exr")).unwrap();
    let mut dirac = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            // Sunlight everywhere but in one-pixel shadow lines every fourth column.
            let lit = if x % 4 == 0 { 0.0 } else { 2.0 };
            dirac.pixel_mut(x, y).fill(lit);
        }
    }
    let mut color = noisy.clone();
    for (c, d) in color.data.iter_mut().zip(&dirac.data) {
        *c += d;
    }
    write_image(&dir.join("color.exr"), &color).unwrap();
    for filter in ["auto", "atrous", "guided"] {
        let run = |with: bool| {
            let out = dir.join(format!("out-{filter}-{with}.exr"));
            let mut args = vec!["--input-dir", dir.to_str().unwrap(), "--filter", filter];
            let plane = dir.join("sun.exr");
            write_image(&plane, &dirac).unwrap();
            if with {
                args.extend(["--dirac", plane.to_str().unwrap()]);
            }
            args.extend(["-o", out.to_str().unwrap()]);
            let o = lumo(&args);
            assert!(o.status.success(), "{filter}: {}", text(&o).1);
            read_image(&out).unwrap()
        };
        // The shadow lines' depth: mean of the lit columns minus mean of the shadow columns.
        let contrast = |img: &Image| {
            let (mut lit, mut dark, mut nl, mut nd) = (0.0f64, 0.0f64, 0, 0);
            for y in 0..h {
                for x in 0..w {
                    let v = img.pixel(x, y)[1] as f64;
                    if x % 4 == 0 {
                        dark += v;
                        nd += 1;
                    } else {
                        lit += v;
                        nl += 1;
                    }
                }
            }
            lit / nl as f64 - dark / nd as f64
        };
        let (with, without) = (contrast(&run(true)), contrast(&run(false)));
        assert!(
            (with - 2.0).abs() < 0.1,
            "{filter}: shadow contrast {with} with the plane (2 in the plane)"
        );
        assert!(without < 1.5, "{filter}: {without} without the plane");
    }
    let small = dir.join("small.exr");
    write_image(&small, &Image::new(16, 24, 3, 0.0)).unwrap();
    let o = lumo(&[
        "--input-dir",
        dir.to_str().unwrap(),
        "--dirac",
        small.to_str().unwrap(),
        "-o",
        dir.join("x.exr").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = text(&o).1;
    assert!(
        err.contains("small.exr") && err.contains("color.exr"),
        "{err}"
    );
}
