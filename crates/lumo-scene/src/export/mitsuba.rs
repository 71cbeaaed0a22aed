//! A scene as a Mitsuba 3 XML file and one PLY file per mesh.
//!
//! Written exactly: meshes (positions, normals, uvs) placed by their instances' matrices,
//! Mitsuba's `sphere`, `disk` and `cylinder` for analytic shapes, the BSDFs that are Mitsuba
//! plugins (`diffuse`, `conductor`/`roughconductor`, `plastic`/`roughplastic`,
//! `dielectric`/`roughdielectric`, `thindielectric`, a perfect mirror as a `conductor` of `material`
//! "none"), constant and checkerboard textures, `twosided`, area
//! emitters, point, directional and constant lights, a pinhole or thin-lens camera with its
//! pixel filter, and the render defaults. What Mitsuba cannot hold exactly is refused.
//!
//! One difference is deliberate and stated: lumo's built-in, glTF and OBJ plastics keep the
//! smooth coat's Fresnel terms at any roughness (`exact_rough_coat: false`), where Mitsuba's
//! `roughplastic` integrates the rough coat; the file says `roughplastic`, so a renderer of the
//! file (lumo included) renders Mitsuba's model.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};

use super::ply::ply_bytes;
use super::ExportError;
use crate::{
    AnalyticKind, BsdfSpec, Distribution, FovAxis, Lens, Light, Material, PixelFilter, Roughness,
    Scene, Texture,
};

/// Writes `scene` as `xml` (a Mitsuba 3 scene file) with its meshes as PLY files in the
/// folder `meshes/` beside it. Returns the files written. Render settings come from the scene's
/// defaults as `<default>`s (`res` for a square image, else `width` and `height`; `spp`,
/// `max_depth`), so `-D` can change them as in any Mitsuba file.
pub fn write_mitsuba(scene: &Scene, xml: &Path) -> Result<Vec<PathBuf>, ExportError> {
    let dir = xml.parent().unwrap_or(Path::new("."));
    let mesh_dir = dir.join("meshes");
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| ExportError::Io { path, source }
    };
    if scene.media.is_active() {
        return Err(ExportError::unsupported(
            "the scene's participating media",
            "media are not exported yet",
        ));
    }
    // Everything that can be refused is checked before the first mesh file is written.
    let mut out = String::new();
    header(scene, &mut out)?;
    for (i, m) in scene.materials.iter().enumerate() {
        bsdf_element(m, &format!("mat{i}"), &mut out)?;
        if m.is_emissive() && m.emission_map.is_some() {
            return Err(ExportError::unsupported(
                format!("material {:?}", m.name),
                "an emission texture is not exported yet",
            ));
        }
    }
    let mut lights = String::new();
    for light in &scene.lights {
        light_element(light, &mut lights)?;
    }
    std::fs::create_dir_all(&mesh_dir).map_err(io(&mesh_dir))?;
    let mut written = vec![];
    let mut mesh_files = vec![None; scene.meshes.len()];
    for inst in &scene.instances {
        let mesh = scene.meshes.get(inst.mesh).ok_or_else(|| {
            ExportError::unsupported(
                format!("instance of mesh {}", inst.mesh),
                "it names no mesh",
            )
        })?;
        let material = &scene.materials[mesh.material];
        let name = xml_text(&mesh.name);
        if let Some(a) = &mesh.analytic {
            let kind = match a.kind {
                AnalyticKind::Sphere => "sphere",
                AnalyticKind::Disk => "disk",
                AnalyticKind::Cylinder => "cylinder",
            };
            // The unit shapes of Mitsuba's defaults (sphere: centre 0, radius 1; cylinder: p0 0,
            // p1 (0, 0, 1), radius 1) under one matrix hold every placement exactly.
            let _ = writeln!(out, "    <shape type=\"{kind}\"> <!-- {name} -->");
            matrix("to_world", &(inst.transform * a.to_mesh), &mut out);
            if a.flip_normals {
                out.push_str("        <boolean name=\"flip_normals\" value=\"true\"/>\n");
            }
        } else {
            let file = match &mesh_files[inst.mesh] {
                Some(f) => f,
                None => {
                    let rel = format!("meshes/{:04}.ply", inst.mesh);
                    let path = dir.join(&rel);
                    std::fs::write(&path, ply_bytes(mesh)).map_err(io(&path))?;
                    written.push(path);
                    mesh_files[inst.mesh] = Some(rel);
                    mesh_files[inst.mesh].as_ref().expect("just set")
                }
            };
            let _ = writeln!(out, "    <shape type=\"ply\"> <!-- {name} -->");
            let _ = writeln!(out, "        <string name=\"filename\" value=\"{file}\"/>");
            if mesh.normals.is_empty() {
                out.push_str("        <boolean name=\"face_normals\" value=\"true\"/>\n");
            }
            matrix("to_world", &inst.transform, &mut out);
        }
        let _ = writeln!(out, "        <ref id=\"mat{}\"/>", mesh.material);
        if material.is_emissive() {
            let _ = writeln!(
                out,
                "        <emitter type=\"area\">{}</emitter>",
                rgb("radiance", material.emission)
            );
        }
        out.push_str("    </shape>\n");
    }
    out.push_str(&lights);
    out.push_str("</scene>\n");
    std::fs::write(xml, out).map_err(io(xml))?;
    written.insert(0, xml.to_path_buf());
    Ok(written)
}

