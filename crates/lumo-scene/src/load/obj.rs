//! Wavefront OBJ with MTL materials. Polygons are fan-triangulated; one mesh per material.

use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::sync::Arc;

use glam::{Vec2, Vec3};

use super::check::check_mesh;
use super::images::ImageCache;
use super::{read_file, read_limited, Diagnostics, LoadError, Location, ReadError};
use crate::{BsdfSpec, Material, Mesh, Roughness, Texture, TextureFilter, WrapMode};

/// Most bytes of MTL read for one OBJ file, all its `mtllib`s together. Material libraries
/// are text of a few kilobytes; the bound stops a file that names a huge one.
const MAX_MTL_BYTES: u64 = 64 << 20;

/// Reads `path` for a lone-mesh scene: meshes and their materials (indices into the list).
pub(crate) fn load(
    path: &Path,
    diag: &mut Diagnostics,
) -> Result<(Vec<Mesh>, Vec<Material>), LoadError> {
    read(path, diag)
}

/// Reads an OBJ file and the MTL files it names.
pub(crate) fn read(
    path: &Path,
    diag: &mut Diagnostics,
) -> Result<(Vec<Mesh>, Vec<Material>), LoadError> {
    let bytes = read_file(path)?;
    let text = String::from_utf8_lossy(&bytes);
    let mut r = ObjReader {
        path,
        diag,
        positions: vec![],
        uvs: vec![],
        normals: vec![],
        groups: vec![],
        current: 0,
        materials: vec![],
        material_index: HashMap::new(),
        warned: HashSet::new(),
        mtl_files: vec![],
        mtl_bytes: 0,
        skipped_faces: (0, 0),
    };
    r.groups.push(Group::new("default", None));
    for (i, line) in text.lines().enumerate() {
        r.line(i + 1, line)?;
    }
    r.finish()
}

/// One face corner: position, texture and normal indices (0-based).
type Corner = (usize, Option<usize>, Option<usize>);

/// Faces that share a material, as (position, uv, normal) index triples per corner.
struct Group {
    name: String,
    material: Option<usize>,
    corners: Vec<[Corner; 3]>,
}

impl Group {
    fn new(name: &str, material: Option<usize>) -> Self {
        Self {
            name: name.into(),
            material,
            corners: vec![],
        }
    }
}

struct ObjReader<'p, 'd> {
    path: &'p Path,
    diag: &'d mut Diagnostics,
    positions: Vec<Vec3>,
    uvs: Vec<Vec2>,
    normals: Vec<Vec3>,
    groups: Vec<Group>,
    current: usize,
    materials: Vec<Material>,
    material_index: HashMap<String, usize>,
    /// Statements already warned about (one warning per kind).
    warned: HashSet<String>,
    /// MTL files already read (each is read once).
    mtl_files: Vec<std::path::PathBuf>,
    /// Bytes of MTL read so far (see [`MAX_MTL_BYTES`]).
    mtl_bytes: u64,
    /// Faces with fewer than 3 vertices skipped, and the line of the first.
    skipped_faces: (usize, usize),
}

impl ObjReader<'_, '_> {
    fn at(&self, line: usize) -> Location {
        Location::line(self.path, line)
    }

