//! Stanford PLY: ASCII and binary (little and big endian); positions, normals, texture
//! coordinates and faces (polygons fan-triangulated). Other elements are skipped.

use std::path::Path;

use glam::{Vec2, Vec3};
use lumo_image::srgb_to_linear;

use super::check::check_mesh;
use super::{read_file, Diagnostics, LoadError, Location};
use crate::{Material, Mesh};

/// Reads `path` for a lone-mesh scene.
pub(crate) fn load(
    path: &Path,
    diag: &mut Diagnostics,
) -> Result<(Vec<Mesh>, Vec<Material>), LoadError> {
    Ok((vec![read(path, diag)?], vec![]))
}

/// Reads a PLY file into one mesh (material 0).
pub(crate) fn read(path: &Path, diag: &mut Diagnostics) -> Result<Mesh, LoadError> {
    let bytes = read_file(path)?;
    read_bytes(path, &bytes, diag)
}

/// Reads PLY `bytes` (from the file `path`, named in messages and in the mesh name) into one
/// mesh (material 0).
pub(crate) fn read_bytes(
    path: &Path,
    bytes: &[u8],
    diag: &mut Diagnostics,
) -> Result<Mesh, LoadError> {
    let mut mesh = parse(path, bytes, diag)?;
    mesh.name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "ply".into());
    check_mesh(&mut mesh, &Location::file(path), diag)?;
    Ok(mesh)
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }
}

#[derive(Debug)]
struct Property {
    name: String,
    /// `Some(count type)` for list properties.
    list: Option<Scalar>,
    ty: Scalar,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

#[derive(Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Little,
    Big,
}

/// The header: format, elements and the byte offset where data starts.
fn header(path: &Path, bytes: &[u8]) -> Result<(Format, Vec<Element>, usize, usize), LoadError> {
    let bad = |line: usize, msg: String| LoadError::invalid(Location::line(path, line), msg);
    if !bytes.starts_with(b"ply") {
        return Err(bad(1, "not a PLY file (it must start with \"ply\")".into()));
    }
    let mut pos = 0;
    let mut line_no = 0;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(end) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(bad(
                line_no + 1,
                "truncated header: no end_header line".into(),
            ));
        };
        let line = String::from_utf8_lossy(&bytes[pos..pos + end])
            .trim()
            .to_string();
        pos += end + 1;
        line_no += 1;
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["ply"] | [] => {}
            ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, _version] => {
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Little,
                    "binary_big_endian" => Format::Big,
                    other => return Err(bad(line_no, format!("unknown PLY format {other:?}"))),
                })
            }
            ["element", name, count] => {
                let count = count
                    .parse::<usize>()
                    .map_err(|_| bad(line_no, format!("element {name}: bad count {count:?}")))?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: vec![],
                });
            }
            ["property", "list", ct, ty, name] => {
                let (Some(ct), Some(ty)) = (Scalar::parse(ct), Scalar::parse(ty)) else {
                    return Err(bad(line_no, format!("unknown type in {line:?}")));
                };
                let el = elements
                    .last_mut()
                    .ok_or_else(|| bad(line_no, "property before any element".into()))?;
                el.props.push(Property {
                    name: name.to_string(),
                    list: Some(ct),
                    ty,
                });
            }
            ["property", ty, name] => {
                let ty = Scalar::parse(ty)
                    .ok_or_else(|| bad(line_no, format!("unknown type {ty:?}")))?;
                let el = elements
                    .last_mut()
                    .ok_or_else(|| bad(line_no, "property before any element".into()))?;
                el.props.push(Property {
                    name: name.to_string(),
                    list: None,
                    ty,
                });
            }
            ["end_header"] => break,
            _ => return Err(bad(line_no, format!("unexpected header line {line:?}"))),
        }
    }
    let format = format.ok_or_else(|| bad(line_no, "header has no format line".into()))?;
    Ok((format, elements, pos, line_no))
}

/// Reads scalars from the body in any of the three encodings.
struct Body<'b> {
    bytes: &'b [u8],
    pos: usize,
    format: Format,
    /// ASCII: current line number (for messages).
    line: usize,
    tokens: std::vec::IntoIter<&'b str>,
}