/// The `<scene>` opening, defaults, integrator and sensor.
fn header(scene: &Scene, out: &mut String) -> Result<(), ExportError> {
    let d = &scene.defaults;
    let c = &scene.camera;
    // A square image gets one `res` parameter, as lumo's scene files have it (`-D res=256`).
    let (size, width, height) = if d.width == d.height {
        (
            format!("<default name=\"res\" value=\"{}\"/>", d.width),
            "$res",
            "$res",
        )
    } else {
        (
            format!(
                "<default name=\"width\" value=\"{}\"/><default name=\"height\" value=\"{}\"/>",
                d.width, d.height
            ),
            "$width",
            "$height",
        )
    };
    let _ = write!(
        out,
        "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n\
         <!-- {}: written by `lumo export` (lumo's scene, as Mitsuba 3 XML). -->\n\
         <scene version=\"3.0.0\">\n\
         \x20   <default name=\"spp\" value=\"{}\"/>\n\
         \x20   {size}\n\
         \x20   <default name=\"max_depth\" value=\"{}\"/>\n\
         \x20   <integrator type=\"path\"><integer name=\"max_depth\" value=\"$max_depth\"/></integrator>\n",
        xml_text(&scene.name),
        d.spp,
        d.max_depth,
    );
    let lens = match c.lens {
        Lens::Pinhole => String::new(),
        Lens::Thin {
            aperture_radius,
            focus_distance,
        } => format!(
            "        <float name=\"aperture_radius\" value=\"{aperture_radius}\"/>\n        \
             <float name=\"focus_distance\" value=\"{focus_distance}\"/>\n"
        ),
        Lens::Orthographic { .. } => {
            return Err(ExportError::unsupported(
                "the orthographic camera",
                "only pinhole and thin-lens cameras are exported yet",
            ))
        }
    };
    let kind = if lens.is_empty() {
        "perspective"
    } else {
        "thinlens"
    };
    let axis = match c.fov_axis {
        FovAxis::X => "x",
        FovAxis::Y => "y",
        FovAxis::Smaller => "smaller",
        FovAxis::Larger => "larger",
        FovAxis::Diagonal => "diagonal",
    };
    let filter = match c.filter {
        PixelFilter::Box => "<rfilter type=\"box\"/>".to_string(),
        PixelFilter::Tent { radius } => {
            format!("<rfilter type=\"tent\"><float name=\"radius\" value=\"{radius}\"/></rfilter>")
        }
        PixelFilter::Gaussian { stddev } => format!(
            "<rfilter type=\"gaussian\"><float name=\"stddev\" value=\"{stddev}\"/></rfilter>"
        ),
    };
    let _ = write!(
        out,
        "    <sensor type=\"{kind}\">\n        <float name=\"fov\" value=\"{}\"/>\n        \
         <string name=\"fov_axis\" value=\"{axis}\"/>\n{lens}        \
         <transform name=\"to_world\"><lookat origin=\"{}\" target=\"{}\" up=\"{}\"/></transform>\n        \
         <sampler type=\"independent\"><integer name=\"sample_count\" value=\"$spp\"/></sampler>\n        \
         <film type=\"hdrfilm\"><integer name=\"width\" value=\"{width}\"/><integer name=\"height\" \
         value=\"{height}\"/>{filter}</film>\n    </sensor>\n",
        c.fov,
        triple(c.origin),
        triple(c.target),
        triple(c.up),
    );
    Ok(())
}