    fn floats<const N: usize>(
        &self,
        line: usize,
        args: &[&str],
        what: &str,
    ) -> Result<[f32; N], LoadError> {
        if args.len() < N {
            return Err(LoadError::invalid(
                self.at(line),
                format!("{what} needs {N} numbers, got {}", args.len()),
            ));
        }
        let mut out = [0.0; N];
        for (o, a) in out.iter_mut().zip(args) {
            *o = a
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    LoadError::invalid(
                        self.at(line),
                        format!("{what}: {a:?} is not a finite number"),
                    )
                })?;
        }
        Ok(out)
    }

    fn line(&mut self, n: usize, line: &str) -> Result<(), LoadError> {
        let line = line.split('#').next().unwrap_or("").trim();
        let mut parts = line.split_whitespace();
        let Some(keyword) = parts.next() else {
            return Ok(());
        };
        let args: Vec<&str> = parts.collect();
        match keyword {
            "v" => {
                let [x, y, z] = self.floats::<3>(n, &args, "vertex")?;
                self.positions.push(Vec3::new(x, y, z));
                if args.len() >= 6 {
                    self.warn_once(
                        n,
                        "v-colour",
                        "OBJ vertex colours are not supported; ignored",
                    )?;
                }
            }
            "vt" => {
                let u = self.floats::<1>(n, &args, "texture coordinate")?[0];
                let v = if args.len() > 1 {
                    self.floats::<2>(n, &args, "texture coordinate")?[1]
                } else {
                    0.0
                };
                self.uvs.push(Vec2::new(u, v));
            }
            "vn" => {
                let [x, y, z] = self.floats::<3>(n, &args, "normal")?;
                self.normals.push(Vec3::new(x, y, z));
            }
            "f" => self.face(n, &args)?,
            "usemtl" => {
                let name = args.join(" ");
                let material = match self.material_index.get(&name) {
                    Some(&m) => m,
                    None => {
                        self.diag.warn(
                            self.at(n),
                            format!("usemtl {name:?}: no such material in the MTL files; using grey diffuse"),
                        )?;
                        self.materials
                            .push(Material::diffuse(&name, Vec3::splat(0.7)));
                        let m = self.materials.len() - 1;
                        self.material_index.insert(name.clone(), m);
                        m
                    }
                };
                self.current = match self
                    .groups
                    .iter()
                    .position(|g| g.material == Some(material))
                {
                    Some(g) => g,
                    None => {
                        self.groups.push(Group::new(&name, Some(material)));
                        self.groups.len() - 1
                    }
                };
            }
            "mtllib" => {
                let dir = self.path.parent().unwrap_or(Path::new(""));
                let name = args.join(" ");
                let mtl = dir.join(&name);
                // Each MTL file is read once, and all of them together within a budget: an
                // OBJ can name the same or a huge file on every line.
                if self.mtl_files.contains(&mtl) {
                    return Ok(());
                }
                self.mtl_files.push(mtl.clone());
                let left = MAX_MTL_BYTES - self.mtl_bytes;
                match read_limited(&mtl, left) {
                    Ok(bytes) => {
                        self.mtl_bytes += bytes.len() as u64;
                        let text = String::from_utf8_lossy(&bytes).into_owned();
                        read_mtl(
                            &mtl,
                            &text,
                            self.diag,
                            &mut self.materials,
                            &mut self.material_index,
                        )?;
                    }
                    Err(e) => {
                        let cause = match e {
                            ReadError::TooLarge { .. } => format!(
                                "the MTL files of this OBJ would be over {} MiB together",
                                MAX_MTL_BYTES >> 20
                            ),
                            other => other.to_string(),
                        };
                        self.diag.warn(
                            self.at(n),
                            format!(
                                "mtllib {}: cannot read: {cause}; its faces get grey diffuse",
                                mtl.display()
                            ),
                        )?
                    }
                }
            }
            // Grouping and smoothing groups do not change the geometry.
            "o" | "g" | "s" => {}
            other => {
                let (key, what) = statement(other);
                let msg = format!("OBJ {what} is not supported; ignored");
                self.warn_once(n, key, &msg)?;
            }
        }
        Ok(())
    }

    fn warn_once(&mut self, line: usize, key: &str, msg: &str) -> Result<(), LoadError> {
        if !self.warned.insert(key.to_string()) {
            return Ok(());
        }
        self.diag.warn(self.at(line), msg)
    }

    /// Resolves a 1-based (or negative, relative) OBJ index into `len` items.
    fn index(&self, line: usize, s: &str, len: usize, what: &str) -> Result<usize, LoadError> {
        let i: i64 = s.parse().map_err(|_| {
            LoadError::invalid(
                self.at(line),
                format!("face: {what} index {s:?} is not an integer"),
            )
        })?;
        let resolved = if i > 0 { i - 1 } else { len as i64 + i };
        if i == 0 || resolved < 0 || resolved >= len as i64 {
            return Err(LoadError::invalid(
                self.at(line),
                format!("face: {what} index {i} is out of range (there are {len} so far)"),
            ));
        }
        Ok(resolved as usize)
    }

    fn face(&mut self, n: usize, args: &[&str]) -> Result<(), LoadError> {
        let mut corners = Vec::with_capacity(args.len());
        for a in args {
            let mut it = a.split('/');
            let v = self.index(n, it.next().unwrap_or(""), self.positions.len(), "vertex")?;
            let vt = match it.next() {
                Some(s) if !s.is_empty() => Some(self.index(n, s, self.uvs.len(), "texture")?),
                _ => None,
            };
            let vn = match it.next() {
                Some(s) if !s.is_empty() => Some(self.index(n, s, self.normals.len(), "normal")?),
                _ => None,
            };
            corners.push((v, vt, vn));
        }
        if corners.len() < 3 {
            if self.skipped_faces.0 == 0 {
                self.skipped_faces.1 = n;
            }
            self.skipped_faces.0 += 1;
            return self.diag.warn(
                self.at(n),
                format!(
                    "face with {} vertices skipped (a face needs 3)",
                    corners.len()
                ),
            );
        }
        let group = &mut self.groups[self.current];
        for i in 1..corners.len() - 1 {
            group.corners.push([corners[0], corners[i], corners[i + 1]]);
        }
        Ok(())
    }

    fn finish(mut self) -> Result<(Vec<Mesh>, Vec<Material>), LoadError> {
        let mut meshes = Vec::new();
        let default_material = if self
            .groups
            .iter()
            .any(|g| g.material.is_none() && !g.corners.is_empty())
        {
            self.materials
                .push(Material::diffuse("default", Vec3::splat(0.7)));
            Some(self.materials.len() - 1)
        } else {
            None
        };
        let stem = self
            .path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        for g in std::mem::take(&mut self.groups) {
            if g.corners.is_empty() {
                continue;
            }
            let with_uv = g.corners.iter().flatten().all(|c| c.1.is_some());
            let with_n = g.corners.iter().flatten().all(|c| c.2.is_some());
            let mut mesh = Mesh {
                name: format!("{stem}:{}", g.name),
                material: g.material.or(default_material).unwrap_or(0),
                ..Default::default()
            };
            let mut unique = HashMap::new();
            for tri in &g.corners {
                let mut idx = [0u32; 3];
                for (k, &(v, vt, vn)) in tri.iter().enumerate() {
                    let key = (v, vt.filter(|_| with_uv), vn.filter(|_| with_n));
                    idx[k] = *unique.entry(key).or_insert_with(|| {
                        mesh.positions.push(self.positions[v]);
                        if let (true, Some(t)) = (with_uv, vt) {
                            mesh.uvs.push(self.uvs[t]);
                        }
                        if let (true, Some(nn)) = (with_n, vn) {
                            mesh.normals.push(self.normals[nn]);
                        }
                        (mesh.positions.len() - 1) as u32
                    });
                }
                mesh.indices.push(idx);
            }
            check_mesh(&mut mesh, &Location::file(self.path), self.diag)?;
            meshes.push(mesh);
        }
        if meshes.is_empty() {
            let (skipped, line) = self.skipped_faces;
            return Err(match skipped {
                0 => LoadError::invalid(Location::file(self.path), "the OBJ file has no faces"),
                _ => LoadError::invalid(
                    self.at(line),
                    format!(
                        "the OBJ file has no faces with 3 or more vertices ({skipped} with fewer \
                         skipped, the first here); a face lists at least 3 vertex indices"
                    ),
                ),
            });
        }
        Ok((meshes, self.materials))
    }
}

