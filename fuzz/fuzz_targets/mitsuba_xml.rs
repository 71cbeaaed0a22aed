//! Mitsuba XML loader on arbitrary input: it must return a scene or an error, never panic,
//! hang or allocate without bound. The in-memory entry point reads no other files.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use lumo_scene::load::{load_mitsuba_str, LoadOptions};

fuzz_target!(|data: &[u8]| {
    // The file loader rejects non-UTF-8 text before parsing; only text is worth exploring.
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = load_mitsuba_str(text, Path::new("fuzz/scene.xml"), &LoadOptions::default());
});
