use std::path::Path;

use crate::io::{format_err, io_err};
use crate::limits::check_image_size;
use crate::{linear_to_srgb, srgb_to_linear, Image, ImageError};

/// Reads an 8- or 16-bit PNG and converts it from sRGB to linear RGB (alpha dropped).
///
/// The header is checked before the pixel buffer is allocated: its size against the pixel
/// budget, and against what the file's `file_bytes` can possibly hold.
pub(crate) fn read(path: &Path, file_bytes: u64) -> Result<Image, ImageError> {
    let file = std::fs::File::open(path).map_err(|e| io_err(path, e))?;
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder
        .read_info()
        .map_err(|e| format_err(path, e.to_string()))?;
    let header = reader.info();
    let (w, h) = (header.width as usize, header.height as usize);
    check_image_size(path, w, h, file_bytes)?;
    let raw = min_raw_bytes(header.width, header.height, header.bits_per_pixel());
    if raw > file_bytes.saturating_mul(MAX_DEFLATE_RATIO) {
        return Err(format_err(
            path,
            format!(
                "truncated or corrupt: {w}x{h} pixels need at least {} bytes of compressed                  data, but the file has {file_bytes} bytes",
                raw.div_ceil(MAX_DEFLATE_RATIO)
            ),
        ));
    }
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| format_err(path, e.to_string()))?;
    let (w, h) = (info.width as usize, info.height as usize);
    let src_channels = info.color_type.samples();
    let sixteen = info.bit_depth == png::BitDepth::Sixteen;
    let value = |i: usize| -> f32 {
        if sixteen {
            u16::from_be_bytes([buf[2 * i], buf[2 * i + 1]]) as f32 / 65535.0
        } else {
            buf[i] as f32 / 255.0
        }
    };
    let mut data = Vec::with_capacity(w * h * 3);
    for p in 0..w * h {
        let base = p * src_channels;
        let rgb = if src_channels < 3 {
            [value(base); 3]
        } else {
            [value(base), value(base + 1), value(base + 2)]
        };
        data.extend(rgb.iter().map(|&c| srgb_to_linear(c)));
    }
    Ok(Image::from_vec(w, h, 3, data))
}

/// Deflate's best possible compression: one 258-byte match coded in two bits.
pub(crate) const MAX_DEFLATE_RATIO: u64 = 1032;

/// Bytes of filtered scanlines a PNG of this size decompresses to (without interlacing, which
/// only adds more): one filter byte and the packed samples per row.
pub(crate) fn min_raw_bytes(width: u32, height: u32, bits_per_pixel: usize) -> u64 {
    let row_bits = width as u64 * bits_per_pixel as u64;
    height as u64 * (1 + row_bits.div_ceil(8))
}

/// Writes an 8-bit sRGB PNG; values are clamped to [0,1], NaN becomes 0.
pub(crate) fn write(path: &Path, image: &Image) -> Result<(), ImageError> {
    let file = std::fs::File::create(path).map_err(|e| io_err(path, e))?;
    let mut encoder = png::Encoder::new(
        std::io::BufWriter::new(file),
        image.width as u32,
        image.height as u32,
    );
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut bytes = Vec::with_capacity(image.pixel_count() * 3);
    for y in 0..image.height {
        for x in 0..image.width {
            for c in image.rgb(x, y) {
                let c = if c.is_nan() { 0.0 } else { c };
                bytes.push((linear_to_srgb(c) * 255.0 + 0.5) as u8);
            }
        }
    }
    let mut writer = encoder
        .write_header()
        .map_err(|e| format_err(path, e.to_string()))?;
    writer
        .write_image_data(&bytes)
        .map_err(|e| format_err(path, e.to_string()))?;
    writer.finish().map_err(|e| format_err(path, e.to_string()))
}
