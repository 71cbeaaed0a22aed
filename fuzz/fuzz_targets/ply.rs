//! PLY reader on arbitrary bytes: a mesh or an error, never a panic, hang or huge allocation.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use lumo_scene::load::{load_ply_bytes, LoadOptions};

fuzz_target!(|data: &[u8]| {
    let _ = load_ply_bytes(data, Path::new("fuzz/mesh.ply"), &LoadOptions::default());
});
