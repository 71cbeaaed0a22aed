//! Mitsuba XML to an owned element tree: `<default>` and `$name` substitution, `<include>`
//! splicing, and the renaming Mitsuba applies to scenes older than version 2.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::rc::Rc;

use crate::load::{read_limited, Diagnostics, LoadError, Location, ReadError};

/// Deepest `<include>` nesting accepted (guards against include cycles and runaway files).
const MAX_INCLUDE_DEPTH: usize = 16;

/// Most `<include>`s followed while reading one scene, counting every occurrence. Depth alone
/// does not bound the work: 13 files that each include the next 4 times make 4^12 includes.
const MAX_INCLUDES: usize = 4096;

/// Most bytes of XML read for one scene, the scene file and all its includes together. Real
/// scenes keep meshes and images in their own files, so their XML is small.
const MAX_XML_BYTES: u64 = 64 << 20;

/// Deepest element nesting accepted. Mitsuba scenes nest a handful of levels; the bound keeps
/// the recursive readers here and in the scene conversion within the stack.
const MAX_ELEMENT_DEPTH: usize = 64;

/// Most bytes `$name` substitution may produce in one scene. Defaults can be built from other
/// defaults, so without a bound a small file can expand exponentially ("billion laughs").
const MAX_SUBSTITUTED_BYTES: usize = 16 << 20;

/// One XML element after substitution, with where it came from.
#[derive(Debug)]
pub(crate) struct Element {
    /// Tag name (`bsdf`, `float`, ...).
    pub tag: String,
    /// Attributes, `$name` substituted.
    pub attrs: Vec<(String, String)>,
    /// Child elements (includes spliced in, defaults removed).
    pub children: Vec<Element>,
    /// The file it is in.
    pub file: Rc<PathBuf>,
    /// Its 1-based line.
    pub line: usize,
}

impl Element {
    /// The attribute `name`, if present.
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    /// The attribute `name`, or an error naming the element.
    pub fn required(&self, name: &str) -> Result<&str, LoadError> {
        self.attr(name).ok_or_else(|| {
            // A typed spectrum (Mitsuba's `blackbody`, `d65`, …) has parameters instead of a
            // value: say what is unsupported rather than that a value is missing.
            let message = match self.attr("type") {
                Some(kind) if self.tag == "spectrum" && name == "value" => format!(
                    "<spectrum type={kind:?}> is not supported by lumo; give the spectrum as \
                     value=\"wavelength:value, …\" pairs, or use <rgb>"
                ),
                _ => format!("<{}> needs a {name:?} attribute", self.tag),
            };
            LoadError::invalid(self.at(), message)
        })
    }

    /// Where the element is.
    pub fn at(&self) -> Location {
        Location::line(&self.file, self.line)
    }

    /// `<tag type="...">` for messages.
    pub fn describe(&self) -> String {
        match self.attr("type") {
            Some(t) => format!("<{} type=\"{t}\">", self.tag),
            None => format!("<{}>", self.tag),
        }
    }
}

/// Reads `path` and everything it includes into one tree rooted at `<scene>`.
pub(crate) fn read_tree(
    path: &Path,
    defines: &[(String, String)],
    diag: &mut Diagnostics,
) -> Result<Element, LoadError> {
    let mut reader = Reader::new(defines, diag, true);
    let root = reader.read_file(path, None)?;
    reader.warn_unused_defines(defines, path)?;
    Ok(root)
}

/// Reads the scene `text` (as if from the file `path`) into a tree rooted at `<scene>`;
/// an `<include>` is an error, as in-memory scenes read no files.
pub(crate) fn read_tree_str(
    text: &str,
    path: &Path,
    defines: &[(String, String)],
    diag: &mut Diagnostics,
) -> Result<Element, LoadError> {
    let mut reader = Reader::new(defines, diag, false);
    let root = reader.read_text(path, path.to_path_buf(), text, None)?;
    reader.warn_unused_defines(defines, path)?;
    Ok(root)
}