/// A top-level `<bsdf id=…>` for `m` (inside `twosided` where it reflects on both sides).
fn bsdf_element(m: &Material, id: &str, out: &mut String) -> Result<(), ExportError> {
    let what = || format!("material {:?}", m.name);
    if m.spectra.reflectance.is_some() {
        return Err(ExportError::unsupported(
            what(),
            "measured reflectance spectra are not exported yet",
        ));
    }
    let inner = bsdf(&m.bsdf, &what)?;
    // Transmissive BSDFs are two-sided in Mitsuba by nature; `twosided` refuses them.
    let transmissive = matches!(
        m.bsdf,
        BsdfSpec::Dielectric { .. } | BsdfSpec::ThinDielectric { .. }
    );
    let _ = if m.two_sided && !transmissive {
        writeln!(
            out,
            "    <bsdf type=\"twosided\" id=\"{id}\"> <!-- {} -->\n        {inner}\n    </bsdf>",
            xml_text(&m.name)
        )
    } else {
        let inner = inner.replacen("<bsdf ", &format!("<bsdf id=\"{id}\" "), 1);
        writeln!(out, "    {inner} <!-- {} -->", xml_text(&m.name))
    };
    Ok(())
}

/// One BSDF element (no id).
fn bsdf(spec: &BsdfSpec, what: &dyn Fn() -> String) -> Result<String, ExportError> {
    Ok(match spec {
        BsdfSpec::Diffuse { reflectance } => format!(
            "<bsdf type=\"diffuse\">{}</bsdf>",
            texture("reflectance", reflectance, what)?
        ),
        // Mitsuba scales a conductor by `specular_reflectance`, which lumo's loader ignores:
        // only a perfect mirror reads back as itself.
        BsdfSpec::Mirror { reflectance } if *reflectance == Vec3::ONE => {
            "<bsdf type=\"conductor\"><string name=\"material\" value=\"none\"/></bsdf>".into()
        }
        BsdfSpec::Conductor { eta, k, roughness } => format!(
            "<bsdf type=\"{}conductor\">{}{}{}</bsdf>",
            rough_prefix(roughness),
            microfacet(roughness, what)?,
            rgb("eta", *eta),
            rgb("k", *k)
        ),
        BsdfSpec::Plastic {
            diffuse,
            ior,
            roughness,
            nonlinear,
            exact_rough_coat: _,
        } => {
            if roughness.alpha_u != roughness.alpha_v {
                return Err(ExportError::unsupported(
                    what(),
                    "Mitsuba's roughplastic is isotropic only",
                ));
            }
            format!(
                "<bsdf type=\"{}plastic\">{}<float name=\"int_ior\" value=\"{ior}\"/>\
                 <float name=\"ext_ior\" value=\"1\"/>{}<boolean name=\"nonlinear\" \
                 value=\"{nonlinear}\"/></bsdf>",
                rough_prefix(roughness),
                microfacet(roughness, what)?,
                texture("diffuse_reflectance", diffuse, what)?
            )
        }
        BsdfSpec::Dielectric { ior, roughness } => format!(
            "<bsdf type=\"{}dielectric\">{}<float name=\"int_ior\" value=\"{ior}\"/>\
             <float name=\"ext_ior\" value=\"1\"/></bsdf>",
            rough_prefix(roughness),
            microfacet(roughness, what)?
        ),
        BsdfSpec::ThinDielectric { ior } => format!(
            "<bsdf type=\"thindielectric\"><float name=\"int_ior\" value=\"{ior}\"/>\
             <float name=\"ext_ior\" value=\"1\"/></bsdf>"
        ),
        other => {
            return Err(ExportError::unsupported(
                what(),
                format!(
                    "its BSDF ({}) has no exact Mitsuba 3 counterpart lumo writes",
                    bsdf_kind(other)
                ),
            ))
        }
    })
}

/// The variant's name, for messages. (Not through `Debug`: that would print a bitmap
/// texture's every texel to read one word.)
fn bsdf_kind(spec: &BsdfSpec) -> &'static str {
    match spec {
        BsdfSpec::Diffuse { .. } => "Diffuse",
        BsdfSpec::Mirror { .. } => "Mirror",
        BsdfSpec::Conductor { .. } => "Conductor",
        BsdfSpec::Plastic { .. } => "Plastic",
        BsdfSpec::Dielectric { .. } => "Dielectric",
        BsdfSpec::ThinDielectric { .. } => "ThinDielectric",
        BsdfSpec::NormalMap { .. } => "NormalMap",
        BsdfSpec::BumpMap { .. } => "BumpMap",
        BsdfSpec::TwoSided { .. } => "TwoSided",
        BsdfSpec::Blend { .. } => "Blend",
        BsdfSpec::GltfPbr { .. } => "GltfPbr",
        BsdfSpec::Principled(_) => "Principled",
        BsdfSpec::Mask { .. } => "Mask",
    }
}

/// "rough" for a microfacet surface, "" for a smooth one.
fn rough_prefix(r: &Roughness) -> &'static str {
    if r.alpha_u == 0.0 && r.alpha_v == 0.0 {
        ""
    } else {
        "rough"
    }
}

