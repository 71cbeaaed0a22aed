//! A plugin's parameters (`<float name=...>`, `<rgb>`, `<transform>`, nested plugins), read on
//! demand and tracked so that parameters lumo never looked at are reported.

use std::cell::{Cell, RefCell};

use glam::{Mat4, Vec3};

use lumo_spectrum::Tabulated;

use super::spectrum::spectrum_to_rgb;
use super::spectrum_plugins::{plugin_spectrum, radiance_to_rgb, PluginSpectrum};
use super::xml::Element;
use crate::load::{Diagnostics, LoadError, Warning};

/// Tags that hold a value rather than a plugin.
const VALUE_TAGS: &[&str] = &[
    "float",
    "integer",
    "boolean",
    "string",
    "rgb",
    "spectrum",
    "point",
    "vector",
    "transform",
];

/// The children of one plugin element, with a used flag each.
pub(crate) struct Props<'a> {
    /// The plugin element.
    pub el: &'a Element,
    used: Vec<Cell<bool>>,
    /// Warnings about values read (negative colours), issued by [`Props::finish`]: the
    /// readers return values, and the diagnostics belong to the caller.
    pending: RefCell<Vec<Warning>>,
}

impl<'a> Props<'a> {
    /// The parameters of `el`.
    pub fn new(el: &'a Element) -> Self {
        Self {
            el,
            used: el.children.iter().map(|_| Cell::new(false)).collect(),
            pending: RefCell::new(Vec::new()),
        }
    }

