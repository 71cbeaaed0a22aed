//! Texture and environment images: PNG, JPEG and Radiance HDR decoded here (from files or from
//! bytes embedded in glTF), EXR and PFM through lumo-image. Colour images are converted from
//! sRGB to linear unless the caller asks for raw values (data textures such as roughness).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use lumo_image::{max_image_pixels, read_image, srgb_to_linear, Image, MAX_PIXELS_VAR};

use super::{read_limited, LoadError, Location, Warning};

/// Images already decoded, by (path, raw), so a texture used twice is read once; and the
/// warnings about their values, for the loader to pass on to its diagnostics (the callers
/// that hold both the cache and the diagnostics flush them with [`ImageCache::take_warnings`]).
#[derive(Default)]
pub(crate) struct ImageCache {
    images: HashMap<(PathBuf, bool), Arc<Image>>,
    warnings: Vec<Warning>,
}

impl ImageCache {
    /// The image at `path`; `raw` keeps 8-bit values linear (no sRGB decoding). Its values are
    /// checked as radiance or reflectance: all NaN is an error, NaN, infinite and negative
    /// values are read as 0 with a warning (see [`ImageCache::take_warnings`]).
    pub fn load(&mut self, path: &Path, raw: bool, at: &Location) -> Result<Arc<Image>, LoadError> {
        if let Some(img) = self.images.get(&(path.to_path_buf(), raw)) {
            return Ok(img.clone());
        }
        let mut img = load_image_file(path, raw, at)?;
        if let Some(message) = check_values(&mut img, path, at)? {
            self.warnings.push(Warning {
                at: at.clone(),
                message,
            });
        }
        let img = Arc::new(img);
        self.images.insert((path.to_path_buf(), raw), img.clone());
        Ok(img)
    }

    /// The warnings collected so far (emptied).
    pub fn take_warnings(&mut self) -> Vec<Warning> {
        std::mem::take(&mut self.warnings)
    }
}

/// Checks an image's values as light or reflectance, which cannot be negative or NaN: an image
/// with no finite value is an error; otherwise non-finite and negative values become 0 and the
/// returned message says how many there were.
pub(crate) fn check_values(
    img: &mut Image,
    path: &Path,
    at: &Location,
) -> Result<Option<String>, LoadError> {
    let total = img.data.len();
    let non_finite = img.non_finite_count();
    if non_finite == total {
        return Err(LoadError::invalid(
            at.clone(),
            format!(
                "image {}: every value is NaN or infinite; re-export the image",
                path.display()
            ),
        ));
    }
    let negative = img.data.iter().filter(|v| **v < 0.0).count();
    if non_finite == 0 && negative == 0 {
        return Ok(None);
    }
    for v in &mut img.data {
        if !v.is_finite() || *v < 0.0 {
            *v = 0.0;
        }
    }
    let mut what = Vec::new();
    if non_finite > 0 {
        what.push(format!("{non_finite} NaN or infinite"));
    }
    if negative > 0 {
        what.push(format!("{negative} negative"));
    }
    Ok(Some(format!(
        "image {}: {} of its {total} values (light and reflectance cannot be negative or NaN); \
         they are read as 0",
        path.display(),
        what.join(" and ")
    )))
}

/// Reads an image file of any supported kind (chosen by content, then extension); an error
/// at `at` naming the file otherwise.
pub(crate) fn load_image_file(path: &Path, raw: bool, at: &Location) -> Result<Image, LoadError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    if ext == "exr" || ext == "pfm" {
        // Float formats are linear already. The error names the file and says what is wrong.
        return read_image(path).map_err(|e| LoadError::invalid(at.clone(), format!("image {e}")));
    }
    let bytes = read_limited(path, u64::MAX)
        .map_err(|e| LoadError::invalid(at.clone(), format!("image {}: {e}", path.display())))?;
    decode_image(&bytes, raw).map_err(|reason| {
        LoadError::invalid(at.clone(), format!("image {}: {reason}", path.display()))
    })
}