/// One MTL material under construction.
#[derive(Default)]
struct Mtl {
    name: String,
    line: usize,
    kd: Option<Vec3>,
    ks: Vec3,
    ns: f32,
    ke: Vec3,
    dissolve: f32,
    ni: Option<f32>,
    map_kd: Option<Texture>,
}

/// How a message names the statement keyword `kw`: (a key for warning once, the words). A
/// short ASCII word is quoted; anything else is "a line that is not a statement", unquoted: a
/// scene may name any file (`mtllib /etc/shadow`), and the loader must not copy a foreign
/// file's contents to the terminal.
fn statement(kw: &str) -> (&str, String) {
    let word = kw.len() <= 16 && kw.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_');
    if word {
        (kw, format!("statement {kw:?}"))
    } else {
        (
            "",
            "a line that is not a statement (not a keyword)".to_string(),
        )
    }
}

/// Parses an MTL file into `materials`, indexed by name.
fn read_mtl(
    path: &Path,
    text: &str,
    diag: &mut Diagnostics,
    materials: &mut Vec<Material>,
    index: &mut HashMap<String, usize>,
) -> Result<(), LoadError> {
    let mut images = ImageCache::default();
    // One warning per kind of odd line, not one per line.
    let mut warned: HashSet<(&str, &str)> = HashSet::new();
    let mut current: Option<Mtl> = None;
    let mut done = Vec::new();
    let dir = path.parent().unwrap_or(Path::new(""));
    for (i, line) in text.lines().enumerate() {
        let n = i + 1;
        let at = Location::line(path, n);
        let line = line.split('#').next().unwrap_or("").trim();
        let mut parts = line.split_whitespace();
        let Some(kw) = parts.next() else { continue };
        let args: Vec<&str> = parts.collect();
        let nums = |count: usize| numbers(kw, &args, &at, count);
        if kw == "newmtl" {
            done.extend(current.take());
            current = Some(Mtl {
                name: args.join(" "),
                line: n,
                ns: 10.0,
                dissolve: 1.0,
                ..Default::default()
            });
            continue;
        }
        let Some(m) = current.as_mut() else {
            let (key, what) = statement(kw);
            if warned.insert(("before newmtl", key)) {
                diag.warn(at, format!("{what} before any newmtl; ignored"))?;
            }
            continue;
        };
        match kw {
            "Kd" | "Ks" | "Ke" => {
                let mut c = Vec3::from_slice(&nums(3)?);
                if c.min_element() < 0.0 {
                    diag.warn(
                        at,
                        format!(
                            "{kw} {c} has a negative value; a colour cannot be negative, so it \
                             is read as 0"
                        ),
                    )?;
                    c = c.max(Vec3::ZERO);
                }
                match kw {
                    "Kd" => m.kd = Some(c),
                    "Ks" => m.ks = c,
                    _ => m.ke = c,
                }
            }
            "Ns" => m.ns = nums(1)?[0],
            "Ni" => {
                let ni = nums(1)?[0];
                // An index of refraction at or below 0 has no meaning (and made a transparent
                // material vanish); 1 is "no refraction", which some exporters write for opaque
                // materials.
                if ni > 0.0 {
                    m.ni = Some(ni);
                } else {
                    diag.warn(
                        at,
                        format!(
                            "Ni {ni}: an index of refraction must be above 0; ignored (glass \
                             takes 1.5)"
                        ),
                    )?;
                }
            }
            "d" => m.dissolve = nums(1)?[0],
            "Tr" => m.dissolve = 1.0 - nums(1)?[0],
            "map_Kd" => {
                if let Some(texture) = read_map_kd(&args, dir, at, &mut images, diag)? {
                    m.map_kd = Some(texture);
                }
            }
            // Ambient colour and illumination model have no physical counterpart here.
            "Ka" | "illum" => {}
            other => {
                let (key, what) = statement(other);
                if warned.insert(("unsupported", key)) {
                    diag.warn(at, format!("MTL {what} is not supported; ignored"))?;
                }
            }
        }
    }
    done.extend(current);
    for w in images.take_warnings() {
        diag.warn(w.at, w.message)?;
    }
    for m in done {
        let name = m.name.clone();
        materials.push(m.material(path, diag)?);
        index.insert(name, materials.len() - 1);
    }
    Ok(())
}

