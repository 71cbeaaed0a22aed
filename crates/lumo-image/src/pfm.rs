use std::io::{Read, Write};
use std::path::Path;

use crate::io::{format_err, io_err};
use crate::limits::check_image_size;
use crate::{Image, ImageError};

/// Longest header token accepted: magic, width, height and scale are a few characters each.
const MAX_TOKEN: usize = 64;

/// Reads a PFM (`PF` colour or `Pf` grey); rows are stored bottom to top.
///
/// The header is read and checked (size against the pixel budget, data against the file's
/// `file_bytes`) before the pixels are allocated and read.
pub(crate) fn read(path: &Path, file_bytes: u64) -> Result<Image, ImageError> {
    let file = std::fs::File::open(path).map_err(|e| io_err(path, e))?;
    let mut reader = std::io::BufReader::new(file);
    // Header: three whitespace-separated tokens, then exactly one whitespace byte.
    let mut tokens = Vec::new();
    let mut header_len = 0u64;
    let mut byte = || -> Result<Option<u8>, ImageError> {
        let mut b = [0u8; 1];
        match reader.read(&mut b).map_err(|e| io_err(path, e))? {
            0 => Ok(None),
            _ => {
                header_len += 1;
                Ok(Some(b[0]))
            }
        }
    };
    let mut next = byte()?;
    while tokens.len() < 4 {
        while next.is_some_and(|b| b.is_ascii_whitespace()) {
            next = byte()?;
        }
        let mut token = Vec::new();
        while let Some(b) = next.filter(|b| !b.is_ascii_whitespace()) {
            if token.len() == MAX_TOKEN {
                return Err(format_err(path, "not a PFM file (header token too long)"));
            }
            token.push(b);
            next = byte()?;
        }
        if token.is_empty() {
            return Err(format_err(path, "truncated PFM header"));
        }
        tokens.push(String::from_utf8_lossy(&token).into_owned());
    }
    // The single whitespace byte ending the header was read (and counted) with the token.
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
    // Its sign is the byte order; zero or NaN says neither, and reading on would turn the
    // pixels into garbage (a zero scale once decoded as big-endian values near ±3e38).
    if !(scale.is_finite() && scale != 0.0) {
        return Err(format_err(
            path,
            format!(
                "PFM scale {:?} must be a non-zero finite number (negative: little-endian \
                 pixels, positive: big-endian; most writers use -1)",
                tokens[3]
            ),
        ));
    }
    let little = scale < 0.0;
    let n = width
        .checked_mul(height)
        .and_then(|n| n.checked_mul(channels))
        .filter(|n| n.checked_mul(4).is_some())
        .ok_or_else(|| format_err(path, format!("PFM size {width}x{height} is too large")))?;
    check_image_size(path, width, height, file_bytes)?;
    let mut body = file_bytes.saturating_sub(header_len);
    // A header written with CRLF line ends (Windows tools) ends in "\r\n": the "\r" ended the
    // scale token, and the "\n" is not pixel data (read as data, every value was shifted by a
    // byte: garbage). The file's size tells it from a first data byte that happens to be 0x0A.
    if next == Some(b'\r') && body == n as u64 * 4 + 1 {
        let mut lf = [0u8; 1];
        reader.read_exact(&mut lf).map_err(|e| io_err(path, e))?;
        if lf[0] != b'\n' {
            return Err(format_err(
                path,
                "PFM header ends in \\r without \\n, and the data is one byte too long",
            ));
        }
        body -= 1;
    }
    if body < n as u64 * 4 {
        return Err(format_err(
            path,
            format!(
                "truncated PFM data: {width}x{height}x{channels} needs {} bytes, found {body}",
                n * 4,
            ),
        ));
    }
    let mut raw = vec![0u8; n * 4];
    reader.read_exact(&mut raw).map_err(|e| io_err(path, e))?;
    let mut data = vec![0.0f32; n];
    let row = width * channels;
    if row > 0 {
        // Rows bottom to top; the byte order decided once, outside the loops, so each row is
        // a plain (vectorised) conversion.
        let src_rows = raw.chunks_exact(row * 4).rev();
        for (dst, src) in data.chunks_exact_mut(row).zip(src_rows) {
            let bytes = src.chunks_exact(4);
            if little {
                for (d, b) in dst.iter_mut().zip(bytes) {
                    *d = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                }
            } else {
                for (d, b) in dst.iter_mut().zip(bytes) {
                    *d = f32::from_be_bytes([b[0], b[1], b[2], b[3]]);
                }
            }
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
    let mut out = format!("{magic}\n{} {}\n-1.0\n", img.width, img.height).into_bytes();
    let header = out.len();
    let row = img.width * img.channels;
    out.resize(header + img.data.len() * 4, 0);
    if row > 0 {
        // Rows bottom to top, each a plain (vectorised) conversion into the sized buffer.
        let dst_rows = out[header..].chunks_exact_mut(row * 4);
        for (dst, src) in dst_rows.zip(img.data.chunks_exact(row).rev()) {
            for (d, v) in dst.chunks_exact_mut(4).zip(src) {
                d.copy_from_slice(&v.to_le_bytes());
            }
        }
    }
    let mut f = std::fs::File::create(path).map_err(|e| io_err(path, e))?;
    f.write_all(&out).map_err(|e| io_err(path, e))
}