/// Errors unless a `w`×`h` image decoded from `bytes` bytes has pixels and fits the pixel
/// budget ([`max_image_pixels`]); checked on the header, before any pixel is allocated.
fn check_size(w: usize, h: usize, bytes: usize) -> Result<(), String> {
    if w == 0 || h == 0 {
        return Err(format!(
            "the image is empty ({w}x{h} pixels); save it with at least one pixel"
        ));
    }
    let limit = max_image_pixels();
    if (w as u64).saturating_mul(h as u64) > limit {
        return Err(format!(
            "{w}x{h} pixels (in {bytes} bytes) is over the image limit of {limit} pixels; if the \
             image is genuine, raise the limit with {MAX_PIXELS_VAR}=PIXELS"
        ));
    }
    // The decoder's buffer and the float image, against what this process may allocate (as
    // lumo-image's readers check EXR, PFM and PNG).
    let need = (w as u64 * h as u64).saturating_mul(lumo_image::DECODE_BYTES_PER_PIXEL);
    if let Some(available) = lumo_image::memory_available().filter(|&a| need > a) {
        return Err(format!(
            "decoding {w}x{h} pixels needs about {} of memory, but only {} is available",
            lumo_image::format_bytes(need),
            lumo_image::format_bytes(available)
        ));
    }
    Ok(())
}

/// Decodes PNG, JPEG or Radiance HDR bytes (by their signature) into a linear RGB image.
pub(crate) fn decode_image(bytes: &[u8], raw: bool) -> Result<Image, String> {
    let mut img = if bytes.starts_with(b"\x89PNG") {
        decode_png(bytes)?
    } else if bytes.starts_with(&[0xFF, 0xD8]) {
        decode_jpeg(bytes)?
    } else if bytes.starts_with(b"#?") {
        // HDR pixels are linear; nothing to undo.
        return decode_hdr(bytes);
    } else {
        return Err(
            "not a PNG, JPEG or Radiance HDR image (EXR and PFM are read from files)".into(),
        );
    };
    if !raw {
        for v in &mut img.data {
            *v = srgb_to_linear(*v);
        }
    }
    Ok(img)
}

/// Deflate's best possible compression: one 258-byte match coded in two bits. A PNG whose
/// header asks for more than this many times its size in pixel data is truncated or corrupt.
const MAX_DEFLATE_RATIO: u64 = 1032;

/// 8- or 16-bit PNG of any colour type to RGB in [0,1] (alpha dropped), values not linearised.
fn decode_png(bytes: &[u8]) -> Result<Image, String> {
    let (w, h, channels, data) = png_samples(bytes)?;
    Ok(to_rgb(w, h, channels, &data))
}

/// The alpha channel of an image's bytes as a one-channel image in [0, 1] (glTF's base colour
/// alpha); `None` for images without one (JPEG, HDR, PNG without alpha).
pub(crate) fn decode_alpha(bytes: &[u8]) -> Result<Option<Image>, String> {
    if !bytes.starts_with(b"\x89PNG") {
        return Ok(None);
    }
    let (w, h, channels, data) = png_samples(bytes)?;
    if channels != 2 && channels != 4 {
        return Ok(None);
    }
    let alpha = data
        .chunks_exact(channels)
        .take(w * h)
        .map(|px| px[channels - 1] as f32 / 255.0)
        .collect::<Vec<_>>();
    if alpha.len() != w * h {
        return Err("corrupt PNG: pixel data does not match its size".into());
    }
    Ok(Some(Image::from_vec(w, h, 1, alpha)))
}

/// A PNG's 8-bit interleaved samples: (width, height, channels, samples).
fn png_samples(bytes: &[u8]) -> Result<(usize, usize, usize, Vec<u8>), String> {
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder
        .read_info()
        .map_err(|e| format!("corrupt PNG: {e}"))?;
    let header = reader.info();
    check_size(header.width as usize, header.height as usize, bytes.len())?;
    // Filtered scanlines: a filter byte and the packed samples per row.
    let row_bits = header.width as u64 * header.bits_per_pixel() as u64;
    let raw_bytes = header.height as u64 * (1 + row_bits.div_ceil(8));
    if raw_bytes > bytes.len() as u64 * MAX_DEFLATE_RATIO {
        return Err(format!(
            "truncated or corrupt PNG: {}x{} pixels need more compressed data than its {} bytes",
            header.width,
            header.height,
            bytes.len()
        ));
    }
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| format!("corrupt PNG: {e}"))?;
    let channels = info.color_type.samples();
    let (w, h) = (info.width as usize, info.height as usize);
    buf.truncate(info.buffer_size());
    Ok((w, h, channels, buf))
}