struct Reader<'d> {
    /// Parameter values: command line first, then `<default>`s in document order.
    vars: HashMap<String, String>,
    /// Parameter names the scene declares (`<default>`) or uses (`$name`): a command-line
    /// definition of any other name has no effect, which the user should hear about.
    known: HashSet<String>,
    diag: &'d mut Diagnostics,
    /// Files being read (for include cycles).
    stack: Vec<PathBuf>,
    /// The scene declares a version below 2: rename camelCase parameters as Mitsuba does.
    legacy: bool,
    /// Whether `<include>` may read files.
    files: bool,
    /// Depth of the element being read (see [`MAX_ELEMENT_DEPTH`]).
    depth: usize,
    /// Bytes produced by substitution so far (see [`MAX_SUBSTITUTED_BYTES`]).
    substituted: usize,
    /// `<include>`s followed so far (see [`MAX_INCLUDES`]).
    includes: usize,
    /// Bytes of XML read so far (see [`MAX_XML_BYTES`]).
    xml_bytes: u64,
}

impl<'d> Reader<'d> {
    fn new(defines: &[(String, String)], diag: &'d mut Diagnostics, files: bool) -> Self {
        Self {
            vars: defines.iter().cloned().collect(),
            known: HashSet::new(),
            diag,
            stack: Vec::new(),
            legacy: false,
            files,
            depth: 0,
            substituted: 0,
            includes: 0,
            xml_bytes: 0,
        }
    }

    /// One warning per command-line definition (`-D NAME=VALUE`) of a name the scene neither
    /// declares nor uses: it changes nothing, which is most likely a typo.
    fn warn_unused_defines(
        &mut self,
        defines: &[(String, String)],
        path: &Path,
    ) -> Result<(), LoadError> {
        for (name, _) in defines {
            if !self.known.contains(name) {
                self.diag.warn(
                    Location::file(path),
                    format!(
                        "-D {name}=…: the scene has no parameter ${name} (no <default \
                         name=\"{name}\"> and no use of ${name}); the definition is ignored"
                    ),
                )?;
            }
        }
        Ok(())
    }

    fn read_file(&mut self, path: &Path, from: Option<Location>) -> Result<Element, LoadError> {
        let canonical = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        if self.stack.contains(&canonical) || self.stack.len() >= MAX_INCLUDE_DEPTH {
            return Err(LoadError::invalid(
                from.unwrap_or_else(|| Location::file(path)),
                format!(
                    "<include> of {} would recurse (include cycle or more than \
                     {MAX_INCLUDE_DEPTH} levels)",
                    path.display()
                ),
            ));
        }
        if let Some(at) = &from {
            self.includes += 1;
            if self.includes > MAX_INCLUDES {
                return Err(LoadError::invalid(
                    at.clone(),
                    format!(
                        "<include> of {}: the scene includes more than {MAX_INCLUDES} files in \
                         all (files that include others several times multiply); include each \
                         file once",
                        path.display()
                    ),
                ));
            }
        }
        let left = MAX_XML_BYTES - self.xml_bytes;
        let bytes = read_limited(path, left).map_err(|e| {
            let cause = match e {
                // The top-level file keeps the typed I/O error.
                ReadError::Io(error) if from.is_none() => return LoadError::io(path, error),
                ReadError::TooLarge { .. } => format!(
                    "the scene's XML, its file and all included files together, would be \
                     over {} MiB; include each file once and keep meshes in .ply or .obj files",
                    MAX_XML_BYTES >> 20
                ),
                other => other.to_string(),
            };
            match &from {
                Some(at) => LoadError::invalid(
                    at.clone(),
                    format!("cannot read included file {}: {cause}", path.display()),
                ),
                None => LoadError::invalid(Location::file(path), format!("cannot read: {cause}")),
            }
        })?;
        self.xml_bytes += bytes.len() as u64;
        let text = String::from_utf8(bytes).map_err(|e| {
            LoadError::invalid(Location::file(path), format!("not UTF-8 text: {e}"))
        })?;
        self.read_text(path, canonical, &text, from)
    }

