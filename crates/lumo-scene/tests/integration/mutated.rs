//! A bounded property test per loader (issue 49): many deterministic mutations of a small
//! valid file of each format (bytes flipped, runs duplicated, numbers made huge, parts cut)
//! are loaded, and each either fails with an error or gives a scene that holds at most a
//! fixed number of elements per input byte, in a time bounded per input byte. A cheap,
//! always-run companion of the cargo-fuzz targets in `fuzz/` (which need nightly).

use std::time::{Duration, Instant};

use crate::common;

use common::{load, scenes, temp_dir, write};

/// splitmix64: a fixed sequence, so every run tries the same inputs.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Values that stress parsers: huge counts, overflows, negatives, non-numbers.
const TOKENS: &[&[u8]] = &[
    b"4294967295",
    b"1e39",
    b"-1",
    b"nan",
    b"inf",
    b"99999999",
    b"0",
    b"\"",
    b"<",
    b">",
    b"{",
    b"}",
    b"[",
    b"]",
    b"\n",
    b"18446744073709551616",
    b"-2147483648",
];

/// One mutation of `seed`.
fn mutate(seed: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut d = seed.to_vec();
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(d.len());
        match rng.below(6) {
            0 => d[at] ^= 1 << rng.below(8),
            1 => {
                let end = (at + 1 + rng.below(64)).min(d.len());
                d.drain(at..end);
            }
            2 => {
                // Duplicate a run several times (elements repeated: more geometry per byte).
                let end = (at + 1 + rng.below(200)).min(d.len());
                let run = d[at..end].to_vec();
                for _ in 0..1 + rng.below(8) {
                    d.splice(at..at, run.iter().copied());
                }
            }
            3 => {
                let t = TOKENS[rng.below(TOKENS.len())];
                d.splice(at..at, t.iter().copied());
            }
            4 => {
                // Replace a digit run with a stress token.
                if let Some(s) = (at..d.len()).find(|&i| d[i].is_ascii_digit()) {
                    let e = (s..d.len())
                        .find(|&i| !d[i].is_ascii_digit())
                        .unwrap_or(d.len());
                    let t = TOKENS[rng.below(7)];
                    d.splice(s..e, t.iter().copied());
                }
            }
            _ => d.truncate(at.max(1)),
        }
        if d.is_empty() {
            d.push(b' ');
        }
    }
    d
}

/// Elements a scene holds (vertices, triangles, meshes, instances, lights).
fn scene_size(s: &lumo_scene::Scene) -> usize {
    let mesh: usize = s
        .meshes
        .iter()
        .map(|m| m.positions.len() + m.indices.len() + 1)
        .sum();
    mesh + s.instances.len() + s.lights.len()
}

/// Most elements per input byte: an OBJ face `f 1 2 3 4 1 2 3 4` (18 bytes) is six
/// triangles, and an exact shape (about 22 bytes) a bounded proxy; a few hundred covers every
/// format with room.
const ELEMENTS_PER_BYTE: usize = 400;

