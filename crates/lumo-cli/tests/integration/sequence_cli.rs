//! `lumo render --frames`: numbered files, a posed-and-updated frame equal to a still rendered
//! at the same time, camera orbits, and bad sequence options refused naming the flag.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn temp_dir(name: &str) -> PathBuf {
    super::common::temp_dir("sequence", name)
}

fn animated() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes/animated.gltf")
        .display()
        .to_string()
}

fn lumo(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lumo"))
        .args(args)
        .current_dir(dir)
        .env_remove("LUMO_MEMORY_LIMIT")
        .output()
        .expect("run lumo")
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

const TINY: [&str; 6] = ["--size", "16x12", "--spp", "1", "--pipeline", "none"];

#[test]
fn a_sequence_frame_equals_a_still_at_the_same_time() {
    let dir = temp_dir("still");
    let scene = animated();
    // fps 1: frame 1 is the pose at t = 1 s, reached by updating the frame-0 render scene.
    let mut args = vec![
        "render", &scene, "--frames", "0..1", "--fps", "1", "-o", "seq.exr",
    ];
    args.extend(TINY);
    let o = lumo(&dir, &args);
    assert!(o.status.success(), "{}", text(&o));
    let out = text(&o);
    assert!(out.contains("2 frames") && out.contains("1 refit"), "{out}");
    let mut args = vec!["render", &scene, "--time", "1", "-o", "still.exr"];
    args.extend(TINY);
    let o = lumo(&dir, &args);
    assert!(o.status.success(), "{}", text(&o));
    let read = |n: &str| std::fs::read(dir.join(n)).unwrap();
    assert_eq!(read("seq_0001.exr"), read("still.exr"));
    assert_ne!(
        read("seq_0000.exr"),
        read("seq_0001.exr"),
        "the scene moves"
    );
}

#[test]
fn orbit_numbers_every_output_and_the_aovs() {
    let dir = temp_dir("orbit");
    let mut args = vec![
        "render", "cornell", "--frames", "8..10", "--orbit", "-30", "--aovs", "aovs",
    ];
    args.extend(TINY);
    let o = lumo(&dir, &args);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("camera orbit"), "{}", text(&o));
    for f in 8..=10 {
        for ext in ["exr", "png"] {
            assert!(
                dir.join(format!("cornell_{f:04}.{ext}")).is_file(),
                "frame {f} {ext}"
            );
        }
        assert!(
            dir.join(format!("aovs/{f:04}/normal.exr")).is_file(),
            "aovs of {f}"
        );
    }
    assert!(!dir.join("cornell_0011.png").exists());
    let read = |n: &str| std::fs::read(dir.join(n)).unwrap();
    assert_ne!(
        read("cornell_0008.exr"),
        read("cornell_0009.exr"),
        "the camera turns"
    );
}

#[test]
fn bad_sequence_options_name_the_flag_and_render_nothing() {
    let dir = temp_dir("bad");
    let scene = animated();
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["cornell", "--frames", "9..3"],
            &["--frames", "comes before", "3..9"],
        ),
        (
            &["cornell", "--frames", "x..3"],
            &["--frames", "not a frame number"],
        ),
        (
            &["cornell", "--frames", "0..3", "--fps", "0"],
            &["--fps", "above 0"],
        ),
        (
            &["cornell", "--frames", "0..3"],
            &["--frames 0..3", "no animation", "--orbit"],
        ),
        (
            &[&scene, "--camera", "1", "--frames", "0..3", "--orbit", "90"],
            &["--orbit", "keyframed"],
        ),
        (&["cornell", "--orbit", "90"], &["--frames"]),
        // An orbit of 0° on a static scene: every frame the same, as without --orbit.
        (
            &["cornell", "--frames", "0..3", "--orbit", "0"],
            &["--orbit 0", "every frame would be the same"],
        ),
        (
            &[&scene, "--frames", "0..3", "--time", "1"],
            &["--frames", "--time"],
        ),
    ];
    for (extra, wanted) in cases {
        let mut args = vec!["render"];
        args.extend_from_slice(extra);
        args.extend(["-o", "x.png"]);
        let o = lumo(&dir, &args);
        let e = text(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        assert!(!e.contains("panicked"), "{e}");
        for w in *wanted {
            assert!(e.contains(w), "{args:?}: {w:?} not in {e}");
        }
    }
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        0,
        "nothing written"
    );
}

#[test]
fn serve_animate_needs_an_animated_scene() {
    let dir = temp_dir("serve");
    let o = lumo(&dir, &["serve", "cornell", "--animate", "--port", "0"]);
    let e = text(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("--animate") && e.contains("no animation"), "{e}");
}

