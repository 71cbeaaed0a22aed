//! Outputs that could only fail after the render (issue 49): a name ending in '/', a name too
//! long for the file system, an AOV plane whose path is a directory (in any frame of a
//! sequence); each is refused before rendering, with nothing written. Temporaries left by
//! interrupted writes are swept.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn temp_dir(name: &str) -> PathBuf {
    super::common::temp_dir("outputs", name)
}

fn lumo_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lumo"))
        .args(args)
        .current_dir(dir)
        .env_remove("LUMO_MEMORY_LIMIT")
        .output()
        .expect("run lumo")
}

fn refused(o: &Output, says: &str) {
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains(says), "{e}");
    // Refused before the render: no progress, no timing line.
    assert!(!e.contains("rendered"), "{e}");
}

const TINY: [&str; 6] = ["render", "--size", "8x8", "--spp", "1", "-o"];

#[test]
fn names_that_cannot_be_written_are_refused_before_rendering() {
    let dir = temp_dir("names");
    let run = |out: &str| lumo_in(&dir, &[&TINY[..], &[out]].concat());
    refused(&run("out.png/"), "ends in '/'");
    let long = format!("{}.png", "n".repeat(300));
    refused(&run(&long), "the file name is 304 bytes");
    // 250 bytes is a valid name; its temporary (which adds a prefix) must be too.
    let fits = format!("{}.png", "f".repeat(246));
    let o = run(&fits);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(dir.join(&fits).is_file());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn every_aov_plane_of_every_frame_is_checked_before_rendering() {
    let dir = temp_dir("aovs");
    std::fs::create_dir_all(dir.join("still/normal.exr")).unwrap();
    let o = lumo_in(&dir, &[&TINY[..], &["a.png", "--aovs", "still"]].concat());
    refused(&o, "still/normal.exr is not a regular file");
    assert!(!dir.join("a.png").exists() && !dir.join("still/color.exr").exists());
    // In a sequence, the last frame's plane is checked too.
    std::fs::create_dir_all(dir.join("seq/0003/albedo.exr")).unwrap();
    let o = lumo_in(
        &dir,
        &[
            &TINY[..],
            &[
                "b.png", "--frames", "1..3", "--orbit", "10", "--aovs", "seq",
            ],
        ]
        .concat(),
    );
    refused(&o, "seq/0003/albedo.exr is not a regular file");
    assert!(!dir.join("b_0001.png").exists() && !dir.join("seq/0001").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[cfg(target_os = "linux")]
#[test]
fn temporaries_of_interrupted_writes_are_swept() {
    let dir = temp_dir("sweep");
    // No process has this id (above Linux's largest pid); one of ours is left alone.
    let stale = dir.join(".lumo-tmp-999999999-0.out.png");
    let live = dir.join(format!(".lumo-tmp-{}-0.x.png", std::process::id()));
    std::fs::write(&stale, b"half an image").unwrap();
    std::fs::write(&live, b"being written").unwrap();
    let o = lumo_in(&dir, &[&TINY[..], &["out.png"]].concat());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{e}");
    assert!(e.contains("removed 1 temporary file(s)"), "{e}");
    assert!(!stale.exists() && live.exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// A scene path that is a loop of symbolic links was reported as a file that "does not exist".
#[cfg(unix)]
#[test]
fn a_symlink_loop_is_named_as_one() {
    let dir = temp_dir("symlink-loop");
    std::os::unix::fs::symlink("b.xml", dir.join("a.xml")).unwrap();
    std::os::unix::fs::symlink("a.xml", dir.join("b.xml")).unwrap();
    let o = lumo_in(
        &dir,
        &[
            "render", "a.xml", "--size", "8x8", "--spp", "1", "-o", "x.png",
        ],
    );
    refused(&o, "symbolic link that cannot be followed");
    assert!(!String::from_utf8_lossy(&o.stderr).contains("does not exist"));
    std::fs::remove_dir_all(&dir).ok();
}

/// `--aovs` writes the Dirac lights' exact light (`dirac.exr`) for a scene lit by a sun
/// whatever the pipeline, so that `lumo denoise --input-dir` can keep it out of its filter;
/// the built-in Cornell box (an area light only) gets none.
#[test]
fn aovs_carry_the_dirac_plane_where_the_scene_has_dirac_lights() {
    let dir = temp_dir("dirac");
    let wires = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes/tuning/tune-wires.xml")
        .display()
        .to_string();
    for (scene, pipeline, expect) in [
        (wires.as_str(), "none", true),
        (wires.as_str(), "auto", true),
        ("cornell", "none", false),
    ] {
        let aovs = format!("aovs-{pipeline}-{expect}");
        let o = lumo_in(
            &dir,
            &[
                "render",
                scene,
                "--size",
                "16x16",
                "--spp",
                "1",
                "--pipeline",
                pipeline,
                "-o",
                "a.exr",
                "--aovs",
                &aovs,
            ],
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert_eq!(
            dir.join(&aovs).join("dirac.exr").is_file(),
            expect,
            "{scene} {pipeline}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
