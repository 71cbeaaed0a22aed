//! A glTF file's buffers: the GLB binary chunk, `data:` URIs and files beside it.

use super::*;

/// Buffer contents: the GLB chunk, data URIs or files beside the glTF.
pub(super) fn load_buffers(
    path: &Path,
    doc: &gltf::Document,
    blob: Option<&[u8]>,
) -> Result<Vec<Vec<u8>>, LoadError> {
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let at = Location::item(path, format!("buffer {}", buffer.index()));
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob
                .ok_or_else(|| {
                    LoadError::invalid(
                        at.clone(),
                        "refers to the GLB binary chunk, which is missing",
                    )
                })?
                .to_vec(),
            gltf::buffer::Source::Uri(uri) => uri_bytes(path, uri, &at)?,
        };
        if data.len() < buffer.length() {
            return Err(LoadError::invalid(
                at,
                format!(
                    "holds {} bytes but declares byteLength {} (truncated file?)",
                    data.len(),
                    buffer.length()
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// Bytes of a `data:` URI or of a file relative to the glTF.
pub(super) fn uri_bytes(path: &Path, uri: &str, at: &Location) -> Result<Vec<u8>, LoadError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (meta, data) = rest
            .split_once(',')
            .ok_or_else(|| LoadError::invalid(at.clone(), "malformed data URI"))?;
        if !meta.ends_with(";base64") {
            return Err(LoadError::invalid(
                at.clone(),
                "only base64 data URIs are supported",
            ));
        }
        return base64_decode(data)
            .ok_or_else(|| LoadError::invalid(at.clone(), "data URI is not valid base64"));
    }
    let file = path
        .parent()
        .unwrap_or(Path::new(""))
        .join(percent_decode(uri));
    read_limited(&file, u64::MAX)
        .map_err(|e| LoadError::invalid(at.clone(), format!("cannot read {}: {e}", file.display())))
}

pub(super) fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            if let Ok(v) = u8::from_str_radix(&s[i + 1..i + 3], 16) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

pub(super) fn base64_decode(s: &str) -> Option<Vec<u8>> {
    let val = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            _ => return None,
        } as u32)
    };
    let clean: Vec<u8> = s
        .bytes()
        .filter(|c| !c.is_ascii_whitespace() && *c != b'=')
        .collect();
    let mut out = Vec::with_capacity(clean.len() * 3 / 4);
    for chunk in clean.chunks(4) {
        let mut acc = 0u32;
        for (i, &c) in chunk.iter().enumerate() {
            acc |= val(c)? << (18 - 6 * i);
        }
        let bytes = acc.to_be_bytes();
        match chunk.len() {
            4 => out.extend_from_slice(&bytes[1..4]),
            3 => out.extend_from_slice(&bytes[1..3]),
            2 => out.push(bytes[1]),
            _ => return None,
        }
    }
    Some(out)
}