/// The distribution and α of a rough surface ("" for a smooth one).
fn microfacet(r: &Roughness, what: &dyn Fn() -> String) -> Result<String, ExportError> {
    if rough_prefix(r).is_empty() {
        return Ok(String::new());
    }
    if r.maps.is_some() {
        return Err(ExportError::unsupported(
            what(),
            "roughness textures are not exported yet",
        ));
    }
    let d = match r.distribution {
        Distribution::Beckmann => "beckmann",
        Distribution::Ggx => "ggx",
    };
    Ok(if r.alpha_u == r.alpha_v {
        format!(
            "<string name=\"distribution\" value=\"{d}\"/><float name=\"alpha\" value=\"{}\"/>",
            r.alpha_u
        )
    } else {
        format!(
            "<string name=\"distribution\" value=\"{d}\"/><float name=\"alpha_u\" value=\"{}\"/>\
             <float name=\"alpha_v\" value=\"{}\"/>",
            r.alpha_u, r.alpha_v
        )
    })
}

/// A colour parameter `name` from a texture: an `<rgb>` or a `checkerboard`.
fn texture(name: &str, t: &Texture, what: &dyn Fn() -> String) -> Result<String, ExportError> {
    match t {
        Texture::Constant(c) => Ok(rgb(name, *c)),
        // lumo's squares per unit uv: `color0` where ⌊u·s⌋ + ⌊v·s⌋ is even; Mitsuba's
        // checkerboard has `color0` where frac(u) and frac(v) lie on the same side of ½, i.e.
        // two squares per unit, so its uv is scaled by s / 2.
        Texture::Checkerboard {
            color0,
            color1,
            scale,
        } => Ok(format!(
            "<texture type=\"checkerboard\" name=\"{name}\">{}{}<transform name=\"to_uv\">\
             <scale x=\"{s}\" y=\"{s}\"/></transform></texture>",
            rgb("color0", *color0),
            rgb("color1", *color1),
            s = scale * 0.5
        )),
        _ => Err(ExportError::unsupported(
            what(),
            format!("its {name} texture is not exported yet (constants and checkerboards are)"),
        )),
    }
}

/// Lights other than area lights.
fn light_element(light: &Light, out: &mut String) -> Result<(), ExportError> {
    let _ = match light {
        Light::Point {
            position,
            intensity,
            range: None,
        } => writeln!(
            out,
            "    <emitter type=\"point\"><point name=\"position\" value=\"{}\"/>{}</emitter>",
            triple(*position),
            rgb("intensity", *intensity)
        ),
        Light::Directional {
            direction,
            irradiance,
        } => writeln!(
            out,
            "    <emitter type=\"directional\"><vector name=\"direction\" value=\"{}\"/>{}</emitter>",
            triple(*direction),
            rgb("irradiance", *irradiance)
        ),
        Light::Constant { radiance } => writeln!(
            out,
            "    <emitter type=\"constant\">{}</emitter>",
            rgb("radiance", *radiance)
        ),
        Light::Point { range: Some(_), .. } => {
            return Err(ExportError::unsupported(
                "a point light with a range",
                "Mitsuba's lights reach any distance",
            ))
        }
        Light::Spot { .. } => {
            return Err(ExportError::unsupported(
                "a spot light",
                "spot lights are not exported yet",
            ))
        }
        Light::Environment(_) => {
            return Err(ExportError::unsupported(
                "the environment map",
                "environment images are not exported yet",
            ))
        }
    };
    Ok(())
}

/// `<transform name=…><matrix …/></transform>`, row by row as Mitsuba reads it.
fn matrix(name: &str, m: &Mat4, out: &mut String) {
    let rows: Vec<String> = (0..4)
        .flat_map(|r| m.row(r).to_array())
        .map(|v| v.to_string())
        .collect();
    let _ = writeln!(
        out,
        "        <transform name=\"{name}\"><matrix value=\"{}\"/></transform>",
        rows.join(" ")
    );
}

/// `<rgb name=… value="r, g, b"/>` (shortest round-trip decimals: the same f32s read back).
fn rgb(name: &str, c: Vec3) -> String {
    format!("<rgb name=\"{name}\" value=\"{}\"/>", triple(c))
}

fn triple(v: Vec3) -> String {
    format!("{}, {}, {}", v.x, v.y, v.z)
}

/// `s` with the characters XML gives a meaning escaped (names go into comments and attributes).
fn xml_text(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace("--", "- -")
}

#[cfg(test)]
#[path = "mitsuba_tests.rs"]
mod tests;
