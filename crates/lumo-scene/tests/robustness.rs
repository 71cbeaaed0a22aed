//! Mutation testing of the loaders: thousands of corrupted copies of the sample scenes (bit
//! flips, overwritten bytes, truncations, duplicated and deleted runs) must load or fail with
//! an error, never panic. `LUMO_FUZZ_ITERS=N` runs N mutations per file (default 300).

mod common;

use std::panic::{catch_unwind, AssertUnwindSafe};

use common::{load, scenes, temp_dir, write};

/// xorshift64*: deterministic, so a failure reproduces.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Interesting replacement bytes: digits, signs, XML and OBJ punctuation, extremes.
const SPICE: &[u8] = b"0123456789-+.eE/<>\"=$ \n\xff\x00";

fn mutate(rng: &mut Rng, data: &[u8]) -> Vec<u8> {
    let mut d = data.to_vec();
    for _ in 0..1 + rng.below(4) {
        if d.is_empty() {
            break;
        }
        let at = rng.below(d.len());
        match rng.below(6) {
            0 => d[at] ^= 1 << rng.below(8),
            1 => d[at] = SPICE[rng.below(SPICE.len())],
            2 => d.truncate(at),
            3 => {
                let len = rng.below(16).min(d.len() - at);
                let run: Vec<u8> = d[at..at + len].to_vec();
                let to = rng.below(d.len());
                d.splice(to..to, run);
            }
            4 => {
                let len = rng.below(16).min(d.len() - at);
                d.drain(at..at + len);
            }
            _ => d[at] = rng.next() as u8,
        }
    }
    d
}

#[test]
fn corrupted_scene_files_never_panic() {
    let iters: usize = std::env::var("LUMO_FUZZ_ITERS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(300);
    let dir = temp_dir("fuzz");
    // Self-contained samples (no relative references), one per reader.
    let samples = [
        "cornell.xml",
        "hierarchy.gltf",
        "hierarchy.glb",
        "meshes/pyramid_le.ply",
        "meshes/pyramid_be.ply",
        "meshes/pyramid_ascii.ply",
    ];
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut ok, mut failed, mut caught) = (0usize, 0usize, 0usize);
    for sample in samples {
        let original = std::fs::read(scenes().join(sample)).unwrap();
        let name = sample.rsplit('/').next().unwrap_or(sample);
        for i in 0..iters {
            let data = mutate(&mut rng, &original);
            let path = write(&dir, name, &data);
            match catch_unwind(AssertUnwindSafe(|| load(&path))) {
                Ok(Ok(_)) => ok += 1,
                Ok(Err(e)) => {
                    failed += 1;
                    // The glTF loader's last-resort guard around the gltf crate.
                    caught += e.to_string().contains("parser failed on") as usize;
                    assert!(
                        e.to_string().contains(name),
                        "{sample} #{i}: error lacks the file: {e}"
                    );
                }
                Err(_) => {
                    let keep = std::env::temp_dir().join(format!("lumo-fuzz-crash-{name}"));
                    std::fs::write(&keep, &data).ok();
                    panic!(
                        "{sample} mutation {i} panicked; input saved to {}",
                        keep.display()
                    );
                }
            }
        }
    }
    eprintln!(
        "{} mutated files: {ok} loaded, {failed} refused with an error ({caught} of them by the \
         guard around the gltf crate)",
        ok + failed
    );
    assert!(failed > 0 && ok > 0);
}