impl<'b> Body<'b> {
    fn value(&mut self, ty: Scalar) -> Option<f64> {
        match self.format {
            Format::Ascii => loop {
                if let Some(t) = self.tokens.next() {
                    return t.parse::<f64>().ok();
                }
                if self.pos >= self.bytes.len() {
                    return None;
                }
                let rest = &self.bytes[self.pos..];
                let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
                let line = std::str::from_utf8(&rest[..end]).ok()?;
                self.pos += end + 1;
                self.line += 1;
                self.tokens = line.split_whitespace().collect::<Vec<_>>().into_iter();
            },
            Format::Little | Format::Big => {
                let n = ty.size();
                let raw = self.bytes.get(self.pos..self.pos + n)?;
                self.pos += n;
                let mut buf = [0u8; 8];
                buf[..n].copy_from_slice(raw);
                if self.format == Format::Big {
                    buf[..n].reverse();
                }
                Some(match ty {
                    Scalar::I8 => buf[0] as i8 as f64,
                    Scalar::U8 => buf[0] as f64,
                    Scalar::I16 => i16::from_le_bytes([buf[0], buf[1]]) as f64,
                    Scalar::U16 => u16::from_le_bytes([buf[0], buf[1]]) as f64,
                    Scalar::I32 => i32::from_le_bytes([buf[0], buf[1], buf[2], buf[3]]) as f64,
                    Scalar::U32 => u32::from_le_bytes([buf[0], buf[1], buf[2], buf[3]]) as f64,
                    Scalar::F32 => f32::from_le_bytes([buf[0], buf[1], buf[2], buf[3]]) as f64,
                    Scalar::F64 => f64::from_le_bytes(buf),
                })
            }
        }
    }
}