    /// Parses `text`, the contents of `path` (`canonical` on the include stack), included
    /// from `from` (`None` for the top-level file).
    fn read_text(
        &mut self,
        path: &Path,
        canonical: PathBuf,
        text: &str,
        from: Option<Location>,
    ) -> Result<Element, LoadError> {
        // The parser recurses per level; refuse what would overflow the stack before it runs.
        super::depth::check_nesting(path, text, MAX_ELEMENT_DEPTH + 1)?;
        let doc = roxmltree::Document::parse(text).map_err(|e| {
            let pos = e.pos();
            LoadError::invalid(
                Location::line(path, pos.row as usize),
                format!("malformed XML: {e}"),
            )
        })?;
        let root = doc.root_element();
        let file = Rc::new(path.to_path_buf());
        // Line starts found once: roxmltree's text_pos_at scans from the file's start on every
        // call, which made loading quadratic (20,000 shapes on one line took 41 s).
        let newlines: Vec<usize> = newline_offsets(text);
        let line_of =
            |node: roxmltree::Node| 1 + newlines.partition_point(|&nl| nl < node.range().start);
        if root.tag_name().name() != "scene" {
            return Err(LoadError::invalid(
                Location::line(path, line_of(root)),
                format!(
                    "the root element is <{}>; a Mitsuba scene file starts with <scene version=\"3.0.0\">",
                    root.tag_name().name()
                ),
            ));
        }
        if from.is_none() {
            self.check_version(
                root.attribute("version"),
                Location::line(path, line_of(root)),
            )?;
        }
        self.stack.push(canonical);
        let mut scene = Element {
            tag: "scene".into(),
            attrs: vec![],
            children: vec![],
            file: file.clone(),
            line: line_of(root),
        };
        let base = path.parent().unwrap_or(Path::new("")).to_path_buf();
        self.read_children(root, &mut scene, &file, &base, &line_of, true)?;
        self.stack.pop();
        Ok(scene)
    }

    fn check_version(&mut self, version: Option<&str>, at: Location) -> Result<(), LoadError> {
        let Some(v) = version else {
            return self.diag.warn(
                at,
                "<scene> has no version attribute; reading it as Mitsuba 3 (add version=\"3.0.0\")",
            );
        };
        let major = v
            .split('.')
            .next()
            .and_then(|m| m.trim().parse::<u32>().ok());
        match major {
            Some(m) if m >= 2 => Ok(()),
            Some(_) => {
                self.legacy = true;
                self.diag.warn(
                    at,
                    format!(
                        "scene version {v} predates Mitsuba 2; camelCase parameter names are \
                         renamed as Mitsuba 3 does, other differences are not translated"
                    ),
                )
            }
            None => Err(LoadError::invalid(
                at,
                format!("<scene version=\"{v}\"> is not a version number such as 3.0.0"),
            )),
        }
    }

