//! glTF loader on arbitrary bytes, as .gltf (JSON) or .glb (binary) by the first byte's low
//! bit: a scene or an error, never a panic, a hang or an unbounded allocation.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use lumo_scene::load::{load_scene, LoadOptions};

fuzz_target!(|data: &[u8]| {
    let Some((&first, rest)) = data.split_first() else {
        return;
    };
    common::set_small_pixel_budget();
    let name = if first & 1 == 0 { "input.gltf" } else { "input.glb" };
    let path = common::write_input(name, rest);
    let _ = load_scene(&path, &LoadOptions::default());
});