fn parse(path: &Path, bytes: &[u8], diag: &mut Diagnostics) -> Result<Mesh, LoadError> {
    let (format, elements, start, header_lines) = header(path, bytes)?;
    let mut body = Body {
        bytes,
        pos: start,
        format,
        line: header_lines,
        tokens: Vec::new().into_iter(),
    };
    let mut mesh = Mesh::default();
    let mut skipped_faces = 0usize;
    for el in &elements {
        // Every item takes at least one byte (binary) or one character plus a separator
        // (ASCII), so a count beyond the file size is corrupt: refuse before allocating.
        let min_item = if format == Format::Ascii {
            2
        } else {
            el.props
                .iter()
                .map(|p| p.list.unwrap_or(p.ty).size())
                .sum::<usize>()
                .max(1)
        };
        if el.count.saturating_mul(min_item) > bytes.len() - start.min(bytes.len()) + 1 {
            return Err(LoadError::invalid(
                Location::item(path, format!("element {}", el.name)),
                format!(
                    "the header declares {} {} items, more than the file can hold (truncated or corrupt)",
                    el.count, el.name
                ),
            ));
        }
        let is_vertex = el.name == "vertex";
        let is_face = el.name == "face";
        let find = |names: &[&str]| {
            el.props
                .iter()
                .position(|p| names.contains(&p.name.as_str()) && p.list.is_none())
        };
        let (ix, iy, iz) = (find(&["x"]), find(&["y"]), find(&["z"]));
        let (inx, iny, inz) = (find(&["nx"]), find(&["ny"]), find(&["nz"]));
        let iu = find(&["u", "s", "texture_u", "texture_s"]);
        let iv = find(&["v", "t", "texture_v", "texture_t"]);
        let rgb = [
            find(&["red", "r", "diffuse_red"]),
            find(&["green", "g", "diffuse_green"]),
            find(&["blue", "b", "diffuse_blue"]),
        ];
        let has_rgb = rgb.iter().all(Option::is_some);
        if is_vertex && (ix.is_none() || iy.is_none() || iz.is_none()) {
            return Err(LoadError::invalid(
                Location::item(path, "element vertex"),
                "vertices need x, y and z properties",
            ));
        }
        let has_n = inx.is_some() && iny.is_some() && inz.is_some();
        let has_uv = iu.is_some() && iv.is_some();
        let list_index = el.props.iter().position(|p| {
            p.list.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index")
        });
        let mut values = vec![0.0f64; el.props.len()];
        let mut list = Vec::new();
        for item in 0..el.count {
            let truncated = |body: &Body| {
                let at = if format == Format::Ascii {
                    Location::line(path, body.line.max(header_lines + 1))
                } else {
                    Location::item(path, format!("element {} item {item}", el.name))
                };
                LoadError::invalid(
                    at,
                    format!(
                        "truncated or malformed data in {} {item} of {} (the header promises {})",
                        el.name, el.count, el.count
                    ),
                )
            };
            for (pi, p) in el.props.iter().enumerate() {
                match p.list {
                    None => values[pi] = body.value(p.ty).ok_or_else(|| truncated(&body))?,
                    Some(ct) => {
                        let n = body.value(ct).ok_or_else(|| truncated(&body))?;
                        if !(0.0..=1e6).contains(&n) || n.fract() != 0.0 {
                            return Err(truncated(&body));
                        }
                        let keep = Some(pi) == list_index && is_face;
                        if keep {
                            list.clear();
                        }
                        for _ in 0..n as usize {
                            let v = body.value(p.ty).ok_or_else(|| truncated(&body))?;
                            if keep {
                                list.push(v);
                            }
                        }
                    }
                }
            }
            // An ASCII item is one line: values left on it were read as the next item's, and
            // the error came later and elsewhere ("no faces with 3 or more vertices").
            if format == Format::Ascii && !body.tokens.as_slice().is_empty() {
                return Err(LoadError::invalid(
                    Location::line(path, body.line),
                    format!(
                        "{} {item} has {} value(s) more than the header's {} properties; \
                         give each {} exactly its properties, one per line",
                        el.name,
                        body.tokens.as_slice().len(),
                        el.props.len(),
                        el.name
                    ),
                ));
            }
            if is_vertex {
                let get = |i: Option<usize>| i.map_or(0.0, |i| values[i] as f32);
                mesh.positions.push(Vec3::new(get(ix), get(iy), get(iz)));
                if has_n {
                    mesh.normals.push(Vec3::new(get(inx), get(iny), get(inz)));
                }
                if has_uv {
                    mesh.uvs.push(Vec2::new(get(iu), get(iv)));
                }
                if has_rgb {
                    // 8- and 16-bit colours are display (sRGB) values; floats are taken as linear.
                    let c = rgb.map(|i| match i.map(|i| el.props[i].ty) {
                        Some(Scalar::U8) => srgb_to_linear(get(i) / 255.0),
                        Some(Scalar::U16) => srgb_to_linear(get(i) / 65535.0),
                        _ => get(i),
                    });
                    mesh.colors.push(Vec3::from(c));
                }
            } else if is_face && list_index.is_some() {
                if list.len() < 3 {
                    skipped_faces += 1;
                    continue;
                }
                for k in 1..list.len() - 1 {
                    let tri = [list[0], list[k], list[k + 1]];
                    if tri.iter().any(|&i| i < 0.0 || i >= u32::MAX as f64) {
                        return Err(LoadError::invalid(
                            Location::item(path, format!("face {item}")),
                            format!("negative or huge vertex index in {tri:?}"),
                        ));
                    }
                    mesh.indices.push(tri.map(|i| i as u32));
                }
            }
        }
    }
    if !elements.iter().any(|e| e.name == "face") || mesh.indices.is_empty() && skipped_faces == 0 {
        return Err(LoadError::invalid(
            Location::file(path),
            "the PLY file has no faces (point clouds are not renderable)",
        ));
    }
    if mesh.indices.is_empty() {
        return Err(LoadError::invalid(
            Location::item(path, "element face"),
            format!(
                "the PLY file has no faces with 3 or more vertices ({skipped_faces} with fewer \
                 skipped); a face lists at least 3 vertex indices"
            ),
        ));
    }
    if skipped_faces > 0 {
        diag.warn(
            Location::item(path, "element face"),
            format!("{skipped_faces} faces with fewer than 3 vertices skipped"),
        )?;
    }
    // A colour cannot be negative (nor NaN): read as 0 with a warning, as OBJ's `Kd` and
    // glTF's factors are, instead of rendering negative light.
    let bad_colours = mesh
        .colors
        .iter()
        // (Not `min_element`: it skips NaN.)
        .filter(|c| !(c.x >= 0.0 && c.y >= 0.0 && c.z >= 0.0))
        .count();
    if bad_colours > 0 {
        for c in &mut mesh.colors {
            *c = Vec3::new(c.x.max(0.0), c.y.max(0.0), c.z.max(0.0));
        }
        diag.warn(
            Location::item(path, "element vertex"),
            format!(
                "{bad_colours} vertex colours have a negative or NaN value; a colour cannot be \
                 negative, so those values are read as 0"
            ),
        )?;
    }
    Ok(mesh)
}