/// `count` finite numbers from the arguments `args` of statement `kw` at `at`; for a colour
/// (`count` 3) a single value means grey.
fn numbers(kw: &str, args: &[&str], at: &Location, count: usize) -> Result<Vec<f32>, LoadError> {
    let v: Option<Vec<f32>> = args
        .iter()
        .take(count)
        .map(|a| a.parse::<f32>().ok().filter(|x| x.is_finite()))
        .collect();
    match v {
        Some(v) if v.len() == count => Ok(v),
        _ if count == 3 && args.len() == 1 => {
            let g = args[0].parse::<f32>().ok().filter(|x| x.is_finite());
            g.map(|g| vec![g; 3]).ok_or_else(|| {
                LoadError::invalid(
                    at.clone(),
                    format!("{kw}: {:?} is not a finite number", args[0]),
                )
            })
        }
        // Say which value is wrong: a NaN is "a number" to whoever wrote it.
        _ => Err(LoadError::invalid(
            at.clone(),
            match args
                .iter()
                .take(count)
                .find(|a| !a.parse::<f32>().is_ok_and(|x| x.is_finite()))
            {
                Some(bad) => {
                    format!("{kw}: {bad:?} is not a finite number (expected {count} numbers)")
                }
                None => format!("{kw}: expected {count} numbers, got {}", args.len()),
            },
        )),
    }
}

