//! End-to-end tests of `lumo compare` on small temporary images.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use lumo_image::metrics::{flip, tone_map, FlipSettings};
use lumo_image::{read_image, write_image, Image};

fn temp_dir(name: &str) -> PathBuf {
    super::common::temp_dir("compare", name)
}

fn lumo(args: &[&Path]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lumo"))
        .arg("compare")
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

fn write(dir: &Path, name: &str, img: &Image) -> PathBuf {
    let p = dir.join(name);
    write_image(&p, img).unwrap();
    p
}

/// A 24×20 RGB image with structure: a gradient plus a bright square.
fn scene(w: usize, h: usize, gain: f32) -> Image {
    let mut img = Image::new(w, h, 3, 0.0);
    for y in 0..h {
        for x in 0..w {
            let base = (x + 2 * y) as f32 / (w + 2 * h) as f32;
            let square = if (6..12).contains(&x) && (5..11).contains(&y) {
                2.0
            } else {
                0.0
            };
            let p = img.pixel_mut(x, y);
            p[0] = gain * (base + square);
            p[1] = gain * 0.5 * base;
            p[2] = gain * (1.0 - base) * 0.3;
        }
    }
    img
}

fn json(o: &Output) -> serde_json::Value {
    let (out, err) = text(o);
    assert!(o.status.success(), "stderr: {err}");
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("not JSON ({e}): {out}"))
}