    /// The plugin type attribute.
    pub fn kind(&self) -> &'a str {
        self.el.attr("type").unwrap_or("")
    }

    /// The value child called `name`, marked used.
    pub fn value(&self, name: &str) -> Option<&'a Element> {
        let i =
            self.el.children.iter().position(|c| {
                VALUE_TAGS.contains(&c.tag.as_str()) && c.attr("name") == Some(name)
            })?;
        self.used[i].set(true);
        Some(&self.el.children[i])
    }

    /// True when a parameter called `name` (value or plugin) is present; marks nothing.
    pub fn has(&self, name: &str) -> bool {
        self.el
            .children
            .iter()
            .any(|c| c.attr("name") == Some(name))
    }

    /// Nested plugins and `<ref>`s with their child index (for [`Props::mark`]).
    pub fn nested(&self) -> Vec<(usize, &'a Element)> {
        self.el
            .children
            .iter()
            .enumerate()
            .filter(|(_, c)| !VALUE_TAGS.contains(&c.tag.as_str()))
            .collect()
    }

    /// Marks child `i` as used.
    pub fn mark(&self, i: usize) {
        if let Some(u) = self.used.get(i) {
            u.set(true);
        }
    }

    /// A nested plugin or `<ref>` with attribute `name`, marked used.
    pub fn named_plugin(&self, name: &str) -> Option<&'a Element> {
        let i =
            self.el.children.iter().position(|c| {
                !VALUE_TAGS.contains(&c.tag.as_str()) && c.attr("name") == Some(name)
            })?;
        self.used[i].set(true);
        Some(&self.el.children[i])
    }

    /// Marks `name` as read without using it (parameters lumo accepts and ignores by design).
    pub fn accept(&self, names: &[&str]) {
        for (i, c) in self.el.children.iter().enumerate() {
            if c.attr("name").is_some_and(|n| names.contains(&n)) {
                self.used[i].set(true);
            }
        }
    }

    /// Issues the warnings about values read, then warns about every child nobody read.
    pub fn finish(&self, diag: &mut Diagnostics) -> Result<(), LoadError> {
        for w in self.pending.take() {
            diag.warn(w.at, w.message)?;
        }
        for (c, used) in self.el.children.iter().zip(&self.used) {
            if used.get() {
                continue;
            }
            let what = match c.attr("name") {
                Some(n) => format!("parameter {n:?} ({})", c.describe()),
                // A value element without a name is a slip, not a feature lumo lacks.
                None if matches!(
                    c.tag.as_str(),
                    "float"
                        | "integer"
                        | "boolean"
                        | "string"
                        | "rgb"
                        | "spectrum"
                        | "point"
                        | "vector"
                ) =>
                {
                    diag.warn(
                        c.at(),
                        format!(
                            "{} in {} has no name attribute, so it sets nothing; add \
                             name=\"...\" (the parameter it is for)",
                            c.describe(),
                            self.el.describe()
                        ),
                    )?;
                    continue;
                }
                None => c.describe(),
            };
            diag.warn(
                c.at(),
                format!(
                    "{what} of {} is not supported by lumo and was ignored",
                    self.el.describe()
                ),
            )?;
        }
        Ok(())
    }

    /// A float parameter (`<float>` or `<integer>`).
    pub fn float(&self, name: &str, default: f32) -> Result<f32, LoadError> {
        match self.value(name) {
            None => Ok(default),
            Some(v) => parse_float(v),
        }
    }

    /// An integer parameter.
    pub fn int(&self, name: &str, default: i64) -> Result<i64, LoadError> {
        match self.value(name) {
            None => Ok(default),
            Some(v) => {
                let s = v.required("value")?;
                s.trim().parse::<i64>().map_err(|_| {
                    LoadError::invalid(v.at(), format!("{name}: {s:?} is not an integer"))
                })
            }
        }
    }

    /// A boolean parameter.
    pub fn bool(&self, name: &str, default: bool) -> Result<bool, LoadError> {
        match self.value(name) {
            None => Ok(default),
            Some(v) => match v.required("value")?.trim().to_ascii_lowercase().as_str() {
                "true" | "1" => Ok(true),
                "false" | "0" => Ok(false),
                s => Err(LoadError::invalid(
                    v.at(),
                    format!("{name}: {s:?} is not a boolean (true or false)"),
                )),
            },
        }
    }

    /// A string parameter.
    pub fn string(&self, name: &str) -> Result<Option<String>, LoadError> {
        match self.value(name) {
            None => Ok(None),
            Some(v) => Ok(Some(v.required("value")?.to_string())),
        }
    }

    /// A colour given as `<rgb>`, `<spectrum>` or a single `<float>`.
    ///
    /// Every colour lumo reads (reflectance, radiance, intensity, irradiance, index of
    /// refraction) is physically non-negative: a negative value is read as 0, with a warning
    /// naming the element, rather than silently making a surface or light emit negative energy.
    pub fn color(&self, name: &str) -> Result<Option<Vec3>, LoadError> {
        let Some(el) = self.value(name) else {
            return Ok(None);
        };
        let c = parse_color(el)?;
        // What the element names, for each warning below: `name: <rgb> in <bsdf …>`.
        let what = format!("{name}: {} in {}", el.describe(), self.el.describe());
        if has_negative_value(el) {
            self.warn_once(
                el,
                format!(
                    "{what} has a negative value; {name} cannot be negative (a colour, \
                     intensity or roughness), so it is read as 0"
                ),
            );
        }
        // Light only outside the visible range converts to black: said here, at the element,
        // not later as "the scene has no emitters".
        let pairs_text = el
            .attr("value")
            .filter(|t| el.tag == "spectrum" && t.contains(':'));
        if let Some(text) = pairs_text {
            let pairs = parse_pairs(el, text)?;
            // One pair is a spectrum at one wavelength, zero at every other: `550:0.5` (meant
            // as 0.5 everywhere) rendered almost black without a word.
            if let [(l, v)] = pairs.as_slice() {
                self.warn_once(
                    el,
                    format!(
                        "{what} is the single pair {l}:{v}, a spectrum that is zero at every \
                         other wavelength (it converts to {c}, almost black); for {v} at every \
                         wavelength write value=\"{v}\", or give pairs spanning 360–830 nm"
                    ),
                );
            }
        }
        if let Some(text) = pairs_text.filter(|_| c == Vec3::ZERO) {
            if parse_pairs(el, text)?.iter().any(|&(_, v)| v > 0.0) {
                self.warn_once(
                    el,
                    format!(
                        "{what} has values only outside the visible range (360–830 nm); it \
                         converts to black"
                    ),
                );
            }
        }
        // A reflectance above 1 is accepted (Mitsuba accepts it) but reflects more light than
        // arrives: said once, since the image then converges to no physical one.
        let reflectance = name.contains("reflectance") || name == "base_color";
        if reflectance && c.max_element() > 1.0 {
            self.warn_once(
                el,
                format!(
                    "{what} is above 1; the surface reflects more light than reaches it \
                     (energy is created), so the image matches no physical renderer's"
                ),
            );
        }
        Ok(Some(c.max(Vec3::ZERO)))
    }

    /// Queues a warning at `el` for [`Props::finish`], unless the same one is queued already.
    fn warn_once(&self, el: &Element, message: String) {
        let mut pending = self.pending.borrow_mut();
        if !pending.iter().any(|w| w.message == message) {
            pending.push(Warning {
                at: el.at(),
                message,
            });
        }
    }

    /// The spectrum `name` when the file gives it as `<spectrum>` wavelength:value pairs (kept
    /// for spectral rendering; [`Props::color`] reads the same element as RGB). Marks nothing.
    pub fn tabulated(&self, name: &str) -> Result<Option<Tabulated>, LoadError> {
        let Some(el) = self.el.children.iter().find(|c| {
            c.tag == "spectrum" && c.attr("name") == Some(name) && c.attr("filename").is_none()
        }) else {
            return Ok(None);
        };
        let pairs = match el.attr("type") {
            Some(kind) => match plugin_spectrum(el, kind)? {
                PluginSpectrum::Grey(_) => return Ok(None),
                PluginSpectrum::Pairs(p) | PluginSpectrum::Radiance(p) => p,
            },
            None => {
                let text = el.required("value")?;
                if !text.contains(':') {
                    return Ok(None);
                }
                parse_pairs(el, text)?
            }
        };
        Ok(Tabulated::new(
            &pairs
                .iter()
                .map(|&(l, v)| (l, v.max(0.0)))
                .collect::<Vec<_>>(),
        ))
    }

    /// A `<point>` or `<vector>` (attributes x, y, z or value="x, y, z").
    pub fn vec3(&self, name: &str) -> Result<Option<Vec3>, LoadError> {
        self.value(name).map(parse_xyz).transpose()
    }

    /// A `<transform>`; identity when absent.
    pub fn transform(&self, name: &str) -> Result<Mat4, LoadError> {
        match self.value(name) {
            None => Ok(Mat4::IDENTITY),
            Some(v) => parse_transform(v),
        }
    }
}

