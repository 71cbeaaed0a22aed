use std::path::Path;

use crate::io::{format_err, io_err};
use crate::{linear_to_srgb, srgb_to_linear, Image, ImageError};

/// Reads an 8- or 16-bit PNG and converts it from sRGB to linear RGB (alpha dropped).
pub(crate) fn read(path: &Path) -> Result<Image, ImageError> {
    let file = std::fs::File::open(path).map_err(|e| io_err(path, e))?;
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder
        .read_info()
        .map_err(|e| format_err(path, e.to_string()))?;
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
