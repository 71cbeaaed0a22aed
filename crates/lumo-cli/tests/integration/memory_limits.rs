//! Every command checks memory before allocating image-sized buffers (issue 49), against the
//! least of MemAvailable, the cgroup's limit and RLIMIT_AS (`LUMO_MEMORY_LIMIT` stands in for
//! a small machine): a refused run exits 2 at once with a message, never an abort.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use lumo_image::{write_image, Image};

fn temp_dir(name: &str) -> PathBuf {
    super::common::temp_dir("memory", name)
}

fn lumo(dir: &Path, args: &[&str], memory: &str) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lumo"))
        .args(args)
        .current_dir(dir)
        .env("LUMO_MEMORY_LIMIT", memory)
        .output()
        .expect("run lumo")
}

fn refused(o: &Output, says: &str) {
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains(says) && e.contains("of memory"), "{e}");
}

#[test]
fn compare_and_denoise_check_memory_before_allocating() {
    let dir = temp_dir("commands");
    // 1024² RGB: each image is 12 MiB as floats; reading one needs 32 MiB, comparing two
    // about 140 MiB, denoising about 500 MiB.
    let img = Image::new(1024, 1024, 3, 0.5);
    write_image(&dir.join("a.pfm"), &img).unwrap();
    write_image(&dir.join("b.pfm"), &img).unwrap();
    let compare = ["compare", "a.pfm", "b.pfm"];
    refused(
        &lumo(&dir, &compare, "16M"),
        "a.pfm: reading 1024x1024 pixels",
    );
    refused(
        &lumo(&dir, &compare, "64M"),
        "comparing 1 image(s) of 1024x1024",
    );
    let denoise = ["denoise", "--color", "a.pfm", "-o", "out.pfm"];
    refused(&lumo(&dir, &denoise, "128M"), "denoising 1024x1024 pixels");
    assert!(!dir.join("out.pfm").exists());
    // A PNG's header is checked before its pixels are decoded.
    write_image(&dir.join("c.png"), &img).unwrap();
    refused(
        &lumo(&dir, &["compare", "c.png", "c.png"], "16M"),
        "c.png: reading 1024x1024 pixels",
    );
    // Within the budget, both run.
    assert!(lumo(&dir, &compare, "1G").status.success());
    std::fs::remove_dir_all(&dir).ok();
}

/// RLIMIT_AS (`ulimit -v`) binds like a small machine: MemAvailable alone let `render --size
/// 8192x8192` start and abort under a 2 GiB limit.
#[cfg(target_os = "linux")]
#[test]
fn the_address_space_limit_is_respected() {
    let dir = temp_dir("rlimit");
    let script = format!(
        "ulimit -v 1048576 && exec '{}' render --size 4096x4096 --spp 1 -o big.png",
        env!("CARGO_BIN_EXE_lumo")
    );
    let o = Command::new("sh")
        .arg("-c")
        .arg(script)
        .current_dir(&dir)
        .env_remove("LUMO_MEMORY_LIMIT")
        .output()
        .expect("run sh");
    refused(&o, "--size");
    let e = String::from_utf8_lossy(&o.stderr);
    // About 1 GiB less what the process already maps, not the machine's MemAvailable.
    assert!(
        e.contains("MiB is available") || e.contains("only 1.0"),
        "{e}"
    );
    assert!(!dir.join("big.png").exists());
    std::fs::remove_dir_all(&dir).ok();
}
