//! Mitsuba 3's spectrum plugins (`<spectrum type="blackbody|d65|regular|irregular">`) read as
//! wavelength:value pairs or a grey level, the forms the rest of the loader already converts.

use super::props::parse_list;
use super::xml::Element;
use crate::load::LoadError;

/// Planck's first radiation constant 2hc² (W·m²/sr) and second hc/k (m·K).
const C1: f64 = 1.191_042_972e-16;
const C2: f64 = 1.438_776_877e-2;

/// What a spectrum plugin stands for.
#[derive(Debug, PartialEq)]
pub(crate) enum PluginSpectrum {
    /// `d65` × `scale` or `uniform` `value`: white of that luminance (D65 is what RGB white means in lumo and in
    /// Mitsuba, so it stays an RGB grey and spectral rendering upsamples it back to D65).
    Grey(f32),
    /// `regular` / `irregular`: a piecewise-linear spectrum, zero outside its wavelengths
    /// (a reflectance or a radiance, as the parameter says).
    Pairs(Vec<(f32, f32)>),
    /// `blackbody`: Planck's spectral radiance in W/(m²·sr·nm), as Mitsuba's spectral
    /// variants emit it, tabulated every 5 nm.
    Radiance(Vec<(f32, f32)>),
}

/// The plugin `<spectrum type=kind>` at `el`.
pub(crate) fn plugin_spectrum(el: &Element, kind: &str) -> Result<PluginSpectrum, LoadError> {
    let known: &[&str] = match kind {
        "d65" => &["scale"],
        "uniform" => &["value"],
        "blackbody" => &["temperature", "wavelength_min", "wavelength_max"],
        "regular" => &[
            "wavelength_min",
            "wavelength_max",
            "values",
            "lambda_min",
            "lambda_max",
        ],
        "irregular" => &["wavelengths", "values"],
        other => {
            return Err(LoadError::invalid(
                el.at(),
                format!(
                    "spectrum type {other:?} is not one of blackbody, d65, regular, irregular, \
                     uniform (or give value=\"λ1:v1, λ2:v2, ...\" or an <rgb>)"
                ),
            ))
        }
    };
    for c in &el.children {
        let name = c.attr("name").unwrap_or("");
        if !known.contains(&name) {
            return Err(LoadError::invalid(
                c.at(),
                format!(
                    "{} in <spectrum type=\"{kind}\"> is not one of its parameters ({})",
                    c.describe(),
                    known.join(", ")
                ),
            ));
        }
    }
    let number = |names: &[&str], default: Option<f32>| -> Result<f32, LoadError> {
        match el
            .children
            .iter()
            .find(|c| c.attr("name").is_some_and(|n| names.contains(&n)))
        {
            Some(c) => match parse_list(c, c.required("value")?)?.as_slice() {
                [v] if v.is_finite() => Ok(*v),
                _ => Err(LoadError::invalid(
                    c.at(),
                    format!("{}: give one finite number", c.describe()),
                )),
            },
            None => default.ok_or_else(|| {
                LoadError::invalid(
                    el.at(),
                    format!(
                        "<spectrum type=\"{kind}\"> needs <float name=\"{}\">",
                        names[0]
                    ),
                )
            }),
        }
    };
    let list = |name: &str| -> Result<Vec<f32>, LoadError> {
        let c = el
            .children
            .iter()
            .find(|c| c.attr("name") == Some(name))
            .ok_or_else(|| {
                LoadError::invalid(
                    el.at(),
                    format!(
                        "<spectrum type=\"{kind}\"> needs <string name=\"{name}\" \
                         value=\"v1, v2, ...\">"
                    ),
                )
            })?;
        let v = parse_list(c, c.required("value")?)?;
        if v.iter().any(|x| !x.is_finite()) {
            return Err(LoadError::invalid(
                c.at(),
                format!("{name}: a value is not finite"),
            ));
        }
        Ok(v)
    };
    match kind {
        "d65" => Ok(PluginSpectrum::Grey(number(&["scale"], Some(1.0))?)),
        "uniform" => Ok(PluginSpectrum::Grey(number(&["value"], None)?)),
        "blackbody" => {
            let t = number(&["temperature"], None)?;
            let (lo, hi) = (
                number(&["wavelength_min"], Some(360.0))?,
                number(&["wavelength_max"], Some(830.0))?,
            );
            if t <= 0.0 || lo >= hi {
                return Err(LoadError::invalid(
                    el.at(),
                    format!(
                        "blackbody: temperature {t} K must be > 0 and wavelength_min {lo} below \
                         wavelength_max {hi}"
                    ),
                ));
            }
            Ok(PluginSpectrum::Radiance(blackbody(t, lo, hi)))
        }
        "regular" => {
            let lo = number(&["wavelength_min", "lambda_min"], None)?;
            let hi = number(&["wavelength_max", "lambda_max"], None)?;
            let values = list("values")?;
            if lo >= hi || values.len() < 2 {
                return Err(LoadError::invalid(
                    el.at(),
                    format!(
                        "regular spectrum: wavelength_min {lo} must be below wavelength_max {hi} \
                         and values hold at least 2 numbers (got {})",
                        values.len()
                    ),
                ));
            }
            let step = (hi - lo) / (values.len() - 1) as f32;
            Ok(PluginSpectrum::Pairs(
                values
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| (lo + step * i as f32, v))
                    .collect(),
            ))
        }
        _ => {
            let (wl, values) = (list("wavelengths")?, list("values")?);
            if wl.len() != values.len() || wl.is_empty() {
                return Err(LoadError::invalid(
                    el.at(),
                    format!(
                        "irregular spectrum: {} wavelengths but {} values; give one value per \
                         wavelength",
                        wl.len(),
                        values.len()
                    ),
                ));
            }
            if wl.windows(2).any(|w| w[1] <= w[0]) {
                return Err(LoadError::invalid(
                    el.at(),
                    "irregular spectrum: wavelengths must increase",
                ));
            }
            Ok(PluginSpectrum::Pairs(wl.into_iter().zip(values).collect()))
        }
    }
}