/// The texture of a `map_Kd` statement with arguments `args` (options, then the file name,
/// relative to `dir`); `None`, said as a warning, where the image does not load (Kd then
/// stays the colour).
fn read_map_kd(
    args: &[&str],
    dir: &Path,
    at: Location,
    images: &mut ImageCache,
    diag: &mut Diagnostics,
) -> Result<Option<Texture>, LoadError> {
    // The file name is the last token; options (-s, -o, ...) come before it.
    let Some(file) = args.last() else {
        return Err(LoadError::invalid(at, "map_Kd needs a file name"));
    };
    let mut uv_scale = glam::Vec2::ONE;
    if let Some(p) = args.iter().position(|a| *a == "-s") {
        let s: Vec<f32> = args[p + 1..]
            .iter()
            .take(2)
            .filter_map(|a| a.parse().ok())
            .collect();
        if s.len() == 2 {
            uv_scale = glam::Vec2::new(s[0], s[1]);
        }
    }
    if args.len() > 1 && !args.contains(&"-s") {
        diag.warn(at.clone(), "map_Kd options other than -s are ignored")?;
    }
    match images.load(&dir.join(file), false, &at) {
        Ok(image) => Ok(Some(Texture::Bitmap {
            image: Arc::clone(&image),
            uv_scale,
            filter: TextureFilter::Nearest,
            wrap: WrapMode::Repeat,
        })),
        // The warning has its own location; keep only the message.
        Err(LoadError::Invalid { message, .. }) => {
            diag.warn(at, format!("{message}; using Kd instead"))?;
            Ok(None)
        }
        Err(e) => {
            diag.warn(at, format!("{e}; using Kd instead"))?;
            Ok(None)
        }
    }
}

impl Mtl {
    /// The scene material this MTL material describes, read from `path`: clear glass where
    /// mostly transparent, a metal where only specular, a plastic where both diffuse and
    /// specular, else diffuse.
    fn material(self, path: &Path, diag: &mut Diagnostics) -> Result<Material, LoadError> {
        let m = self;
        let at = Location::line(path, m.line);
        let kd = m.kd.unwrap_or(Vec3::splat(0.7));
        let diffuse = m.map_kd.unwrap_or(Texture::Constant(kd));
        let bsdf = if m.dissolve < 0.5 {
            diag.warn(
                at.clone(),
                format!(
                    "material {:?}: transparency (d = {}) rendered as clear glass",
                    m.name, m.dissolve
                ),
            )?;
            BsdfSpec::Dielectric {
                ior: m.ni.unwrap_or(1.5),
                roughness: Roughness::SMOOTH,
            }
        } else if m.ks.max_element() > 0.0 && diffuse.average().max_element() <= 0.0 {
            let (eta, k) = super::materials::metal_from_reflectance(m.ks);
            BsdfSpec::Conductor {
                eta,
                k,
                roughness: Roughness::ggx(phong_alpha(m.ns)),
            }
        } else if m.ks.max_element() > 0.0 {
            BsdfSpec::Plastic {
                diffuse,
                ior: 1.5,
                roughness: Roughness::ggx(phong_alpha(m.ns)),
                nonlinear: false,
                exact_rough_coat: false,
            }
        } else {
            BsdfSpec::Diffuse {
                reflectance: diffuse,
            }
        };
        if m.dissolve < 1.0 && m.dissolve >= 0.5 {
            diag.warn(
                at,
                format!(
                    "material {:?}: partial transparency (d = {}) ignored; rendered opaque",
                    m.name, m.dissolve
                ),
            )?;
        }
        Ok(Material {
            name: m.name,
            bsdf,
            emission: m.ke.max(Vec3::ZERO),
            two_sided: true,
            emission_map: None,
            spectra: Default::default(),
        })
    }
}

/// GGX α roughly equivalent to a Phong exponent (Walter et al.'s α = sqrt(2 / (n + 2))).
fn phong_alpha(ns: f32) -> f32 {
    (2.0 / (ns.max(0.0) + 2.0)).sqrt()
}