#[test]
fn mutated_files_of_every_format_load_or_fail_within_bounds() {
    let dir = temp_dir("mutated");
    // Textures and meshes the seeds name resolve next to the mutated file.
    for f in ["box.obj", "box.mtl", "pyramid_ascii.ply", "pyramid_le.ply"] {
        std::fs::copy(scenes().join("meshes").join(f), dir.join(f)).unwrap();
    }
    let seeds: [(&str, Vec<u8>); 5] = [
        ("xml", std::fs::read(scenes().join("cornell.xml")).unwrap()),
        (
            "gltf",
            std::fs::read(scenes().join("hierarchy.gltf")).unwrap(),
        ),
        (
            "obj",
            std::fs::read(scenes().join("meshes/box.obj")).unwrap(),
        ),
        (
            "ply",
            std::fs::read(scenes().join("meshes/pyramid_ascii.ply")).unwrap(),
        ),
        (
            "ply",
            std::fs::read(scenes().join("meshes/pyramid_le.ply")).unwrap(),
        ),
    ];
    let mut rng = Rng(49);
    let mut worst = (0.0f64, String::new());
    for (ext, seed) in &seeds {
        let (mut loaded, mut refused) = (0, 0);
        for i in 0..150 {
            let input = mutate(seed, &mut rng);
            let path = write(&dir, &format!("m.{ext}"), &input);
            let start = Instant::now();
            let result = load(&path);
            let took = start.elapsed();
            match result {
                Ok(s) => {
                    loaded += 1;
                    let size = scene_size(&s.scene);
                    assert!(
                        size <= ELEMENTS_PER_BYTE * input.len() + 10_000,
                        "{ext} mutation {i}: {size} elements from {} bytes",
                        input.len()
                    );
                }
                Err(_) => refused += 1,
            }
            // 20 µs per byte plus 0.5 s: far above any near-linear loader on a loaded
            // machine, far below a quadratic one on these sizes.
            let bound = Duration::from_millis(500) + Duration::from_micros(20 * input.len() as u64);
            assert!(
                took < bound,
                "{ext} mutation {i}: {took:?} for {} bytes",
                input.len()
            );
            let per_byte = took.as_secs_f64() / input.len() as f64;
            if per_byte > worst.0 {
                worst = (per_byte, format!("{ext} mutation {i}"));
            }
        }
        // The mutations must exercise both outcomes, or the test checks little.
        assert!(
            loaded > 0 && refused > 0,
            "{ext}: {loaded} loaded, {refused} refused"
        );
    }
    eprintln!(
        "slowest per byte: {:.2} µs/byte ({})",
        worst.0 * 1e6,
        worst.1
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The image readers (PNG, PFM, EXR, Radiance HDR) on mutated files, through an environment
/// map: an error or an image, in a time bounded per input byte (the readers check a header's
/// size against the file and the pixel budget before allocating).
#[test]
fn mutated_images_of_every_format_load_or_fail_within_bounds() {
    let dir = temp_dir("mutated-images");
    let mut img = lumo_image::Image::new(8, 6, 3, 0.0);
    for (i, v) in img.data.iter_mut().enumerate() {
        *v = (i % 7) as f32 * 0.1;
    }
    let mut seeds: Vec<(&str, Vec<u8>)> = ["png", "pfm", "exr"]
        .into_iter()
        .map(|ext| {
            let p = dir.join(format!("seed.{ext}"));
            lumo_image::write_image(&p, &img).unwrap();
            (ext, std::fs::read(&p).unwrap())
        })
        .collect();
    let mut hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 6 +X 8\n".to_vec();
    for i in 0..48u8 {
        hdr.extend_from_slice(&[i * 5, 100, 200 - i, 128]);
    }
    seeds.push(("hdr", hdr));
    let mut rng = Rng(4949);
    for (ext, seed) in &seeds {
        let xml = common::mitsuba(&format!(
            r#"<emitter type="envmap"><string name="filename" value="m.{ext}"/></emitter>"#
        ));
        let scene = write(&dir, &format!("env-{ext}.xml"), xml);
        write(&dir, &format!("m.{ext}"), seed);
        load(&scene).unwrap_or_else(|e| panic!("the {ext} seed loads: {e}"));
        let (mut loaded, mut refused) = (0, 0);
        for i in 0..150 {
            let input = mutate(seed, &mut rng);
            write(&dir, &format!("m.{ext}"), &input);
            let start = Instant::now();
            match load(&scene) {
                Ok(_) => loaded += 1,
                Err(_) => refused += 1,
            }
            let took = start.elapsed();
            let bound = Duration::from_millis(500) + Duration::from_micros(20 * input.len() as u64);
            assert!(
                took < bound,
                "{ext} mutation {i}: {took:?} for {} bytes",
                input.len()
            );
        }
        // Checksums (PNG) may refuse every mutation; the refusals must be there.
        assert!(refused > 0, "{ext}: {loaded} loaded, {refused} refused");
    }
    std::fs::remove_dir_all(&dir).ok();
}
