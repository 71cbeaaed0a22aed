//! `lumo bench quality`, `speed` and `reference` end to end, on tiny images: the report and
//! contact sheet have the expected rows and columns, the reference is cached and reused, scores
//! are deterministic, bad input fails before anything is written, and an interrupted run leaves
//! no partial file. No timing assertions.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn temp_dir(name: &str) -> PathBuf {
    super::common::temp_dir("bench", name)
}

use super::common::lumo;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `lumo bench quality` at 32×32 with a 16-spp reference.
fn quality(cache: &Path, out: &Path, extra: &[&str]) -> Output {
    let (c, o) = (cache.to_str().unwrap(), out.to_str().unwrap());
    let mut args = vec![
        "bench",
        "quality",
        "--scenes",
        "cornell",
        "--size",
        "32x32",
        "--spp",
        "1,2",
        "--reference-spp",
        "16",
        "--cache",
        c,
        "--out-dir",
        o,
    ];
    args.extend_from_slice(extra);
    let r = lumo(&args);
    assert!(r.status.success(), "{}", stderr(&r));
    r
}

/// The rows of the Markdown table under the heading `heading` (header and rule excluded).
fn table(md: &str, heading: &str) -> Vec<Vec<String>> {
    let start = md
        .lines()
        .position(|l| l == heading)
        .unwrap_or_else(|| panic!("no {heading:?} in\n{md}"));
    md.lines()
        .skip(start + 1)
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .skip(2)
        .map(|l| {
            l.trim_matches('|')
                .split('|')
                .map(|c| c.trim().to_string())
                .collect()
        })
        .collect()
}

