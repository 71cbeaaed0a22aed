//! Texture and environment images: PNG, JPEG and Radiance HDR decoded here (from files or from
//! bytes embedded in glTF), EXR and PFM through lumo-image. Colour images are converted from
//! sRGB to linear unless the caller asks for raw values (data textures such as roughness).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use lumo_image::{read_image, srgb_to_linear, Image};

use super::{read_file, LoadError, Location};

/// Images already decoded, by (path, raw), so a texture used twice is read once.
#[derive(Default)]
pub(crate) struct ImageCache {
    images: HashMap<(PathBuf, bool), Arc<Image>>,
}

impl ImageCache {
    /// The image at `path`; `raw` keeps 8-bit values linear (no sRGB decoding).
    pub fn load(&mut self, path: &Path, raw: bool, at: &Location) -> Result<Arc<Image>, LoadError> {
        if let Some(img) = self.images.get(&(path.to_path_buf(), raw)) {
            return Ok(img.clone());
        }
        if !path.exists() {
            return Err(LoadError::invalid(
                at.clone(),
                format!("image {} does not exist", path.display()),
            ));
        }
        let img = Arc::new(load_image_file(path, raw, at)?);
        self.images.insert((path.to_path_buf(), raw), img.clone());
        Ok(img)
    }
}

/// Reads an image file of any supported kind (chosen by content, then extension).
pub(crate) fn load_image_file(path: &Path, raw: bool, at: &Location) -> Result<Image, LoadError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    if ext == "exr" || ext == "pfm" {
        // Float formats are linear already.
        return read_image(path)
            .map_err(|e| LoadError::invalid(at.clone(), format!("cannot read image: {e}")));
    }
    let bytes = read_file(path)?;
    decode_image(&bytes, raw).map_err(|reason| {
        LoadError::invalid(at.clone(), format!("image {}: {reason}", path.display()))
    })
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

/// 8- or 16-bit PNG of any colour type to RGB in [0,1] (alpha dropped), values not linearised.
fn decode_png(bytes: &[u8]) -> Result<Image, String> {
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder
        .read_info()
        .map_err(|e| format!("corrupt PNG: {e}"))?;
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| format!("corrupt PNG: {e}"))?;
    let channels = info.color_type.samples();
    let (w, h) = (info.width as usize, info.height as usize);
    let data = &buf[..info.buffer_size()];
    Ok(to_rgb(w, h, channels, data))
}

fn decode_jpeg(bytes: &[u8]) -> Result<Image, String> {
    use zune_jpeg::zune_core::{colorspace::ColorSpace, options::DecoderOptions};
    let options = DecoderOptions::default().jpeg_set_out_colorspace(ColorSpace::RGB);
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(bytes, options);
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
    if w == 0 || h == 0 || w.saturating_mul(h) > 1 << 28 {
        return Err(format!("HDR: unreasonable size {w}x{h}"));
    }
    let data = &bytes[pos..];
    let mut at = 0usize;
    let mut next = || -> Result<u8, String> {
        let b = *data.get(at).ok_or("HDR: truncated pixel data")?;
        at += 1;
        Ok(b)
    };
    let mut out = Vec::with_capacity(w * h * 3);
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
            scan[0] = head;
            for px in scan.iter_mut().skip(1) {
                *px = [next()?, next()?, next()?, next()?];
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