    fn read_children(
        &mut self,
        node: roxmltree::Node,
        out: &mut Element,
        file: &Rc<PathBuf>,
        base: &Path,
        line_of: &dyn Fn(roxmltree::Node) -> usize,
        top: bool,
    ) -> Result<(), LoadError> {
        for child in node.children().filter(|c| c.is_element()) {
            let line = line_of(child);
            let at = Location::line(file, line);
            let mut tag = child.tag_name().name().to_string();
            if self.legacy && tag == "lookAt" {
                tag = "lookat".into();
            }
            let mut attrs = Vec::new();
            for a in child.attributes() {
                let mut value = self.substitute(a.value(), &at)?;
                if self.legacy && a.name() == "name" {
                    value = camel_to_snake(&value);
                }
                attrs.push((a.name().to_string(), value));
            }
            let get = |k: &str| attrs.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone());
            match tag.as_str() {
                "default" => {
                    let (Some(name), Some(value)) = (get("name"), get("value")) else {
                        return Err(LoadError::invalid(
                            at,
                            "<default> needs name and value attributes",
                        ));
                    };
                    if !top {
                        self.diag.warn(
                            at,
                            "<default> inside a plugin; Mitsuba only allows it in <scene>",
                        )?;
                    }
                    // Command-line definitions and earlier defaults win.
                    self.known.insert(name.clone());
                    self.vars.entry(name).or_insert(value);
                }
                "include" => {
                    let Some(name) = get("filename") else {
                        return Err(LoadError::invalid(
                            at,
                            "<include> needs a filename attribute",
                        ));
                    };
                    if !self.files {
                        return Err(LoadError::invalid(
                            at,
                            format!(
                                "<include filename={name:?}>: a scene loaded from memory \
                                 reads no files"
                            ),
                        ));
                    }
                    let included = self.read_file(&base.join(&name), Some(at))?;
                    out.children.extend(included.children);
                }
                _ => {
                    if self.depth >= MAX_ELEMENT_DEPTH {
                        return Err(LoadError::invalid(
                            at,
                            format!(
                                "<{tag}> is nested more than {MAX_ELEMENT_DEPTH} elements deep"
                            ),
                        ));
                    }
                    let mut el = Element {
                        tag,
                        attrs,
                        children: vec![],
                        file: file.clone(),
                        line,
                    };
                    self.depth += 1;
                    self.read_children(child, &mut el, file, base, line_of, false)?;
                    self.depth -= 1;
                    out.children.push(el);
                }
            }
        }
        Ok(())
    }

    /// Replaces every `$name` with its value; an undefined name is an error, and so is more
    /// than [`MAX_SUBSTITUTED_BYTES`] of output in all.
    fn substitute(&mut self, text: &str, at: &Location) -> Result<String, LoadError> {
        if !text.contains('$') {
            return Ok(text.to_string());
        }
        let mut out = String::with_capacity(text.len());
        let mut rest = text;
        while let Some(i) = rest.find('$') {
            out.push_str(&rest[..i]);
            let after = &rest[i + 1..];
            let len = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            if len == 0 {
                out.push('$');
                rest = after;
                continue;
            }
            let name = &after[..len];
            if !self.known.contains(name) {
                self.known.insert(name.to_string());
            }
            let value = self.vars.get(name).ok_or_else(|| {
                LoadError::invalid(
                    at.clone(),
                    format!(
                        "${name} is not defined; declare <default name=\"{name}\" value=\"...\"/> \
                         before its use or pass -D {name}=VALUE"
                    ),
                )
            })?;
            if self.substituted + out.len() + value.len() > MAX_SUBSTITUTED_BYTES {
                return Err(LoadError::invalid(
                    at.clone(),
                    format!(
                        "${name}: parameter substitution would produce more than {} MiB \
                         (defaults built from defaults grow without bound)",
                        MAX_SUBSTITUTED_BYTES >> 20
                    ),
                ));
            }
            out.push_str(value);
            rest = &after[len..];
        }
        out.push_str(rest);
        self.substituted += out.len();
        Ok(out)
    }
}

/// `maxDepth` → `max_depth`, as Mitsuba 3 upgrades old scenes.
fn camel_to_snake(name: &str) -> String {
    let mut out = String::with_capacity(name.len() + 4);
    for (i, c) in name.chars().enumerate() {
        if c.is_ascii_uppercase() && i > 0 {
            out.push('_');
        }
        out.push(c.to_ascii_lowercase());
    }
    out
}

/// The byte offsets of every `\n` in `text`, in order.
fn newline_offsets(text: &str) -> Vec<usize> {
    text.bytes()
        .enumerate()
        .filter_map(|(i, b)| (b == b'\n').then_some(i))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::camel_to_snake;

    #[test]
    fn legacy_names() {
        assert_eq!(camel_to_snake("maxDepth"), "max_depth");
        assert_eq!(camel_to_snake("toWorld"), "to_world");
        assert_eq!(camel_to_snake("radiance"), "radiance");
    }
}