/// Numbers separated by commas and/or whitespace.
pub(crate) fn parse_list(el: &Element, text: &str) -> Result<Vec<f32>, LoadError> {
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<f32>().map_err(|_| {
                LoadError::invalid(el.at(), format!("{}: {s:?} is not a number", el.describe()))
            })
        })
        .collect()
}

fn parse_float(el: &Element) -> Result<f32, LoadError> {
    let s = el.required("value")?;
    let v = s.trim().parse::<f32>().map_err(|_| {
        LoadError::invalid(el.at(), format!("{}: {s:?} is not a number", attr_name(el)))
    })?;
    if !v.is_finite() {
        return Err(LoadError::invalid(
            el.at(),
            format!("{}: {s:?} is not finite", attr_name(el)),
        ));
    }
    Ok(v)
}

fn attr_name(el: &Element) -> String {
    el.attr("name").unwrap_or(&el.tag).to_string()
}

fn finite3(el: &Element, v: Vec3) -> Result<Vec3, LoadError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(LoadError::invalid(
            el.at(),
            format!("{}: {v} is not finite", attr_name(el)),
        ))
    }
}

/// The wavelength:value pairs of a `<spectrum>` (strictly increasing, finite).
fn parse_pairs(el: &Element, text: &str) -> Result<Vec<(f32, f32)>, LoadError> {
    let mut pairs = Vec::new();
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let parsed = item.split_once(':').and_then(|(w, v)| {
            Some((w.trim().parse::<f32>().ok()?, v.trim().parse::<f32>().ok()?))
        });
        match parsed {
            Some(p) if p.0.is_finite() && p.1.is_finite() => pairs.push(p),
            _ => {
                return Err(LoadError::invalid(
                    el.at(),
                    format!("spectrum entry {item:?} is not wavelength:value"),
                ))
            }
        }
    }
    if pairs.windows(2).any(|w| w[1].0 <= w[0].0) {
        return Err(LoadError::invalid(
            el.at(),
            "spectrum wavelengths must increase",
        ));
    }
    Ok(pairs)
}