/// Baseline or progressive JPEG to RGB in [0,1], values not linearised.
fn decode_jpeg(bytes: &[u8]) -> Result<Image, String> {
    use zune_jpeg::zune_core::{colorspace::ColorSpace, options::DecoderOptions};
    // zune's own size limit (16384 a side) is replaced by lumo's pixel budget, checked below.
    let options = DecoderOptions::default()
        .jpeg_set_out_colorspace(ColorSpace::RGB)
        .set_max_width(usize::from(u16::MAX))
        .set_max_height(usize::from(u16::MAX));
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(bytes, options);
    decoder
        .decode_headers()
        .map_err(|e| format!("corrupt JPEG: {e:?}"))?;
    let (w, h) = decoder
        .dimensions()
        .ok_or("corrupt JPEG: no size in its header")?;
    check_size(w, h, bytes.len())?;
    let data = decoder
        .decode()
        .map_err(|e| format!("corrupt JPEG: {e:?}"))?;
    let info = decoder.info().ok_or("corrupt JPEG: no header")?;
    let (w, h) = (info.width as usize, info.height as usize);
    if data.len() != w * h * 3 {
        return Err("corrupt JPEG: pixel data does not match its size".into());
    }
    Ok(to_rgb(w, h, 3, &data))
}

/// Interleaved 8-bit samples to an RGB float image (grey broadcast, alpha dropped).
fn to_rgb(w: usize, h: usize, channels: usize, data: &[u8]) -> Image {
    let mut out = Vec::with_capacity(w * h * 3);
    for px in data.chunks_exact(channels.max(1)).take(w * h) {
        let rgb = if channels < 3 {
            [px[0]; 3]
        } else {
            [px[0], px[1], px[2]]
        };
        out.extend(rgb.iter().map(|&c| c as f32 / 255.0));
    }
    out.resize(w * h * 3, 0.0);
    Image::from_vec(w, h, 3, out)
}