#[test]
fn table_states_conventions_and_identical_images_score_perfectly() {
    let dir = temp_dir("identical");
    let r = write(&dir, "ref.exr", &scene(24, 20, 1.0));
    let o = lumo(&[&r, &r]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    for needle in [
        "eps = 0.01",
        "sRGB OETF of clamp",
        "exposure 0 stops",
        "11x11",
        "ppd",
    ] {
        assert!(out.contains(needle), "missing {needle:?} in\n{out}");
    }
    let row = out
        .lines()
        .find(|l| l.starts_with(&*r.display().to_string()))
        .unwrap();
    let cols: Vec<&str> = row.split_whitespace().collect();
    // image, MSE, relMSE, SMAPE, PSNR, SSIM, FLIP, non-finite
    assert_eq!(cols.len(), 8, "{row}");
    assert_eq!(cols[1].parse::<f64>().unwrap(), 0.0);
    assert_eq!(cols[4], "inf");
    assert_eq!(cols[5], "1.00000");
    assert_eq!(cols[6], "0.00000");
    assert_eq!(cols[7], "0");
    let v = json(&lumo(&[&r, &r, Path::new("--json")]));
    assert!(
        v["images"][0]["psnr_db"].is_null(),
        "infinite PSNR is null: {v}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn json_numbers_match_hand_computed_values() {
    let dir = temp_dir("json");
    let r = write(&dir, "ref.exr", &Image::new(16, 12, 3, 0.25));
    let t = write(&dir, "test.exr", &Image::new(16, 12, 3, 0.5));
    let s = write(&dir, "scene.exr", &scene(16, 12, 1.0));
    let v = json(&lumo(&[
        &r,
        &t,
        &s,
        Path::new("--json"),
        Path::new("--exposure=-1"),
    ]));
    assert_eq!(v["settings"]["relmse_epsilon"], 0.01);
    assert_eq!(v["settings"]["exposure_stops"], -1.0);
    assert_eq!(v["reference"]["width"], 16);
    let m = &v["images"][0];
    let num = |k: &str| m[k].as_f64().unwrap_or_else(|| panic!("{k}: {m}"));
    assert!((num("mse") - 0.0625).abs() < 1e-9);
    assert!((num("relmse") - 0.0625 / 0.0725).abs() < 1e-9);
    assert!((num("smape") - 0.25 / 0.76).abs() < 1e-9);
    // One stop down: 0.125 and 0.25 before the sRGB curve.
    let d = (tone_map(0.5, -1.0) - tone_map(0.25, -1.0)) as f64;
    assert!((num("psnr_db") + 20.0 * d.log10()).abs() < 1e-6);
    assert!((num("ssim") - 1.0).abs() > 1e-3 && num("ssim") < 1.0);
    assert_eq!(m["nonfinite_pixels"], 0);
    // The CLI's FLIP is the library's at the same exposure.
    let lib = flip(
        &read_image(&r).unwrap(),
        &read_image(&s).unwrap(),
        &FlipSettings {
            exposure: -1.0,
            ..FlipSettings::default()
        },
    )
    .unwrap();
    assert!((v["images"][1]["flip"].as_f64().unwrap() - lib).abs() < 1e-12);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn nonfinite_pixels_are_counted_not_fatal() {
    let dir = temp_dir("nan");
    let reference = scene(24, 20, 1.0);
    let mut bad = scene(24, 20, 1.1);
    bad.pixel_mut(3, 4)[1] = f32::NAN;
    bad.pixel_mut(20, 19)[0] = f32::INFINITY;
    bad.pixel_mut(7, 7).fill(f32::NAN);
    let r = write(&dir, "ref.exr", &reference);
    let b = write(&dir, "bad.exr", &bad);
    let v = json(&lumo(&[&r, &b, Path::new("--json")]));
    let m = &v["images"][0];
    assert_eq!(m["nonfinite_pixels"], 3);
    for k in ["mse", "relmse", "smape", "psnr_db", "ssim", "flip"] {
        assert!(m[k].as_f64().is_some_and(f64::is_finite), "{k}: {m}");
    }
    let o = lumo(&[&r, &b]);
    let (out, _) = text(&o);
    assert!(o.status.success());
    assert!(out.contains("left out of every metric"), "{out}");

    // Nothing finite left: a clear error, not a crash or a NaN table.
    let all_nan = write(&dir, "nan.exr", &Image::new(24, 20, 3, f32::NAN));
    let o = lumo(&[&r, &all_nan]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("nan.exr") && err.contains("480 of 480"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn diff_images_one_or_indexed() {
    let dir = temp_dir("diff");
    let r = write(&dir, "ref.exr", &scene(24, 20, 1.0));
    let a = write(&dir, "a.exr", &scene(24, 20, 1.2));
    let b = write(&dir, "b.pfm", &scene(24, 20, 0.5));
    let out = dir.join("err.png");
    let o = lumo(&[&r, &a, Path::new("--diff"), &out]);
    assert!(o.status.success(), "{}", text(&o).1);
    let d = read_image(&out).unwrap();
    assert_eq!((d.width, d.height, d.channels), (24, 20, 3));
    // Error differs across the image, so the false colours do too.
    assert!(d.data.chunks(3).any(|p| p != d.pixel(0, 0)));

    let o = lumo(&[
        &r,
        &a,
        &b,
        Path::new("--diff"),
        &out,
        Path::new("--diff-metric"),
        Path::new("relmse"),
    ]);
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{err}");
    for name in ["err-1.png", "err-2.png"] {
        assert!(dir.join(name).exists(), "{name} missing; stdout:\n{stdout}");
        assert!(stdout.contains(name));
    }
    assert!(stdout.contains("log scale"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn mismatched_inputs_fail_with_one_line_and_code_2() {
    let dir = temp_dir("errors");
    let r = write(&dir, "ref.exr", &Image::new(5, 3, 3, 0.5));
    let small = write(&dir, "small.exr", &Image::new(4, 3, 3, 0.5));
    let grey = write(&dir, "grey.exr", &Image::new(5, 3, 1, 0.5));
    let ok = write(&dir, "ok.exr", &Image::new(5, 3, 3, 0.4));

    // A bad image after a good one still fails before any table is printed.
    let o = lumo(&[&r, &ok, &small]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(2));
    assert!(out.is_empty(), "{out}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("ref.exr is 5x3") && err.contains("small.exr is 4x3"),
        "{err}"
    );

    let o = lumo(&[&r, &grey]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(2));
    assert!(err.contains("channel") && err.contains("grey.exr"), "{err}");

    let missing = dir.join("missing.exr");
    let o = lumo(&[&r, &missing]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).1.contains("missing.exr"));

    let o = lumo(&[&r, Path::new("x.tiff")]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).1.contains("unsupported"));

    // clap usage errors (no image at all) also exit 2.
    let o = lumo(&[&r]);
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&dir).ok();
}

/// A `--diff` path that names an input is refused before anything is written: it once
/// replaced the reference with the false-colour diff (exit 0, the data gone).
#[test]
fn a_diff_over_an_input_is_refused_and_the_input_kept() {
    let dir = temp_dir("diff-over-input");
    let reference = write(&dir, "ref.exr", &scene(24, 20, 1.0));
    let test = write(&dir, "img.exr", &scene(24, 20, 1.1));
    let before = std::fs::read(&reference).unwrap();
    // The reference itself, the test image, and the reference through another spelling.
    let other = dir.join(".").join("ref.exr");
    for diff in [&reference, &test, &other] {
        let o = lumo(&[&reference, &test, Path::new("--diff"), diff]);
        let (_, stderr) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{}: {stderr}", diff.display());
        assert!(stderr.contains("would overwrite the input"), "{stderr}");
    }
    assert_eq!(std::fs::read(&reference).unwrap(), before);
    // A fresh name still works.
    let ok = dir.join("diff.png");
    let o = lumo(&[&reference, &test, Path::new("--diff"), &ok]);
    assert!(o.status.success(), "{}", text(&o).1);
    assert!(ok.exists());
}

/// `--ppd 1e-30` passed the "positive" check and FLIP came out NaN with exit 0; below one
/// pixel per degree is refused, and 1 gives a finite FLIP.
#[test]
fn a_ppd_below_one_is_refused() {
    let dir = temp_dir("tiny-ppd");
    let r = write(&dir, "ref.exr", &scene(24, 20, 1.0));
    let t = write(&dir, "test.exr", &scene(24, 20, 0.5));
    for ppd in ["1e-30", "0.5"] {
        let o = lumo(&[&r, &t, Path::new("--ppd"), Path::new(ppd)]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{ppd}: {err}");
        assert!(err.contains("--ppd") && err.contains("at least 1"), "{err}");
    }
    let v = json(&lumo(&[
        &r,
        &t,
        Path::new("--ppd"),
        Path::new("1"),
        Path::new("--json"),
    ]));
    assert!(v["images"][0]["flip"].as_f64().unwrap().is_finite(), "{v}");
}

/// `--exposure 64` clipped two different images to white everywhere and reported PSNR inf,
/// SSIM 1 and FLIP 0 (a perfect match). Images whose linear values differ but whose
/// tone-mapped values do not get no tone-mapped scores ("clipped" / null) and a warning with
/// an exposure that shows the difference; identical images still score perfectly.
#[test]
fn images_that_differ_only_where_they_clip_are_not_called_identical() {
    let dir = temp_dir("saturation");
    let reference = scene(24, 20, 1.0);
    let r = write(&dir, "ref.exr", &reference);
    let t = write(&dir, "test.exr", &scene(24, 20, 0.5));
    // Differs only in the square's red channel, which is above 1 (white) at exposure 0.
    let mut bright = reference.clone();
    for y in 5..11 {
        for x in 6..12 {
            bright.pixel_mut(x, y)[0] *= 4.0;
        }
    }
    let b = write(&dir, "bright.exr", &bright);
    for (test, exposure) in [(&t, "64"), (&b, "0")] {
        let o = lumo(&[&r, test, Path::new("--exposure"), Path::new(exposure)]);
        let (out, err) = text(&o);
        assert!(o.status.success(), "{err}");
        let row = out
            .lines()
            .find(|l| l.starts_with(&*test.display().to_string()))
            .unwrap_or_else(|| panic!("no row in\n{out}"));
        assert!(
            row.matches("clipped").count() == 3 && !row.contains("inf"),
            "--exposure {exposure}: {row}"
        );
        assert!(
            err.contains("warning") && err.contains("identical after tone mapping"),
            "{err}"
        );
        let hint = err.split("e.g. --exposure ").nth(1).expect("a hint");
        let e: f32 = hint.split_whitespace().next().unwrap().parse().unwrap();
        // The brightest values are 2.9 (the square) and 8 (its red channel ×4).
        assert!(
            e <= -2.0,
            "the hint puts the brightest value at white: {err}"
        );
        let v = json(&lumo(&[
            &r,
            test,
            Path::new("--exposure"),
            Path::new(exposure),
            Path::new("--json"),
        ]));
        let m = &v["images"][0];
        assert!(m["mse"].as_f64().unwrap() > 0.0, "{v}");
        for k in ["psnr_db", "ssim", "flip"] {
            assert!(m[k].is_null(), "{k} at --exposure {exposure}: {v}");
        }
        assert_eq!(m["clipped_alike"], true, "{v}");
        // At the hinted exposure the difference is seen.
        let v = json(&lumo(&[
            &r,
            test,
            Path::new(&format!("--exposure={e}")),
            Path::new("--json"),
        ]));
        let m = &v["images"][0];
        assert!(m["psnr_db"].as_f64().unwrap().is_finite(), "{v}");
        assert!(m["flip"].as_f64().unwrap() > 0.0, "{v}");
    }
    // The same image at exposure 64 is still a perfect match, not "clipped".
    let v = json(&lumo(&[
        &r,
        &r,
        Path::new("--exposure"),
        Path::new("64"),
        Path::new("--json"),
    ]));
    assert_eq!(v["images"][0]["clipped_alike"], false, "{v}");
    assert_eq!(v["images"][0]["ssim"].as_f64(), Some(1.0), "{v}");
}