/// `<rgb value="r, g, b">` (or one value), `<spectrum value="v">` or wavelength:value pairs,
/// `<float value="v">` (grey).
pub(crate) fn parse_color(el: &Element) -> Result<Vec3, LoadError> {
    if el.tag == "spectrum" {
        if let Some(file) = el.attr("filename") {
            // Checked before `value`, which such an element lacks: the message was about a
            // missing value, not about the file.
            return Err(LoadError::invalid(
                el.at(),
                format!(
                    "{}: <spectrum filename={file:?}> (a spectrum file) is not read by lumo; \
                     copy the file's wavelength/value lines into value=\"λ1:v1, λ2:v2, ...\" \
                     or a <spectrum type=\"irregular\">",
                    attr_name(el)
                ),
            ));
        }
        if let Some(kind) = el.attr("type") {
            return Ok(match plugin_spectrum(el, kind)? {
                PluginSpectrum::Grey(v) => finite3(el, Vec3::splat(v))?,
                PluginSpectrum::Pairs(pairs) => spectrum_to_rgb(&pairs),
                PluginSpectrum::Radiance(pairs) => radiance_to_rgb(&pairs),
            });
        }
    }
    let text = el.required("value")?;
    match el.tag.as_str() {
        "rgb" => {
            let v = parse_list(el, text)?;
            match v.as_slice() {
                [g] => finite3(el, Vec3::splat(*g)),
                [r, g, b] => finite3(el, Vec3::new(*r, *g, *b)),
                _ => Err(LoadError::invalid(
                    el.at(),
                    format!("{}: rgb needs 3 values, got {}", attr_name(el), v.len()),
                )),
            }
        }
        "spectrum" => {
            if !text.contains(':') {
                let v = parse_list(el, text)?;
                return match v.as_slice() {
                    [g] => finite3(el, Vec3::splat(*g)),
                    _ => Err(LoadError::invalid(
                        el.at(),
                        "a spectrum is one value or wavelength:value pairs",
                    )),
                };
            }
            let pairs = parse_pairs(el, text)?;
            Ok(spectrum_to_rgb(&pairs))
        }
        "float" | "integer" => Ok(Vec3::splat(parse_float(el)?)),
        _ => Err(LoadError::invalid(
            el.at(),
            format!(
                "{} is not a colour (use <rgb> or <spectrum>)",
                el.describe()
            ),
        )),
    }
}

/// Whether the value of a colour element (already parsed by [`parse_color`]) has a negative
/// number: an rgb or grey component, or the value of a wavelength:value pair (whose RGB
/// projection is clamped to 0 and would hide it).
fn has_negative_value(el: &Element) -> bool {
    let text = el.attr("value").unwrap_or("");
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|item| item.rsplit(':').next().unwrap_or(item))
        .any(|v| v.trim().parse::<f32>().is_ok_and(|v| v < 0.0))
}

/// x/y/z attributes, or value="x, y, z".
pub(crate) fn parse_xyz(el: &Element) -> Result<Vec3, LoadError> {
    if let Some(text) = el.attr("value") {
        let v = parse_list(el, text)?;
        return match v.as_slice() {
            [a] => finite3(el, Vec3::splat(*a)),
            [x, y, z] => finite3(el, Vec3::new(*x, *y, *z)),
            _ => Err(LoadError::invalid(
                el.at(),
                format!("{}: expected 3 numbers, got {}", el.describe(), v.len()),
            )),
        };
    }
    let get = |k: &str, default: f32| -> Result<f32, LoadError> {
        match el.attr(k) {
            None => Ok(default),
            Some(s) => s.trim().parse::<f32>().map_err(|_| {
                LoadError::invalid(
                    el.at(),
                    format!("{}: {k}={s:?} is not a number", el.describe()),
                )
            }),
        }
    };
    finite3(
        el,
        Vec3::new(get("x", 0.0)?, get("y", 0.0)?, get("z", 0.0)?),
    )
}

