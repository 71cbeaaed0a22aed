//! The PFM reader of lumo-image on arbitrary bytes: an image or an error, never a panic,
//! a hang or an allocation beyond the pixel budget and the file's size.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    common::set_small_pixel_budget();
    let path = common::write_input("input.pfm", data);
    if let Ok(img) = lumo_image::read_image(&path) {
        assert_eq!(img.data.len(), img.width * img.height * img.channels);
        assert!(img.width > 0 && img.height > 0);
    }
});