/// `--temporal` writes every frame filtered (not the traced 1-spp noise: the filtered frame is
/// smoother), `--temporal-eval` writes its report, and both refuse what they cannot do.
#[test]
fn temporal_sequences_filter_and_evaluate() {
    let dir = temp_dir("temporal");
    let scene = animated();
    let size = ["--size", "32x24", "--spp", "1"];
    let mut args = vec![
        "render",
        &scene,
        "--frames",
        "0..2",
        "--temporal",
        "-o",
        "t.pfm",
    ];
    args.extend(size);
    let o = lumo(&dir, &args);
    assert!(o.status.success(), "{}", text(&o));
    let mut args = vec![
        "render",
        &scene,
        "--frames",
        "0..2",
        "--pipeline",
        "none",
        "-o",
        "n.pfm",
    ];
    args.extend(size);
    assert!(lumo(&dir, &args).status.success());
    // Roughness: mean absolute difference of horizontal neighbours.
    let rough = |n: &str| {
        let img = lumo_image::read_image(&dir.join(n)).unwrap();
        let d = &img.data;
        let s: f32 = (3..d.len()).map(|i| (d[i] - d[i - 3]).abs()).sum();
        s / d.len() as f32
    };
    for f in ["0000", "0001", "0002"] {
        let (t, n) = (rough(&format!("t_{f}.pfm")), rough(&format!("n_{f}.pfm")));
        assert!(t < 0.7 * n, "frame {f}: roughness {t} filtered, {n} traced");
    }
    let mut args = vec![
        "render",
        &scene,
        "--frames",
        "0..9",
        "--temporal-eval",
        "eval",
        "--reference-spp",
        "4",
    ];
    args.extend(size);
    let o = lumo(&dir, &args);
    assert!(o.status.success(), "{}", text(&o));
    // The header names what runs, not the --pipeline default that these modes ignore.
    assert!(
        text(&o).contains("per-frame À-Trous beside the temporal filter")
            && !text(&o).contains("pipeline auto"),
        "{}",
        text(&o)
    );
    for f in [
        "frames.csv",
        "summary.md",
        "flip.png",
        "stability.png",
        "strip.png",
    ] {
        assert!(dir.join("eval").join(f).is_file(), "{f}");
    }
    let csv = std::fs::read_to_string(dir.join("eval/frames.csv")).unwrap();
    assert_eq!(csv.lines().count(), 11, "a header and ten frames");
    for (bad, why) in [
        (
            vec!["--temporal", "--pipeline", "atrous"],
            "drop --pipeline atrous",
        ),
        (
            vec!["--temporal", "--integrator", "light"],
            "makes no G-buffer",
        ),
    ] {
        let mut args = vec!["render", &scene, "--frames", "0..1", "-o", "x.exr"];
        args.extend(bad);
        let o = lumo(&dir, &args);
        assert!(
            !o.status.success() && text(&o).contains(why),
            "{}",
            text(&o)
        );
    }
    let o = lumo(&dir, &["render", &scene, "--temporal"]);
    assert!(
        !o.status.success() && text(&o).contains("--frames"),
        "{}",
        text(&o)
    );
}

/// `--temporal-eval` keeps its references for reuse; they were named by frame, size and spp
/// alone, so a second run of another scene (or another orbit) into the same directory was
/// scored against the first one's references without a word. A reused directory now gives
/// the scores of a fresh one.
#[test]
fn temporal_eval_reuses_only_its_own_references() {
    let dir = temp_dir("eval-cache");
    let run = |scene: &str, out: &str| {
        let o = lumo(
            &dir,
            &[
                "render",
                scene,
                "--frames",
                "0..1",
                "--orbit",
                "60",
                "--temporal-eval",
                out,
                "--reference-spp",
                "4",
                "--size",
                "24x24",
                "--spp",
                "1",
            ],
        );
        assert!(o.status.success(), "{}", text(&o));
        // The FLIP columns (the rest are times).
        std::fs::read_to_string(dir.join(out).join("frames.csv"))
            .unwrap()
            .lines()
            .map(|l| l.split(',').take(4).collect::<Vec<_>>().join(","))
            .collect::<Vec<_>>()
    };
    run("cornell", "shared");
    let reused = run("cornell-spheres", "shared");
    let fresh = run("cornell-spheres", "fresh");
    assert_eq!(reused, fresh);
    let references = std::fs::read_dir(dir.join("shared/references"))
        .unwrap()
        .count();
    assert_eq!(references, 4, "two frames of each scene");
    // The same run again reuses its own (no new files).
    run("cornell-spheres", "shared");
    assert_eq!(
        std::fs::read_dir(dir.join("shared/references"))
            .unwrap()
            .count(),
        4
    );
}

/// Two seeds must not share a frame's noise: with `seed + frame·k` per frame, seed 5's frame 1
/// was seed 5 + k's frame 0, byte for byte.
#[test]
fn temporal_frame_seeds_of_different_seeds_do_not_coincide() {
    let dir = temp_dir("frame-seeds");
    let scene = "cornell";
    let render = |frames: &str, seed: &str, out: &str| {
        let o = lumo(
            &dir,
            &[
                "render",
                scene,
                "--frames",
                frames,
                "--orbit",
                "30",
                "--temporal",
                "--size",
                "24x24",
                "--spp",
                "1",
                "--seed",
                seed,
                "-o",
                out,
            ],
        );
        assert!(o.status.success(), "{}", text(&o));
    };
    render("1..2", "5", "e.pfm");
    render("0..1", &5u32.wrapping_add(0x9e37_79b9).to_string(), "f.pfm");
    let read = |n: &str| std::fs::read(dir.join(n)).unwrap();
    assert_ne!(read("e_0001.pfm"), read("f_0000.pfm"));
}