/// A `<transform>`: each child operation is applied after the ones before it.
pub(crate) fn parse_transform(el: &Element) -> Result<Mat4, LoadError> {
    let mut m = Mat4::IDENTITY;
    for op in &el.children {
        let step = match op.tag.as_str() {
            "translate" => Mat4::from_translation(parse_xyz(op)?),
            "scale" => {
                let s = if op.attr("value").is_some() {
                    parse_xyz(op)?
                } else {
                    // Unspecified axes of a scale stay 1.
                    let get = |k: &str| op.attr(k).map(|s| s.trim().parse::<f32>());
                    let mut v = Vec3::ONE;
                    for (i, k) in ["x", "y", "z"].iter().enumerate() {
                        if let Some(r) = get(k) {
                            v[i] = r.map_err(|_| {
                                LoadError::invalid(op.at(), format!("<scale> {k} is not a number"))
                            })?;
                        }
                    }
                    v
                };
                Mat4::from_scale(finite3(op, s)?)
            }
            "rotate" => {
                let axis = parse_xyz(op)?;
                let angle = op.required("angle")?;
                let angle: f32 = angle.trim().parse().map_err(|_| {
                    LoadError::invalid(op.at(), format!("<rotate> angle {angle:?} is not a number"))
                })?;
                if axis.length_squared() == 0.0 || !angle.is_finite() {
                    return Err(LoadError::invalid(
                        op.at(),
                        "<rotate> needs a non-zero axis (x, y, z) and a finite angle in degrees",
                    ));
                }
                Mat4::from_axis_angle(axis.normalize(), angle.to_radians())
            }
            "matrix" => {
                let v = parse_list(op, op.required("value")?)?;
                match v.len() {
                    // Row-major in the file; glam is column-major. Only affine transforms
                    // place geometry (a projective bottom row was silently dropped).
                    16 if v[12..] != [0.0, 0.0, 0.0, 1.0] => {
                        return Err(LoadError::invalid(
                            op.at(),
                            format!(
                                "<matrix>: the bottom row is {:?}; lumo takes affine transforms, \
                                 whose bottom row is 0 0 0 1",
                                &v[12..]
                            ),
                        ))
                    }
                    16 => Mat4::from_cols_array(&v.try_into().unwrap_or([0.0; 16])).transpose(),
                    9 => Mat4::from_mat3(
                        glam::Mat3::from_cols_array(&v.try_into().unwrap_or([0.0; 9])).transpose(),
                    ),
                    n => {
                        return Err(LoadError::invalid(
                            op.at(),
                            format!("<matrix> needs 16 (or 9) numbers, got {n}"),
                        ))
                    }
                }
            }
            "lookat" => {
                let get = |k: &str| -> Result<Vec3, LoadError> {
                    let v = parse_list(op, op.required(k)?)?;
                    match v.as_slice() {
                        [x, y, z] => finite3(op, Vec3::new(*x, *y, *z)),
                        _ => Err(LoadError::invalid(
                            op.at(),
                            format!("<lookat> {k} needs 3 numbers"),
                        )),
                    }
                };
                let origin = get("origin")?;
                let target = get("target")?;
                let up = if op.attr("up").is_some() {
                    get("up")?
                } else {
                    Vec3::Y
                };
                look_at(origin, target, up).ok_or_else(|| {
                    LoadError::invalid(
                        op.at(),
                        "<lookat>: origin equals target, or up is parallel to the view direction",
                    )
                })?
            }
            _ => {
                return Err(LoadError::invalid(
                    op.at(),
                    format!(
                    "<{}> is not a transform operation (translate, rotate, scale, matrix, lookat)",
                    op.tag
                ),
                ))
            }
        };
        m = step * m;
    }
    if !m.is_finite() {
        return Err(LoadError::invalid(el.at(), "the transform is not finite"));
    }
    Ok(m)
}

/// Mitsuba's look-at matrix: columns (left, up, forward, origin), so local +z looks at `target`.
pub(crate) fn look_at(origin: Vec3, target: Vec3, up: Vec3) -> Option<Mat4> {
    let dir = (target - origin).try_normalize()?;
    let left = up.cross(dir).try_normalize()?;
    let new_up = dir.cross(left);
    Some(Mat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ))
}
