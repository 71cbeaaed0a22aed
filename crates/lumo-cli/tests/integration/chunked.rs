//! `lumo_cli::chunked`: a render cut into sample chunks, shipped as bytes and added up in any
//! order writes the same bytes as `lumo render`; damaged or foreign chunks are refused.

use std::path::{Path, PathBuf};
use std::process::Command;

use lumo_cli::chunked::{Chunk, ChunkedRender, Role};

fn temp_dir(name: &str) -> PathBuf {
    super::common::temp_dir("chunked", name)
}

fn words(args: &[&str]) -> Vec<String> {
    args.iter().map(|s| s.to_string()).collect()
}

fn lumo_render(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_lumo"))
        .arg("render")
        .args(args)
        .env_remove("LUMO_MEMORY_LIMIT")
        .output()
        .expect("run lumo");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Renders `args` (with `-o OUT` last) in chunks of `chunk_spp` on one "worker" plan, ships
/// them as bytes and finishes every frame with the chunks in reverse order on a driver plan.
fn render_chunked(args: &[&str], chunk_spp: u32) {
    let mut worker = ChunkedRender::new(&words(args), Role::Worker).expect("worker plan");
    let mut driver = ChunkedRender::new(&words(args), Role::Driver).expect("driver plan");
    let size = driver.size();
    for frame in driver.frames() {
        let mut shipped: Vec<Vec<u8>> = worker
            .chunks(chunk_spp)
            .into_iter()
            .filter(|c| c.frame == frame)
            .map(|c| worker.render_chunk(c).expect("chunk").to_bytes(size))
            .collect();
        shipped.reverse();
        for b in &shipped {
            let c = driver.read_chunk(b).expect("a good chunk");
            driver.add(c).expect("added");
        }
        driver.finish(frame).expect("finish");
    }
}

fn same_bytes(a: &Path, b: &Path) {
    let (x, y) = (std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
    assert!(x == y, "{} and {} differ", a.display(), b.display());
}

#[test]
fn a_still_in_chunks_equals_lumo_render_for_every_cut() {
    let dir = temp_dir("still");
    for pipeline in ["auto", "none", "atrous"] {
        let whole = dir.join(format!("whole-{pipeline}.exr"));
        let common = [
            "cornell",
            "--size",
            "24x16",
            "--spp",
            "7",
            "--pipeline",
            pipeline,
        ];
        lumo_render(&[&common[..], &["-o", whole.to_str().unwrap()]].concat());
        for cut in [1, 3, 7] {
            let part = dir.join(format!("chunked-{pipeline}-{cut}.exr"));
            render_chunked(
                &[&common[..], &["-o", part.to_str().unwrap()]].concat(),
                cut,
            );
            same_bytes(&whole, &part);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_sequence_in_chunks_equals_lumo_render_frames() {
    let dir = temp_dir("frames");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/animated.gltf");
    let scene = scene.to_str().unwrap();
    let common = [
        scene,
        "--frames",
        "0..2",
        "--size",
        "16x12",
        "--spp",
        "4",
        "--pipeline",
        "atrous",
    ];
    let whole = dir.join("whole.exr");
    let part = dir.join("part.exr");
    lumo_render(&[&common[..], &["-o", whole.to_str().unwrap()]].concat());
    render_chunked(&[&common[..], &["-o", part.to_str().unwrap()]].concat(), 3);
    for f in 0..=2 {
        same_bytes(
            &dir.join(format!("whole_{f:04}.exr")),
            &dir.join(format!("part_{f:04}.exr")),
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn missing_twice_given_damaged_and_foreign_chunks_are_refused() {
    let dir = temp_dir("refused");
    let out = dir.join("x.exr");
    let args = words(&[
        "cornell",
        "--size",
        "8x8",
        "--spp",
        "4",
        "-o",
        out.to_str().unwrap(),
    ]);
    let mut r = ChunkedRender::new(&args, Role::Driver).unwrap();
    let size = r.size();
    let c = |first, count| Chunk {
        frame: 0,
        first,
        count,
    };
    let a = r.render_chunk(c(0, 2)).unwrap();
    let b = r.render_chunk(c(2, 2)).unwrap();
    r.add(a.clone()).unwrap();
    let err = r.finish(0).unwrap_err().to_string();
    assert!(err.contains("samples 2..4 are missing"), "{err}");
    let err = r.add(a.clone()).unwrap_err().to_string();
    assert!(err.contains("given twice"), "{err}");
    assert!(r.render_chunk(c(3, 2)).is_err(), "past spp");
    let mut bytes = a.to_bytes(size);
    assert!(
        r.read_chunk(&bytes[..bytes.len() - 1]).is_err(),
        "truncated"
    );
    let last = bytes.len() - 1;
    bytes[20] ^= 0xff; // the plan id
    let err = r.read_chunk(&bytes).unwrap_err().to_string();
    assert!(err.contains("another plan"), "{err}");
    bytes[20] ^= 0xff;
    bytes[last + 1 - lumo_render::PixelSums::RECORD_BYTES] = 9; // the last pixel's count
    assert!(r.read_chunk(&bytes).is_err(), "a damaged record");
    assert!(r
        .read_chunk(b"garbage")
        .unwrap_err()
        .to_string()
        .contains("not a lumo chunk"));
    let other = words(&["cornell", "--size", "8x8", "--spp", "4", "--seed", "1"]);
    let foreign = ChunkedRender::new(&other, Role::Worker)
        .unwrap()
        .render_chunk(c(0, 2))
        .unwrap();
    let err = r.add(foreign).unwrap_err().to_string();
    assert!(err.contains("another plan"), "{err}");
    r.add(b).unwrap();
    r.finish(0).expect("0..4 covered");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn what_cannot_be_added_up_is_refused_naming_the_option() {
    for (args, says) in [
        (&["cornell", "--integrator", "bdpt"][..], "--integrator"),
        (
            &["cornell", "--pipeline", "guided"][..],
            "--pipeline guided",
        ),
        (
            &["cornell", "--pipeline", "atrous", "--subsample", "2"][..],
            "--subsample 2",
        ),
        (
            &["cornell", "--frames", "0..1", "--orbit", "10", "--temporal"][..],
            "--temporal",
        ),
        (&["cornell", "--spp", "0"][..], "--spp"),
    ] {
        let err = ChunkedRender::new(&words(args), Role::Worker)
            .err()
            .expect("refused");
        assert!(err.to_string().contains(says), "{args:?}: {err}");
    }
}
