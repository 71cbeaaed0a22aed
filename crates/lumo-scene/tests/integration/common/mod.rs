//! Helpers shared by the loader tests.
#![allow(dead_code)]

pub mod builder;

use std::path::{Path, PathBuf};

use lumo_scene::load::{load_scene, LoadError, LoadOptions, LoadedScene};

/// The repository's scenes/ directory.
pub fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

/// A fresh temporary directory for one test.
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lumo-load-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes `contents` to `dir/name` and returns the path.
pub fn write(dir: &Path, name: &str, contents: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, contents).unwrap();
    p
}

/// An 8-bit PNG of `width` × `height` texels (`data` row by row) in colour type `color`.
pub fn png8(width: u32, height: u32, color: png::ColorType, data: &[u8]) -> Vec<u8> {
    let mut out = vec![];
    let mut enc = png::Encoder::new(&mut out, width, height);
    enc.set_color(color);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header().unwrap();
    w.write_image_data(data).unwrap();
    drop(w);
    out
}

/// Loads with default options.
pub fn load(path: &Path) -> Result<LoadedScene, LoadError> {
    load_scene(path, &LoadOptions::default())
}

/// Loads in strict mode.
pub fn load_strict(path: &Path) -> Result<LoadedScene, LoadError> {
    load_scene(
        path,
        &LoadOptions {
            strict: true,
            ..Default::default()
        },
    )
}

/// Wraps shapes and emitters in a minimal Mitsuba scene with a camera.
pub fn mitsuba(body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="45"/></sensor>
{body}
</scene>
"#
    )
}