/// Every file name in `dir`.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn quality_writes_the_tables_and_the_contact_sheet() {
    let dir = temp_dir("tables");
    let out = dir.join("results");
    quality(&dir.join("cache"), &out, &[]);
    assert_eq!(names(&out), ["quality.md", "quality.png"]);
    let md = std::fs::read_to_string(out.join("quality.md")).unwrap();
    let header = md
        .lines()
        .find(|l| l.starts_with("| method | cornell"))
        .unwrap();
    assert_eq!(header, "| method | cornell 1 spp | cornell 2 spp |");
    for heading in [
        "## relMSE per method and scene",
        "## FLIP per method and scene",
    ] {
        let rows = table(&md, heading);
        let methods: Vec<&str> = rows.iter().map(|r| r[0].as_str()).collect();
        assert_eq!(
            methods,
            [
                "none",
                "bilateral",
                "atrous",
                "guided",
                "jbu",
                "light (equal time)",
                "bdpt (equal time)",
                "ppm (equal time)"
            ]
        );
        assert!(rows.iter().all(|r| r.len() == 3), "{rows:?}");
        for r in &rows[5..] {
            for c in &r[1..] {
                let v: f64 = c.parse().unwrap_or_else(|_| panic!("{r:?}"));
                assert!(v.is_finite() && v >= 0.0, "{r:?}");
            }
        }
    }
    // The integrators' own table: one row per integrator and spp, at least one sample each.
    let rows = table(&md, "## Integrators at equal time");
    let which: Vec<(&str, &str)> = rows
        .iter()
        .map(|r| (r[1].as_str(), r[2].as_str()))
        .collect();
    assert_eq!(
        which,
        [
            ("1", "light"),
            ("1", "bdpt"),
            ("1", "ppm"),
            ("2", "light"),
            ("2", "bdpt"),
            ("2", "ppm")
        ]
    );
    for r in &rows {
        assert_eq!(r.len(), 9, "{r:?}");
        assert!(r[3].parse::<u32>().unwrap() >= 1, "{r:?}");
        assert!(r[6].parse::<f64>().unwrap() > 0.0, "{r:?}");
    }
    let rows = table(&md, "### cornell");
    assert_eq!(rows.len(), 10);
    for r in &rows {
        assert_eq!(r.len(), 11, "{r:?}");
        let relmse: f64 = r[3].parse().unwrap();
        assert!(relmse.is_finite() && relmse > 0.0, "{r:?}");
    }
    // Filtering must beat the unfiltered path tracer at 1 spp on relMSE.
    let none: f64 = rows[0][3].parse().unwrap();
    let atrous: f64 = rows[2][3].parse().unwrap();
    assert!(atrous < none, "{atrous} vs {none}");

    let sheet = lumo_image::read_image(&out.join("quality.png")).unwrap();
    // Reference + 5 methods, 32 px each with 4 px gaps; two rows (1 and 2 spp).
    assert_eq!(sheet.width, 4 + 6 * (32 + 4));
    assert!(sheet.height > 2 * 32 + 2 * 16, "{}", sheet.height);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_reference_is_cached_and_scores_are_deterministic() {
    let dir = temp_dir("cache");
    let cache = dir.join("cache");
    let first = quality(&cache, &dir.join("a"), &[]);
    assert!(
        stderr(&first).contains("reference cornell: rendered"),
        "{}",
        stderr(&first)
    );
    let second = quality(&cache, &dir.join("b"), &[]);
    assert!(
        stderr(&second).contains("reference cornell: cached"),
        "{}",
        stderr(&second)
    );
    assert!(!stderr(&second).contains("rendered"), "{}", stderr(&second));
    // A fresh cache and one thread: the reference is rendered again, bit for bit the same.
    let third = quality(&dir.join("cache2"), &dir.join("c"), &["--threads", "1"]);
    assert!(stderr(&third).contains("reference cornell: rendered"));
    let scores = |d: &str| -> Vec<Vec<String>> {
        let md = std::fs::read_to_string(dir.join(d).join("quality.md")).unwrap();
        // Method, spp and the six error columns; the three time columns vary.
        table(&md, "### cornell")
            .into_iter()
            .map(|r| r[..8].to_vec())
            .collect()
    };
    assert_eq!(scores("a"), scores("b"));
    assert_eq!(scores("a"), scores("c"));
    // The cache holds one EXR and its key.
    let entries = names(&cache);
    assert_eq!(entries.len(), 2, "{entries:?}");
    let key = std::fs::read_to_string(cache.join(entries[1].as_str())).unwrap();
    assert!(
        key.contains("scene builtin:cornell") && key.contains("spp 16"),
        "{key}"
    );
    // `lumo bench reference` finds the same entry without rendering.
    let r = lumo(&[
        "bench",
        "reference",
        "cornell",
        "--size",
        "32x32",
        "--reference-spp",
        "16",
        "--cache",
        cache.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    assert!(stderr(&r).contains("cached"));
    let printed = String::from_utf8_lossy(&r.stdout).trim().to_string();
    assert_eq!(Path::new(&printed), cache.join(entries[0].as_str()));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_bad_scene_path_fails_before_anything_is_written() {
    let dir = temp_dir("bad");
    let out = dir.join("results");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("quality.md"), "previous results").unwrap();
    let r = lumo(&[
        "bench",
        "quality",
        "--scenes",
        "cornell,no/such/scene.xml",
        "--size",
        "32x32",
        "--reference-spp",
        "16",
        "--cache",
        dir.join("cache").to_str().unwrap(),
        "--out-dir",
        out.to_str().unwrap(),
    ]);
    assert_eq!(r.status.code(), Some(2));
    let err = stderr(&r);
    assert!(
        err.contains("no/such/scene.xml") && err.contains("does not exist"),
        "{err}"
    );
    assert_eq!(names(&out), ["quality.md"]);
    assert_eq!(
        std::fs::read_to_string(out.join("quality.md")).unwrap(),
        "previous results"
    );
    assert!(!dir.join("cache").exists());
    for bad in [
        &["--spp", "0"][..],
        &["--pipelines", "nope"],
        &["--size", "0x4"],
    ] {
        let mut args = vec!["bench", "quality", "--out-dir", out.to_str().unwrap()];
        args.extend_from_slice(bad);
        let r = lumo(&args);
        assert_eq!(r.status.code(), Some(2), "{bad:?}: {}", stderr(&r));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Ctrl-C in the middle of a run: the previous results stay as they were, no temporary or
/// half-written file is left, and no half-rendered reference enters the cache.
#[cfg(unix)]
#[test]
fn an_interrupted_run_leaves_no_partial_file() {
    let dir = temp_dir("interrupt");
    let out = dir.join("results");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("quality.md"), "previous results").unwrap();
    let cache = dir.join("cache");
    let mut child = Command::new(env!("CARGO_BIN_EXE_lumo"))
        .args([
            "bench",
            "quality",
            "--scenes",
            "cornell",
            "--size",
            "32x32",
            // Far more work than the wait below, so the signal lands mid-render.
            "--reference-spp",
            "1000000",
            "--cache",
            cache.to_str().unwrap(),
            "--out-dir",
            out.to_str().unwrap(),
        ])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(500));
    // Ctrl-C's SIGINT and SIGTERM both end lumo without running any clean-up, which is what is
    // tested here. SIGTERM is sent because a process started in the background by a
    // non-interactive shell (as CI scripts may run) inherits SIGINT *ignored*.
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let t0 = std::time::Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t0.elapsed() > std::time::Duration::from_secs(30) {
            let _ = child.kill();
            panic!("lumo bench quality did not stop within 30 s of SIGTERM");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    assert!(!status.success());
    assert_eq!(names(&out), ["quality.md"]);
    assert_eq!(
        std::fs::read_to_string(out.join("quality.md")).unwrap(),
        "previous results"
    );
    if cache.exists() {
        assert!(names(&cache).is_empty(), "{:?}", names(&cache));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn speed_writes_both_tables_with_the_machine_in_the_header() {
    let dir = temp_dir("speed");
    let out = dir.join("results");
    let r = lumo(&[
        "bench",
        "speed",
        "--scenes",
        "cornell",
        "--size",
        "16x16",
        "--spp",
        "1",
        "--bounces",
        "0,1",
        "--pipelines",
        "none,atrous,jbu",
        "--filter-sizes",
        "24x24,32x16",
        "--repeats",
        "2",
        "--warmup",
        "0",
        "--out-dir",
        out.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    assert_eq!(names(&out), ["speed.md"]);
    let md = std::fs::read_to_string(out.join("speed.md")).unwrap();
    assert!(
        md.contains(&format!("- lumo {}", env!("CARGO_PKG_VERSION"))),
        "{md}"
    );
    assert!(md.contains("- CPU: ") && md.contains(" cores; "), "{md}");
    let t1 = table(
        &md,
        "## Table 1: render time per scene, indirect bounces and spp",
    );
    assert_eq!(t1.len(), 2);
    assert_eq!(t1[0][..3], ["cornell", "0", "1"]);
    assert_eq!(t1[1].len(), 3 + 3);
    let stages = table(&md, "### Stages");
    assert_eq!(stages.len(), 6);
    let t2 = table(&md, "## Table 2: filter time per resolution and settings");
    // 9 À-Trous + the default + 6 guided + 3 bilateral configurations, two sizes each.
    assert_eq!(t2.len(), 19);
    assert!(t2.iter().all(|r| r.len() == 4), "{t2:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn any_scene_file_works_next_to_a_builtin_of_the_same_name() {
    let dir = temp_dir("file");
    let out = dir.join("results");
    let xml = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell.xml");
    let scenes = format!("{},cornell", xml.display());
    let r = lumo(&[
        "bench",
        "quality",
        "--scenes",
        &scenes,
        "--size",
        "16x16",
        "--spp",
        "1",
        "--pipelines",
        "none",
        "--reference-spp",
        "4",
        "--cache",
        dir.join("cache").to_str().unwrap(),
        "--out-dir",
        out.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let md = std::fs::read_to_string(out.join("quality.md")).unwrap();
    let file_rows = table(&md, "### cornell.xml");
    let builtin_rows = table(&md, "### cornell");
    assert_eq!(file_rows.len(), 1);
    // The Mitsuba file is the built-in scene: same image, same scores.
    assert_eq!(file_rows[0][..8], builtin_rows[0][..8]);
    // Two scenes given under one name are refused.
    let r = lumo(&[
        "bench",
        "quality",
        "--scenes",
        "cornell,cornell",
        "--out-dir",
        out.to_str().unwrap(),
    ]);
    assert_eq!(r.status.code(), Some(2));
    assert!(stderr(&r).contains("already named"), "{}", stderr(&r));
    let _ = std::fs::remove_dir_all(&dir);
}
