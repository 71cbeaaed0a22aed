//! Image planes for lumo: a float image type, OpenEXR / PFM / PNG reading and writing, and the
//! colour helpers (sRGB transfer, luminance) that renderer, filters and tools share.
#![forbid(unsafe_code)]

mod color;
mod error;
mod exr_io;
mod image;
mod io;
mod limits;
mod memory;
pub mod metrics;
mod pfm;
mod png_io;
pub mod temps;

pub use color::{linear_to_srgb, luminance, srgb_to_linear};
pub use error::{describe_io_error, ImageError};
pub use image::{rgb_of, Image};
pub use io::{read_image, sweep_stale_temps, temp_path, write_image, ImageFormat, MAX_NAME_BYTES};
pub use limits::{
    check_image_size, file_kind, max_image_pixels, regular_file_size, DECODE_BYTES_PER_PIXEL,
    DEFAULT_MAX_PIXELS, MAX_PIXELS_VAR,
};
pub use memory::{format_bytes, memory_available, parse_size, MEMORY_LIMIT_VAR};
