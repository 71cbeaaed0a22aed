use std::io::Write;
use std::path::Path;

use crate::io::{format_err, io_err};
use crate::{Image, ImageError};

/// Reads a PFM (`PF` colour or `Pf` grey); rows are stored bottom to top.
pub(crate) fn read(path: &Path) -> Result<Image, ImageError> {
    let bytes = std::fs::read(path).map_err(|e| io_err(path, e))?;
    // Header: three whitespace-separated tokens, then exactly one whitespace byte.
    let mut tokens = Vec::new();
    let mut pos = 0;
    while tokens.len() < 4 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos {
            return Err(format_err(path, "truncated PFM header"));
        }
        tokens.push(String::from_utf8_lossy(&bytes[start..pos]).into_owned());
    }
    pos += 1;
    let channels = match tokens[0].as_str() {
        "PF" => 3,
        "Pf" => 1,
        other => {
            return Err(format_err(
                path,
                format!("not a PFM file (magic {other:?})"),
            ))
        }
    };
    let parse = |t: &str, what: &str| {
        t.parse::<usize>()
            .map_err(|_| format_err(path, format!("bad PFM {what} {t:?}")))
    };
    let width = parse(&tokens[1], "width")?;
    let height = parse(&tokens[2], "height")?;
    let scale: f32 = tokens[3]
        .parse()
        .map_err(|_| format_err(path, format!("bad PFM scale {:?}", tokens[3])))?;
    let little = scale < 0.0;
    let n = width * height * channels;
    let body = bytes.get(pos..).unwrap_or(&[]);
    if body.len() < n * 4 {
        return Err(format_err(
            path,
            format!(
                "truncated PFM data: {width}x{height}x{channels} needs {} bytes, found {}",
                n * 4,
                body.len()
            ),
        ));
    }
    let mut data = vec![0.0f32; n];
    let row = width * channels;
    for y in 0..height {
        let src_row = height - 1 - y;
        for i in 0..row {
            let o = (src_row * row + i) * 4;
            let b = [body[o], body[o + 1], body[o + 2], body[o + 3]];
            data[y * row + i] = if little {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            };
        }
    }
    Ok(Image::from_vec(width, height, channels, data))
}

/// Writes a little-endian PFM; images with 2 or 4+ channels are written as their first three.
pub(crate) fn write(path: &Path, image: &Image) -> Result<(), ImageError> {
    let img = if image.channels == 1 || image.channels == 3 {
        std::borrow::Cow::Borrowed(image)
    } else {
        std::borrow::Cow::Owned(image.to_channels(3))
    };
    let magic = if img.channels == 1 { "Pf" } else { "PF" };
    let mut out = Vec::with_capacity(img.data.len() * 4 + 32);
    out.extend_from_slice(format!("{magic}\n{} {}\n-1.0\n", img.width, img.height).as_bytes());
    let row = img.width * img.channels;
    for y in (0..img.height).rev() {
        for v in &img.data[y * row..(y + 1) * row] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    let mut f = std::fs::File::create(path).map_err(|e| io_err(path, e))?;
    f.write_all(&out).map_err(|e| io_err(path, e))
}