/// Radiance RGBE (.hdr), flat or run-length encoded scanlines, `-Y h +X w` orientation.
fn decode_hdr(bytes: &[u8]) -> Result<Image, String> {
    let mut pos = 0;
    let mut line = || -> Option<&[u8]> {
        let start = pos;
        let end = start + bytes.get(start..)?.iter().position(|&b| b == b'\n')?;
        pos = end + 1;
        Some(&bytes[start..end])
    };
    let mut resolution = None;
    while let Some(l) = line() {
        if l.is_empty() {
            resolution = line();
            break;
        }
        if let Some(format) = l.strip_prefix(b"FORMAT=") {
            if format != b"32-bit_rle_rgbe" {
                return Err("HDR: only the 32-bit_rle_rgbe format is supported".into());
            }
        }
    }
    let res = resolution.ok_or("HDR: truncated header")?;
    let res = std::str::from_utf8(res).map_err(|_| "HDR: bad resolution line")?;
    let parts: Vec<&str> = res.split_whitespace().collect();
    let (h, w) = match parts.as_slice() {
        ["-Y", h, "+X", w] => (h.parse::<usize>(), w.parse::<usize>()),
        _ => {
            return Err(format!(
                "HDR: unsupported orientation {res:?} (need -Y h +X w)"
            ))
        }
    };
    let (h, w) = (
        h.map_err(|_| "HDR: bad height")?,
        w.map_err(|_| "HDR: bad width")?,
    );
    check_size(w, h, bytes.len())?;
    let data = &bytes[pos..];
    let mut at = 0usize;
    let mut next = || -> Result<u8, String> {
        let b = *data.get(at).ok_or("HDR: truncated pixel data")?;
        at += 1;
        Ok(b)
    };
    // Reserve no more than the data can hold (a run-length coded pixel takes at least 4 × 2
    // bytes per 127 pixels), so that a short file with a big header allocates little before
    // it runs out of data.
    let mut out = Vec::with_capacity((w * h).min(data.len().saturating_mul(16)) * 3);
    let mut scan = vec![[0u8; 4]; w];
    for _ in 0..h {
        let head = [next()?, next()?, next()?, next()?];
        if (8..0x8000).contains(&w) && head[0] == 2 && head[1] == 2 && head[2] & 0x80 == 0 {
            // New-style RLE: each of the four components run-length coded separately.
            if ((head[2] as usize) << 8 | head[3] as usize) != w {
                return Err("HDR: scanline width mismatch".into());
            }
            for c in 0..4 {
                let mut x = 0;
                while x < w {
                    let count = next()? as usize;
                    if count > 128 {
                        let n = count - 128;
                        let v = next()?;
                        if x + n > w {
                            return Err("HDR: run overflows scanline".into());
                        }
                        for px in &mut scan[x..x + n] {
                            px[c] = v;
                        }
                        x += n;
                    } else {
                        if count == 0 || x + count > w {
                            return Err("HDR: bad run length".into());
                        }
                        for px in &mut scan[x..x + count] {
                            px[c] = next()?;
                        }
                        x += count;
                    }
                }
            }
        } else {
            // Flat pixels, or old-style RLE: a pixel (1, 1, 1, n) repeats the one before it n
            // times, n shifted left by 8 more bits for each run that directly follows a run.
            // Read as plain pixels, such runs turned into near-black texels and shifted the
            // rest of the image.
            let (mut x, mut shift, mut px) = (0usize, 0u32, head);
            loop {
                if px[..3] == [1, 1, 1] {
                    let n = (px[3] as usize).checked_shl(shift).unwrap_or(usize::MAX);
                    if x == 0 || n > w - x {
                        return Err("HDR: old-style run outside its scanline".into());
                    }
                    let prev = scan[x - 1];
                    scan[x..x + n].fill(prev);
                    x += n;
                    shift = (shift + 8).min(usize::BITS);
                } else {
                    scan[x] = px;
                    x += 1;
                    shift = 0;
                }
                if x == w {
                    break;
                }
                px = [next()?, next()?, next()?, next()?];
            }
        }
        for px in &scan {
            let f = if px[3] == 0 {
                0.0
            } else {
                (px[3] as f32 - 136.0).exp2()
            };
            out.extend([px[0] as f32 * f, px[1] as f32 * f, px[2] as f32 * f]);
        }
    }
    Ok(Image::from_vec(w, h, 3, out))
}

#[cfg(test)]
mod tests {
    use super::decode_hdr;

    fn hdr(w: usize, pixels: &[[u8; 4]]) -> Vec<u8> {
        let mut b = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X {w}\n").into_bytes();
        b.extend(pixels.iter().flatten());
        b
    }

    /// Old-style RLE (a pixel (1, 1, 1, n) repeats the previous one; a run right after a run
    /// counts 256 times more) was read as plain pixels: near-black texels, the rest shifted.
    #[test]
    fn old_style_runs_repeat_the_previous_pixel() {
        let a = [128, 64, 32, 129]; // (1, 0.5, 0.25): mantissas × 2^(129 − 136)
        let img = decode_hdr(&hdr(4, &[a, [1, 1, 1, 3]])).unwrap();
        assert_eq!(img.data, [1.0, 0.5, 0.25].repeat(4));
        // 1 + 1 + (1 << 8) pixels: the second run is shifted.
        let img = decode_hdr(&hdr(258, &[a, [1, 1, 1, 1], [1, 1, 1, 1]])).unwrap();
        assert_eq!(img.data, [1.0, 0.5, 0.25].repeat(258));
        // A run with nothing before it, or past the scanline, is an error.
        assert!(decode_hdr(&hdr(4, &[[1, 1, 1, 3], a])).is_err());
        assert!(decode_hdr(&hdr(4, &[a, [1, 1, 1, 9]])).is_err());
    }
}