/// Planck's law at temperature `t` (K) every 5 nm over [lo, hi] nm, in W/(m²·sr·nm).
fn blackbody(t: f32, lo: f32, hi: f32) -> Vec<(f32, f32)> {
    let n = ((hi - lo) / 5.0).ceil().max(1.0) as usize;
    (0..=n)
        .map(|i| {
            let l = (lo + (hi - lo) * i as f32 / n as f32) as f64;
            let m = l * 1e-9;
            let b = C1 / (m.powi(5) * ((C2 / (m * t as f64)).exp_m1())) * 1e-9;
            (l as f32, b as f32)
        })
        .collect()
}

/// Linear sRGB of a radiance spectrum given as pairs (piecewise linear, zero outside): what a
/// camera with the CIE observer records, as Mitsuba's spectral film does.
pub(crate) fn radiance_to_rgb(pairs: &[(f32, f32)]) -> glam::Vec3 {
    let table = lumo_spectrum::Tabulated::new(pairs);
    let xyz = lumo_spectrum::cie::spectrum_to_xyz(|l| match (&table, pairs) {
        (Some(t), [first, .., last]) if l >= first.0 && l <= last.0 => t.eval(l),
        _ => 0.0,
    });
    (lumo_spectrum::cie::XYZ_TO_SRGB * xyz).max(glam::Vec3::ZERO)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Planck's law at 5000 K and 550 nm: 1.27e4 W/(m²·sr·nm) (and Mitsuba 3.9.1's spectral
    /// variant gives RGB (15366, 12102, 9492) for a 5000 K environment, checked here within
    /// 1.5 %: Mitsuba integrates the observer at its sampled wavelengths, lumo on its 5 nm table).
    #[test]
    fn blackbody_matches_planck_and_mitsuba() {
        let b = blackbody(5000.0, 360.0, 830.0);
        let at550 = b.iter().find(|p| (p.0 - 550.0).abs() < 1e-3).unwrap().1;
        assert!((at550 / 1.2706e4 - 1.0).abs() < 2e-3, "{at550}");
        let rgb = radiance_to_rgb(&b);
        let m = glam::Vec3::new(15366.148, 12102.153, 9492.049);
        assert!(((rgb - m) / m).abs().max_element() < 0.015, "{rgb} vs {m}");
    }
}
