//! OBJ loader on arbitrary bytes (through a file, as it has no in-memory entry point): a scene
//! or an error, never a panic, a hang or an unbounded allocation. `mtllib`s and textures it
//! names resolve in a scratch directory that holds only the input.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use lumo_scene::load::{load_scene, LoadOptions};

fuzz_target!(|data: &[u8]| {
    common::set_small_pixel_budget();
    let path = common::write_input("input.obj", data);
    let _ = load_scene(&path, &LoadOptions::default());
});