/// The first frame's AOV directory is checked before anything renders, a refused run creates
/// no AOV directory, and in a sequence `-o av/color.exr --aovs av` is fine (the image is
/// `av/color_0000.exr`, the planes `av/0000/color.exr`).
#[test]
fn sequence_aov_directories_are_checked_first_and_numbered_names_do_not_clash() {
    let dir = temp_dir("seq-aovs");
    let scene = animated();
    let sequence = |out: &str, aovs: &str| {
        let mut args = vec![
            "render", &scene, "--frames", "0..1", "-o", out, "--aovs", aovs,
        ];
        args.extend(TINY);
        lumo(&dir, &args)
    };
    std::fs::create_dir_all(dir.join("bv")).unwrap();
    std::fs::write(dir.join("bv/0000"), b"").unwrap();
    let o = sequence("b.pfm", "bv");
    assert!(
        !o.status.success() && text(&o).contains("bv/0000"),
        "{}",
        text(&o)
    );
    assert!(
        !dir.join("b_0000.pfm").exists(),
        "refused only after rendering frame 0"
    );

    let o = sequence("nodir/a.pfm", "newaov");
    assert!(
        !o.status.success() && text(&o).contains("nodir"),
        "{}",
        text(&o)
    );
    assert!(
        !dir.join("newaov").exists(),
        "a refused run created its AOV directory"
    );

    let o = sequence("av/color.exr", "av");
    assert!(o.status.success(), "{}", text(&o));
    assert!(dir.join("av/color_0001.exr").is_file() && dir.join("av/0001/color.exr").is_file());
}

/// With eight frames or fewer `summary.md` averaged nothing (NaN ratios, -0.0000 means), and
/// `--reference-spp 0` printed FLIP 0.0000 per frame, which reads as a perfect score.
#[test]
fn short_or_unreferenced_evaluations_say_what_they_cannot_score() {
    let dir = temp_dir("eval-short");
    let eval = |out: &str, spp: &str| {
        let o = lumo(
            &dir,
            &[
                "render",
                "cornell",
                "--frames",
                "0..3",
                "--orbit",
                "60",
                "--temporal-eval",
                out,
                "--reference-spp",
                spp,
                "--size",
                "24x24",
                "--spp",
                "1",
            ],
        );
        assert!(o.status.success(), "{}", text(&o));
        (
            text(&o),
            std::fs::read_to_string(dir.join(out).join("summary.md")).unwrap(),
        )
    };
    let (_, summary) = eval("short", "4");
    assert!(
        summary.contains("No quality summary") && !summary.contains("NaN"),
        "{summary}"
    );
    let (log, _) = eval("none", "0");
    assert!(
        log.contains("FLIP n/a") && !log.contains("FLIP 1 spp 0.0000"),
        "{log}"
    );
}

/// scenes/skinned.gltf: the skinned, morphing tube bends left by t = 1 s. A `--frames` frame
/// (mesh re-skinned and refitted) equals a still loaded at that time, and the tube's
/// silhouette moves: its leftmost blue pixel moves left.
#[test]
fn a_skinned_mesh_bends_and_its_refitted_frame_equals_a_still() {
    let dir = temp_dir("skinned");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes/skinned.gltf")
        .display()
        .to_string();
    let tiny = ["--size", "32x32", "--spp", "2", "--pipeline", "none"];
    let mut args = vec![
        "render", &scene, "--frames", "0..1", "--fps", "1", "-o", "seq.exr",
    ];
    args.extend(tiny);
    let o = lumo(&dir, &args);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("1 refit"), "{}", text(&o));
    let mut args = vec!["render", &scene, "--time", "1", "-o", "still.exr"];
    args.extend(tiny);
    let o = lumo(&dir, &args);
    assert!(o.status.success(), "{}", text(&o));
    let read = |n: &str| std::fs::read(dir.join(n)).unwrap();
    assert_eq!(read("seq_0001.exr"), read("still.exr"));
    // Leftmost column holding a pixel of the blue tube (blue well above red; the floor is grey).
    let leftmost = |n: &str| {
        let img = lumo_image::read_image(&dir.join(n)).unwrap();
        let c = img.channels;
        (0..img.width)
            .find(|&x| {
                (0..img.height).any(|y| {
                    let p = &img.data[(y * img.width + x) * c..][..3];
                    p[2] > 0.05 && p[2] > 2.0 * p[0]
                })
            })
            .expect("the tube is in view")
    };
    let (rest, bent) = (leftmost("seq_0000.exr"), leftmost("seq_0001.exr"));
    assert!(
        bent + 3 <= rest,
        "leftmost tube column {rest} at t = 0, {bent} at t = 1"
    );
}
