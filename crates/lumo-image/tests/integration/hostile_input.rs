//! Image files that lie (issue 25): headers claiming more pixels than the file holds, images
//! without pixels, paths that are not regular files. Each must be a clear error naming the
//! file, returned fast, without a panic and without allocating what the header claims. The
//! inputs are in tests/data/bad/ (written by make.py there).

use std::path::{Path, PathBuf};
use std::time::Duration;

use lumo_image::{read_image, ImageError, DEFAULT_MAX_PIXELS};

fn bad(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data/bad")
        .join(name)
}

/// Reads `path` on another thread and fails the test if that takes more than 20 s: a reader
/// that blocks (on a FIFO) or reads forever (from a device) must not hang the test suite.
fn read_within_time(path: PathBuf) -> Result<lumo_image::Image, ImageError> {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        // The receiver may have given up; nothing to do then.
        let _ = tx.send(read_image(&path));
    });
    rx.recv_timeout(Duration::from_secs(20))
        .expect("reading the image blocked or ran on")
}

fn error_of(name: &str) -> (ImageError, String) {
    let e = read_within_time(bad(name)).expect_err("the image must be refused");
    let text = e.to_string();
    assert!(
        text.contains(name),
        "{name}: the message must name the file: {text}"
    );
    (e, text)
}

#[test]
fn an_image_without_pixels_is_an_error() {
    let (e, text) = error_of("empty.pfm");
    assert!(
        matches!(
            e,
            ImageError::Empty {
                width: 0,
                height: 4,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(text.contains("empty (0x4 pixels)"), "{text}");
}

#[test]
fn headers_over_the_pixel_budget_are_refused_before_allocating() {
    // The budget is documented as 2^27 pixels unless LUMO_MAX_PIXELS says otherwise.
    assert_eq!(DEFAULT_MAX_PIXELS, 1 << 27);
    for name in ["huge_window.exr", "huge_ihdr.png"] {
        let (e, text) = error_of(name);
        let size = std::fs::metadata(bad(name)).unwrap().len();
        assert!(
            matches!(
                e,
                ImageError::TooLarge {
                    width: 100000,
                    height: 100000,
                    ..
                }
            ),
            "{name}: {e:?}"
        );
        // One line naming the file, its size and the limit.
        assert!(!text.contains('\n'), "{text}");
        assert!(
            text.contains(&format!("in a file of {size} bytes")),
            "{text}"
        );
        assert!(text.contains("over the image limit of") && text.contains("LUMO_MAX_PIXELS"));
    }
}

#[test]
fn headers_within_the_budget_but_beyond_the_file_are_refused_before_allocating() {
    // 1×2^20 pixels in 2^20 uncompressed blocks, in a file of 285 bytes.
    let (_, text) = error_of("many_blocks.exr");
    assert!(text.contains("1048576 blocks"), "{text}");
    // 8192² grey pixels (64 MiB) cannot come out of 68 bytes of deflate data.
    let (_, text) = error_of("short_8k.png");
    assert!(text.contains("truncated or corrupt"), "{text}");
}

#[test]
fn a_missing_file_is_named_once_with_its_cause_once() {
    let path = bad("no_such_image.exr");
    let e = read_image(&path).expect_err("missing");
    let text = e.to_string();
    assert_eq!(text.matches("no_such_image.exr").count(), 1, "{text}");
    assert!(text.contains("no such file; check the name"), "{text}");
    assert!(!text.contains("os error"), "{text}");
    // The cause is in the message, so it is not chained too (printers of the chain, such as
    // anyhow's {:#}, would print it twice).
    assert!(std::error::Error::source(&e).is_none());
}

#[cfg(unix)]
#[test]
fn fifos_devices_and_directories_are_refused_without_opening_them() {
    let dir = std::env::temp_dir().join(format!("lumo-image-hostile-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // Opening a FIFO for reading blocks until a writer comes; nobody will.
    let fifo = dir.join("pipe.pfm");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    assert!(made.is_ok_and(|s| s.success()), "mkfifo failed");
    // /dev/zero never ends.
    let zero = dir.join("zero.exr");
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    let folder = dir.join("folder.png");
    std::fs::create_dir(&folder).unwrap();
    for (path, kind) in [
        (fifo, "FIFO (named pipe)"),
        (zero, "device"),
        (folder, "directory"),
    ] {
        let e = read_within_time(path.clone()).expect_err("refused");
        let text = e.to_string();
        assert!(matches!(e, ImageError::NotAFile { .. }), "{e:?}");
        assert!(
            text.contains(&format!("is a {kind}, not a regular file")),
            "{text}"
        );
        assert!(text.contains(path.file_name().unwrap().to_str().unwrap()));
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A PFM scale of zero, NaN or infinity names no byte order: refused naming the file and the
/// fix, not decoded as big-endian garbage (values near ±3e38 once).
#[test]
fn a_pfm_scale_that_is_zero_or_not_finite_is_an_error() {
    let dir = std::env::temp_dir().join(format!("lumo-pfm-scale-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (i, scale) in ["0", "0.0", "nan", "inf", "-0"].iter().enumerate() {
        let path = dir.join(format!("scale{i}.pfm"));
        let mut bytes = format!("PF\n2 1\n{scale}\n").into_bytes();
        bytes.extend(std::iter::repeat_n(0u8, 2 * 3 * 4));
        std::fs::write(&path, bytes).unwrap();
        let text = read_within_time(path.clone())
            .expect_err("refused")
            .to_string();
        assert!(
            text.contains(&format!("scale{i}.pfm")) && text.contains("non-zero finite"),
            "{scale}: {text}"
        );
    }
    // A usual scale still reads.
    let path = dir.join("ok.pfm");
    let mut bytes = b"PF\n2 1\n-1.0\n".to_vec();
    bytes.extend(std::iter::repeat_n(0u8, 2 * 3 * 4));
    std::fs::write(&path, bytes).unwrap();
    assert!(read_within_time(path).is_ok());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A PFM whose header lines end in CRLF (written on Windows) was read one byte off: every
/// value garbage. The "\r\n" is now one line end; a first data byte of 0x0A after a plain
/// "\n" header is still data (the file's size tells them apart).
#[test]
fn a_pfm_header_with_crlf_line_ends_is_read_right() {
    let dir = std::env::temp_dir().join(format!("lumo-pfm-crlf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let values = [0.5f32, 1.0, 2.0, 0.25, 4.0, 8.0];
    let data: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    let crlf = dir.join("crlf.pfm");
    std::fs::write(&crlf, [b"PF\r\n2 1\r\n-1.0\r\n".as_slice(), &data].concat()).unwrap();
    assert_eq!(read_image(&crlf).unwrap().data, values);
    // A plain header whose first value's first byte is 0x0A ('\n').
    let tricky = [f32::from_le_bytes([0x0a, 0, 0, 0x3f]), 1.0, 2.0];
    let data: Vec<u8> = tricky.iter().flat_map(|v| v.to_le_bytes()).collect();
    let lf = dir.join("lf.pfm");
    std::fs::write(&lf, [b"PF\n1 1\n-1.0\r".as_slice(), &data].concat()).unwrap();
    assert_eq!(read_image(&lf).unwrap().data, tricky);
    std::fs::remove_dir_all(&dir).ok();
}
