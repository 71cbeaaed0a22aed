//! Options without sensible bounds, unwritable outputs and ignored options (issue 25): each
//! is refused before any work with a message naming the option as typed, or warned about in
//! one line; nothing here allocates much or renders more than a few pixels.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn temp_dir(name: &str) -> PathBuf {
    super::common::temp_dir("hostile", name)
}

/// Runs `lumo args…` in `dir`, with the memory budget `LUMO_MEMORY_LIMIT=memory` if given.
fn lumo_in(dir: &Path, args: &[&str], memory: Option<&str>) -> (Output, Duration) {
    let mut c = Command::new(env!("CARGO_BIN_EXE_lumo"));
    c.args(args)
        .current_dir(dir)
        .env_remove("LUMO_MEMORY_LIMIT");
    if let Some(m) = memory {
        c.env("LUMO_MEMORY_LIMIT", m);
    }
    let start = Instant::now();
    let out = c.output().expect("run lumo");
    (out, start.elapsed())
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A tiny, fast render: 8x8 pixels, 1 spp.
const TINY: [&str; 5] = ["--size", "8x8", "--spp", "1", "-o"];

#[test]
fn a_size_that_cannot_fit_is_refused_before_allocating() {
    let dir = temp_dir("size");
    // 16384x16384 needs about 80 GiB; with a 1 GiB budget it must be refused at once, on any
    // machine (the budget stands in for MemAvailable, which a large machine might exceed).
    let (o, took) = lumo_in(
        &dir,
        &["render", "--size", "16384x16384", "-o", "big.png"],
        Some("1G"),
    );
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("--size") && e.contains("GiB of memory"), "{e}");
    assert!(took < Duration::from_secs(10), "took {took:?}");
    assert!(!dir.join("big.png").exists());
    // The same render fits a budget above its estimate (and a plain number is bytes).
    let (o, _) = lumo_in(
        &dir,
        &["render", "--size", "8x8", "--spp", "1", "-o", "small.png"],
        Some("100000"),
    );
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn unbounded_options_are_refused_naming_the_option() {
    let dir = temp_dir("bounds");
    let cases: &[(&[&str], &str)] = &[
        (&["render", "--spp", "4294967295"], "--spp 4294967295"),
        (
            &["render", "--pipeline", "jbu", "--paths", "4000000000"],
            "--paths 4000000000",
        ),
        (
            &["render", "--pipeline", "guided", "--radius", "100000000"],
            "--radius 100000000",
        ),
        (
            &["render", "--pipeline", "jbu", "--block", "0"],
            "--block 0",
        ),
        // The range --block 0 states is the one --block 1000 is checked against.
        (
            &["render", "--pipeline", "jbu", "--block", "1000"],
            "--block 1000: use 1 to 64",
        ),
        (&["render", "--subsample", "3"], "--subsample 3"),
        // Beyond a scene file's own limit a closed mirror box traces for hours.
        (
            &["render", "--max-depth", "4294967295"],
            "--max-depth 4294967295",
        ),
        (&["render", "--rr-depth", "0"], "--rr-depth 0"),
        (&["render", "--rr-depth", "65537"], "--rr-depth 65537"),
        (&["render", "--time", "nan"], "finite number of seconds"),
        // The benchmarks' sample counts and times: 4294967295 samples once asked for a
        // terabyte and aborted; 0 printed NaN ratios.
        (
            &[
                "bench",
                "inputs",
                "cornell",
                "--size",
                "16x16",
                "--spp",
                "4294967295",
                "--out",
                "d",
            ],
            "invalid sample count",
        ),
        (
            &[
                "bench",
                "reference",
                "cornell",
                "--reference-spp",
                "4294967295",
                "--cache",
                "c",
            ],
            "invalid sample count",
        ),
        (
            &["bench", "render", "cornell", "--spp", "0"],
            "invalid sample count",
        ),
        (
            &["bench", "render", "cornell", "--max-depth", "0"],
            "--max-depth",
        ),
        (
            &["bench", "render", "cornell", "--markdown", "nodir/x.md"],
            "directory nodir does not exist",
        ),
        (
            &["bench", "integrators", "--reference-seconds", "NaN"],
            "invalid time",
        ),
        (
            &["render", "--seed", "18446744073709551615"],
            "expected a whole number in 0..=4294967295",
        ),
        (&["render", "--threads=-1"], "(0 = all cores)"),
        // An integrator without a pipeline is not told to add one.
        (
            &["render", "--integrator", "bdpt", "--subsample", "2"],
            "--integrator bdpt renders without a pipeline: drop --subsample",
        ),
        (
            &["render", "--integrator", "light", "--photon-radius", "0.5"],
            "--photon-radius apply to --integrator ppm",
        ),
        (&["render", "--guide-dims", "2"], "--guide-dims 2"),
        (
            &["compare", "--ppd", "1e30", "a.png", "b.png"],
            "--ppd 1e30",
        ),
        // Both tables skipped wrote an empty speed.md and reported success.
        (
            &["bench", "speed", "--no-render", "--no-filters"],
            "cannot be used with",
        ),
        // 2^1e9 saturated every pixel: PSNR inf and SSIM 1 for any two images.
        (
            &["compare", "--exposure", "1e9", "a.png", "b.png"],
            "--exposure 1000000000: use a finite number of stops from -64 to 64",
        ),
        // A negative value gets the range message, not clap's advice to write `-- -5`.
        (
            &["compare", "--ppd", "-5", "a.png", "b.png"],
            "--ppd must be a positive number",
        ),
        (
            &[
                "denoise",
                "--subsample",
                "3",
                "--color",
                "c.exr",
                "-o",
                "d.png",
            ],
            "--subsample 3",
        ),
    ];
    for (args, expect) in cases {
        let mut all = args.to_vec();
        if args[0] == "render" {
            all.extend_from_slice(&["-o", "x.png"]);
        }
        let (o, took) = lumo_in(&dir, &all, None);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        assert!(e.contains(expect), "{args:?}: {e}");
        assert!(!e.contains("sparse"), "internal name in {e}");
        assert!(took < Duration::from_secs(10), "{args:?} took {took:?}");
        assert!(!dir.join("x.png").exists());
    }
}

#[test]
fn thread_counts_are_capped_and_zero_is_warned_about() {
    let dir = temp_dir("threads");
    let (o, _) = lumo_in(
        &dir,
        &[&["render", "--threads", "100000"][..], &TINY, &["a.png"]].concat(),
        None,
    );
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    let warnings: Vec<&str> = e.lines().filter(|l| l.starts_with("warning:")).collect();
    assert_eq!(warnings.len(), 1, "{e}");
    assert!(warnings[0].contains("--threads 100000"), "{e}");
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    assert!(e.contains(&format!(", {} threads", 4 * cores)), "{e}");

    let (o, _) = lumo_in(
        &dir,
        &[&["render", "--threads", "0"][..], &TINY, &["b.png"]].concat(),
        None,
    );
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(e.contains("warning: --threads 0"), "{e}");
}

#[test]
fn ignored_options_are_warned_about_one_line_each() {
    let dir = temp_dir("ignored");
    let args = [
        &["render", "cornell", "--camera", "1", "--time", "2"][..],
        &TINY,
        &["a.png"],
    ]
    .concat();
    let (o, _) = lumo_in(&dir, &args, None);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    let warnings: Vec<&str> = e.lines().filter(|l| l.starts_with("warning:")).collect();
    assert_eq!(warnings.len(), 2, "{e}");
    assert!(
        warnings[0].contains("--camera") && warnings[1].contains("--time"),
        "{e}"
    );

    let cornell = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell.xml");
    let cornell = cornell.to_str().unwrap();
    let args = [
        &["render", cornell, "-D", "spp=1", "-D", "sppp=2"][..],
        &TINY[..2],
        &["-o", "b.png"],
    ]
    .concat();
    let (o, _) = lumo_in(&dir, &args, None);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    let lines: Vec<&str> = e.lines().filter(|l| l.contains("-D ")).collect();
    assert_eq!(lines.len(), 1, "only the undeclared name: {e}");
    assert!(
        lines[0].contains("-D sppp=") && lines[0].contains("$sppp"),
        "{e}"
    );

    // A pipeline's knob on a run of another pipeline: one line.
    let (o, _) = lumo_in(
        &dir,
        &[
            "render",
            "--pipeline",
            "none",
            "--radius",
            "3",
            "--size",
            "8x8",
            "--spp",
            "1",
            "-o",
            "r.png",
        ],
        None,
    );
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    let warnings: Vec<&str> = e.lines().filter(|l| l.starts_with("warning:")).collect();
    assert_eq!(warnings.len(), 1, "{e}");
    assert!(
        warnings[0].contains("--radius applies to --pipeline guided"),
        "{e}"
    );

    // An AOV directory named like an image: made, with a warning that it is a directory.
    let (o, _) = lumo_in(
        &dir,
        &[
            "render",
            "--size",
            "8x8",
            "--spp",
            "1",
            "--pipeline",
            "none",
            "--aovs",
            "planes.exr",
            "-o",
            "p.png",
        ],
        None,
    );
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(
        e.contains("warning: --aovs planes.exr names a directory"),
        "{e}"
    );
    assert!(dir.join("planes.exr").join("color.exr").is_file());

    // lumo denoise: an option of another filter is warned about, not silently dropped.
    let (o, _) = lumo_in(
        &dir,
        &[
            "render",
            "--size",
            "8x8",
            "--spp",
            "1",
            "--pipeline",
            "none",
            "--aovs",
            "aovs",
            "-o",
            "n.exr",
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    for (filter, flag, count) in [
        ("guided", "--iterations", 1),
        ("auto", "--radius", 1),
        ("atrous", "--iterations", 0),
    ] {
        let value = if flag == "--radius" { "4" } else { "3" };
        let (o, _) = lumo_in(
            &dir,
            &[
                "denoise",
                "--input-dir",
                "aovs",
                "--filter",
                filter,
                flag,
                value,
                "-o",
                "d.exr",
            ],
            None,
        );
        let e = stderr(&o);
        assert!(o.status.success(), "{e}");
        let warnings = e
            .lines()
            .filter(|l| l.starts_with("warning:") && l.contains(flag))
            .count();
        assert_eq!(warnings, count, "{filter} {flag}: {e}");
    }
}

/// `--subsample` is the À-Trous pipeline's: with the default pipeline (`auto`) it would do
/// nothing, so it is refused with the fix, and works with `--pipeline atrous`.
#[test]
fn subsample_needs_the_atrous_pipeline() {
    let dir = temp_dir("subsample");
    let args = [
        &["render", "cornell", "--subsample", "2"][..],
        &TINY,
        &["s.png"],
    ]
    .concat();
    let (o, _) = lumo_in(&dir, &args, None);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("--subsample 2") && e.contains("add --pipeline atrous"),
        "{e}"
    );
    let (o, _) = lumo_in(&dir, &[&args[..], &["--pipeline", "atrous"]].concat(), None);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// An output path that is a directory is refused before any work (it used to be found only
/// when the finished image was written).
#[test]
fn an_output_that_is_a_directory_is_refused_before_the_render() {
    let dir = temp_dir("outdir");
    std::fs::create_dir_all(dir.join("out.png")).unwrap();
    let (o, _) = lumo_in(
        &dir,
        &["render", "--size", "8x8", "--spp", "1", "-o", "out.png"],
        None,
    );
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("out.png") && e.contains("is a directory"), "{e}");
    assert!(
        !e.contains("triangles"),
        "refused only after loading and rendering: {e}"
    );
}

#[test]
fn an_unwritable_aov_directory_is_found_before_the_render() {
    let dir = temp_dir("aovs");
    std::fs::write(dir.join("file"), b"").unwrap();
    // A directory under a regular file can never be created; a large render must fail at once.
    let (o, took) = lumo_in(
        &dir,
        &[
            "render",
            "--size",
            "2048x2048",
            "--spp",
            "64",
            "--aovs",
            "file/aovs",
            "-o",
            "a.png",
        ],
        None,
    );
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("--aovs file/aovs"), "{e}");
    assert!(
        took < Duration::from_secs(10),
        "took {took:?}: rendered first?"
    );
    assert!(!dir.join("a.png").exists());
}

/// `-o av/color.exr --aovs av` used to write the image, then overwrite it with the noisy colour
/// plane, and report success. An output that a frame or pipeline plane would overwrite is
/// refused before the render; another name in the same directory is fine.
#[test]
fn an_output_that_an_aov_plane_would_overwrite_is_refused() {
    let dir = temp_dir("aov-clash");
    for (out, plane) in [
        ("av/color.exr", "color.exr"),
        (
            "./av/illumination_filtered.EXR",
            "illumination_filtered.exr",
        ),
    ] {
        let (o, _) = lumo_in(
            &dir,
            &[
                "render", "--aovs", "av", "--size", "8x8", "--spp", "1", "-o", out,
            ],
            None,
        );
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{out}: {e}");
        assert!(
            e.contains(out) && e.contains(plane) && e.contains("would overwrite"),
            "{out}: {e}"
        );
        assert!(!e.contains("triangles"), "refused only after loading: {e}");
    }
    let (o, _) = lumo_in(
        &dir,
        &[
            "render",
            "--aovs",
            "av",
            "--size",
            "8x8",
            "--spp",
            "1",
            "-o",
            "av/beauty.exr",
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("av/beauty.exr").is_file() && dir.join("av/color.exr").is_file());
}

#[test]
fn bench_repeats_zero_is_refused() {
    let dir = temp_dir("repeats");
    let args = [
        "bench",
        "render",
        "cornell",
        "--size",
        "8x8",
        "--spp",
        "1",
        "--repeats",
        "0",
    ];
    let (o, _) = lumo_in(&dir, &args, None);
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(e.contains("--repeats must be at least 1"), "{e}");
}

#[test]
fn bench_quality_leaves_the_committed_results_alone_unless_asked() {
    let dir = temp_dir("quality");
    let args = [
        "bench",
        "quality",
        "--scenes",
        "cornell",
        "--size",
        "16x16",
        "--spp",
        "1",
        "--pipelines",
        "none",
        "--reference-spp",
        "4",
    ];
    let (o, _) = lumo_in(&dir, &args, None);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("target/lumo-bench/quality.md").is_file());
    assert!(
        !dir.join("docs").exists(),
        "wrote under docs/ without --publish"
    );
    // --publish and --out-dir contradict each other.
    let (o, _) = lumo_in(
        &dir,
        &[&args[..], &["--publish", "--out-dir", "x"]].concat(),
        None,
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn copies_of_one_triangle_build_their_bvh_quickly() {
    // 100,000 copies of one triangle (a 0.8 MB OBJ) took over 2 minutes in the BVH build
    // when PLOC saw them as they are; clustered, it takes milliseconds. The cap is generous
    // for a loaded machine and still far below the quadratic time.
    let dir = temp_dir("copies");
    let mut obj = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    obj.push_str(&"f 1 2 3\n".repeat(100_000));
    std::fs::write(dir.join("same.obj"), obj).unwrap();
    let args = [&["render", "same.obj"][..], &TINY, &["same.png"]].concat();
    let (o, took) = lumo_in(&dir, &args, None);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(took < Duration::from_secs(30), "took {took:?}");
}

/// `--integrator light` renders an image; with a filtering pipeline or AOVs (which the light
/// tracer cannot make) it is refused up front, naming the option.
#[test]
fn the_light_integrator_renders_and_refuses_what_it_cannot_do() {
    let dir = temp_dir("light");
    let (o, _) = lumo_in(
        &dir,
        &[
            "render",
            "--integrator",
            "light",
            "--size",
            "16x16",
            "--spp",
            "2",
            "-o",
            "l.exr",
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let img = lumo_image::read_image(&dir.join("l.exr")).expect("an EXR");
    assert!(img.data.iter().all(|v| v.is_finite()) && img.data.iter().any(|&v| v > 0.0));
    let (o, _) = lumo_in(
        &dir,
        &[
            "render",
            "--integrator",
            "light",
            "--pipeline",
            "guided",
            "-o",
            "g.exr",
        ],
        None,
    );
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--pipeline guided"), "{}", stderr(&o));
    let (o, _) = lumo_in(
        &dir,
        &[
            "render",
            "--integrator",
            "light",
            "--aovs",
            "a",
            "-o",
            "a.exr",
        ],
        None,
    );
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--aovs"), "{}", stderr(&o));
    assert!(
        !dir.join("a").exists(),
        "refused before creating the AOV directory"
    );
}

/// A scene with participating media renders with `--integrator light` and `bdpt` (both
/// transport light through media); photon mapping refuses it, naming itself and the
/// integrators that render it.
#[test]
fn media_render_light_traced_and_bdpt_and_ppm_refuses_them() {
    let dir = temp_dir("media-light");
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/mitsuba/scenes/media_fog_box.xml"
    );
    let run = |integrator: &str| {
        let args = [
            "render",
            scene,
            "--integrator",
            integrator,
            "--size",
            "16x16",
            "--spp",
            "2",
            "-o",
            "m.exr",
        ];
        lumo_in(&dir, &args, None).0
    };
    for taker in ["light", "bdpt"] {
        let o = run(taker);
        assert!(o.status.success(), "{taker}: {}", stderr(&o));
        let img = lumo_image::read_image(&dir.join("m.exr")).expect("an EXR");
        assert!(img.data.iter().all(|v| v.is_finite()) && img.data.iter().any(|&v| v > 0.0));
        std::fs::remove_file(dir.join("m.exr")).expect("remove");
    }
    let o = run("ppm");
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("the ppm integrator does not render")
            && err.contains("--integrator path")
            && err.contains("--integrator light")
            && err.contains("--integrator bdpt"),
        "{err}"
    );
}

/// `--integrator ppm` renders and reports its photons; it refuses a filtering pipeline and
/// a zero `--max-photons` up front, and on a scene lit by an environment alone it warns in
/// one line and still renders.
#[test]
fn the_ppm_integrator_renders_warns_and_refuses_what_it_cannot_do() {
    let dir = temp_dir("ppm");
    let args = [
        "render",
        "--integrator",
        "ppm",
        "--size",
        "16x16",
        "--spp",
        "2",
        "-o",
        "p.exr",
    ];
    let (o, _) = lumo_in(&dir, &args, None);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("photon paths/s") && out.contains("photons"),
        "{out}"
    );
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    let img = lumo_image::read_image(&dir.join("p.exr")).expect("an EXR");
    assert!(img.data.iter().all(|v| v.is_finite()) && img.data.iter().any(|&v| v > 0.0));
    let (o, _) = lumo_in(&dir, &[&args[..], &["--pipeline", "atrous"]].concat(), None);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--pipeline atrous"), "{}", stderr(&o));
    let (o, _) = lumo_in(&dir, &[&args[..], &["--max-photons", "0"]].concat(), None);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--max-photons 0"), "{}", stderr(&o));
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/mitsuba/scenes/constant_env.xml"
    );
    let env_args = [&["render", scene][..], &args[1..]].concat();
    let (o, _) = lumo_in(&dir, &env_args, None);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let warnings: Vec<&str> = err
        .lines()
        .filter(|l| l.contains("--integrator ppm"))
        .collect();
    assert_eq!(warnings.len(), 1, "{}", stderr(&o));
    assert!(
        warnings[0].contains("no light emits photons"),
        "{}",
        warnings[0]
    );
}
