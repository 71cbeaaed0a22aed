//! The reference-image cache: a converged render is expensive (1024 spp by default), so it is
//! rendered once per scene and settings and kept as EXR in a cache directory. The file name
//! carries a hash of everything the image depends on; a text file beside it spells the key
//! out, so a stale entry can be recognised by eye.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use lumo_image::{read_image, Image};

use super::atomic::{write_bytes, write_image_atomic};

/// Everything a reference image depends on.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ReferenceKey {
    /// `builtin:NAME`, or `file:CANONICAL-PATH` with the file's size and modification time.
    pub scene_id: String,
    /// A file-name-safe short name of the scene.
    pub slug: String,
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// Samples per pixel of the reference.
    pub spp: u32,
    /// Longest path depth.
    pub max_depth: u32,
    /// Russian-roulette start depth.
    pub rr_depth: u32,
    /// Sampler seed of the reference.
    pub seed: u32,
}

impl ReferenceKey {
    /// The key spelled out, one setting a line; the hash is taken over exactly this text.
    /// The lumo version is part of it: a renderer change may change the converged image.
    pub fn text(&self) -> String {
        format!(
            "lumo reference v1\nlumo {}\nscene {}\nsize {}x{}\nspp {}\nmax_depth {}\n\
             rr_depth {}\nseed {}\n",
            env!("CARGO_PKG_VERSION"),
            self.scene_id,
            self.width,
            self.height,
            self.spp,
            self.max_depth,
            self.rr_depth,
            self.seed
        )
    }

    /// `SLUG-WxH-Nspp-HASH.exr`.
    pub fn file_name(&self) -> String {
        format!(
            "{}-{}x{}-{}spp-{:016x}.exr",
            self.slug,
            self.width,
            self.height,
            self.spp,
            fnv1a(self.text().as_bytes())
        )
    }
}

/// FNV-1a, 64 bit: stable across Rust releases and platforms (std's `DefaultHasher` is not
/// promised to be), which a cache that outlives one build needs.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The identity of a scene argument: a built-in name as it is, a file by canonical path,
/// size and modification time (so editing the file invalidates its references).
pub fn scene_identity(scene: &str, is_file: bool) -> Result<String> {
    if !is_file {
        return Ok(format!("builtin:{scene}"));
    }
    let path = Path::new(scene);
    let canonical = path
        .canonicalize()
        .with_context(|| format!("cannot resolve scene file {scene}"))?;
    let meta =
        std::fs::metadata(&canonical).with_context(|| format!("cannot read scene file {scene}"))?;
    let mtime = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map_or(0, |d| d.as_nanos());
    Ok(format!(
        "file:{} size={} mtime_ns={mtime}",
        canonical.display(),
        meta.len()
    ))
}

/// A file-name-safe version of a scene argument: its file stem, with anything but ASCII
/// letters, digits, `-` and `_` replaced by `_`.
pub fn slug(scene: &str) -> String {
    let stem = Path::new(scene)
        .file_stem()
        .map_or_else(|| scene.to_string(), |s| s.to_string_lossy().into_owned());
    let s: String = stem
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() {
        "scene".into()
    } else {
        s
    }
}

/// Where `key`'s reference lives in `dir`.
pub fn entry_path(dir: &Path, key: &ReferenceKey) -> PathBuf {
    dir.join(key.file_name())
}

/// The cached reference, if there is a readable one of the right size. An unreadable entry
/// (say, from a disk that filled up) is treated as absent and rendered again.
pub fn load(dir: &Path, key: &ReferenceKey) -> Option<Image> {
    let img = read_image(&entry_path(dir, key)).ok()?;
    (img.width == key.width && img.height == key.height && img.channels == 3).then_some(img)
}

/// Stores `image` as `key`'s reference (atomically, with the key text beside it) and returns
/// its path.
pub fn store(dir: &Path, key: &ReferenceKey, image: &Image) -> Result<PathBuf> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create the cache directory {}", dir.display()))?;
    let path = entry_path(dir, key);
    write_image_atomic(&path, image)?;
    write_bytes(&path.with_extension("txt"), key.text().as_bytes())?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key() -> ReferenceKey {
        ReferenceKey {
            scene_id: "builtin:cornell".into(),
            slug: "cornell".into(),
            width: 32,
            height: 32,
            spp: 16,
            max_depth: 8,
            rr_depth: 5,
            seed: 1,
        }
    }

    #[test]
    fn every_setting_changes_the_file_name() {
        let base = key().file_name();
        let variants = [
            ReferenceKey {
                scene_id: "builtin:atrium".into(),
                ..key()
            },
            ReferenceKey { width: 33, ..key() },
            ReferenceKey {
                height: 33,
                ..key()
            },
            ReferenceKey { spp: 17, ..key() },
            ReferenceKey {
                max_depth: 3,
                ..key()
            },
            ReferenceKey {
                rr_depth: 4,
                ..key()
            },
            ReferenceKey { seed: 2, ..key() },
        ];
        for v in variants {
            assert_ne!(v.file_name(), base, "{v:?}");
        }
        assert_eq!(key().file_name(), base);
        assert!(base.starts_with("cornell-32x32-16spp-"));
    }

    #[test]
    fn fnv1a_matches_the_published_test_vectors() {
        assert_eq!(fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
    }

    #[test]
    fn slugs_are_file_name_safe() {
        assert_eq!(slug("cornell-spheres"), "cornell-spheres");
        assert_eq!(slug("scenes/my scene.xml"), "my_scene");
    }

    #[test]
    fn store_then_load_round_trips_and_a_wrong_size_is_a_miss() {
        let dir = std::env::temp_dir().join(format!("lumo-cache-test-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        let img = Image::new(32, 32, 3, 0.25);
        assert!(load(&dir, &key()).is_none());
        let p = store(&dir, &key(), &img).unwrap();
        assert!(p.exists() && p.with_extension("txt").exists());
        assert_eq!(load(&dir, &key()), Some(img));
        let other = ReferenceKey { width: 16, ..key() };
        std::fs::copy(&p, entry_path(&dir, &other)).unwrap();
        assert!(load(&dir, &other).is_none());
        std::fs::remove_dir_all(&dir).ok();
    }
}
