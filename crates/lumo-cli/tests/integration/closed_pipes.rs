//! Standard output or error closed by the reader (`lumo compare … --json | head`, `lumo render
//! --list | true`): the command ends without a panic (exit 101) and still writes its files.

use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

use lumo_image::{write_image, Image};

fn temp_dir(name: &str) -> PathBuf {
    super::common::temp_dir("pipes", name)
}

/// A pipe whose reading end is already closed: every write to the other end fails with
/// EPIPE (Rust ignores SIGPIPE), as after `| head` has exited.
fn closed_pipe() -> Stdio {
    let (reader, writer) = std::io::pipe().expect("pipe");
    drop(reader);
    writer.into()
}

/// Runs `lumo args…` with stdout (and, if `stderr_too`, stderr) on a closed pipe.
fn lumo_closed(args: &[&str], stderr_too: bool) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_lumo"));
    c.args(args).stdout(closed_pipe());
    if stderr_too {
        c.stderr(closed_pipe());
    } else {
        c.stderr(Stdio::piped());
    }
    c.output().expect("run lumo")
}

#[test]
fn a_closed_stdout_ends_the_output_quietly() {
    let dir = temp_dir("stdout");
    let mut a = Image::new(8, 6, 3, 0.25);
    let b = Image::new(8, 6, 3, 0.5);
    a.pixel_mut(1, 1)[0] = 1.0;
    let (ra, rb) = (dir.join("a.pfm"), dir.join("b.pfm"));
    write_image(&ra, &a).unwrap();
    write_image(&rb, &b).unwrap();
    let (ra, rb) = (ra.to_str().unwrap(), rb.to_str().unwrap());
    let diff = dir.join("diff.png");
    let denoised = dir.join("d.pfm");
    let runs: [Vec<&str>; 4] = [
        vec!["render", "--list"],
        vec!["compare", ra, rb, "--json"],
        vec!["compare", ra, rb, "--diff", diff.to_str().unwrap()],
        vec![
            "denoise",
            "--color",
            rb,
            "-o",
            denoised.to_str().unwrap(),
            "--filter",
            "atrous",
            "--timings",
        ],
    ];
    for args in &runs {
        let o = lumo_closed(args, false);
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {e}");
        assert!(
            !e.contains("panicked") && !e.contains("Broken pipe"),
            "{args:?}: {e}"
        );
    }
    // The work after the closed output still happened.
    assert!(diff.exists() && denoised.exists());
    // With stderr closed as well (`2>&1 | head`), an error still exits 2, not 101.
    let o = lumo_closed(&["render", "--list"], true);
    assert_eq!(o.status.code(), Some(0));
    let o = lumo_closed(&["compare", ra, "/nonexistent/x.pfm"], true);
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&dir).ok();
}
