//! Checks every loader runs on its meshes: degenerate triangles are dropped with a warning,
//! non-finite or out-of-range data is an error naming the file, and lights that cannot emit are
//! reported.

use std::path::Path;

use super::{Diagnostics, LoadError, Location};
use crate::{Light, Mesh, Scene, MAX_EMISSION};
use glam::Vec3;

/// `v`, an emitted radiance, intensity or irradiance (`what`, as the file names it), if it is
/// finite and at most [`MAX_EMISSION`]; else an error at `at` saying so.
pub(crate) fn check_emission(at: &Location, what: &str, v: Vec3) -> Result<Vec3, LoadError> {
    if !v.is_finite() || v.max_element() > MAX_EMISSION {
        return Err(LoadError::invalid(
            at.clone(),
            format!(
                "{what} [{:e}, {:e}, {:e}] is {}; the renderer's sums overflow beyond \
                 {MAX_EMISSION:e} per channel: scale the light down (and the exposure up)",
                v.x,
                v.y,
                v.z,
                if v.is_finite() {
                    "too bright"
                } else {
                    "not finite (an f32 overflow)"
                }
            ),
        ));
    }
    Ok(v)
}

/// `light` if its strength passes [`check_emission`], the field named `field` (or, with
/// `None`, the name [`Light::strength`] gives).
pub(crate) fn check_light(
    at: &Location,
    field: Option<&str>,
    light: Light,
) -> Result<Light, LoadError> {
    let (name, v) = light.strength();
    check_emission(at, field.unwrap_or(name), v)?;
    Ok(light)
}

/// Validates a freshly read mesh: indices in range and finite positions are errors (with the
/// triangle or vertex number), zero-area triangles are removed with one warning per mesh.
pub(crate) fn check_mesh(
    mesh: &mut Mesh,
    at: &Location,
    diag: &mut Diagnostics,
) -> Result<(), LoadError> {
    let n = mesh.positions.len();
    if let Some(i) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(LoadError::invalid(
            at.clone(),
            format!(
                "mesh {:?}: vertex {i} has a non-finite position ({}, {}, {}); fix or remove \
                 that vertex",
                mesh.name, mesh.positions[i].x, mesh.positions[i].y, mesh.positions[i].z
            ),
        ));
    }
    for (t, tri) in mesh.indices.iter().enumerate() {
        if let Some(&bad) = tri.iter().find(|&&i| i as usize >= n) {
            return Err(LoadError::invalid(
                at.clone(),
                format!(
                    "mesh {:?}: face {t} uses vertex {bad} but there are only {n} vertices",
                    mesh.name
                ),
            ));
        }
    }
    // Non-finite normals or uvs are recoverable: drop the attribute rather than the mesh.
    if mesh.normals.iter().any(|v| !v.is_finite()) {
        mesh.normals.clear();
        diag.warn(
            at.clone(),
            format!(
                "mesh {:?}: non-finite normals; using flat shading",
                mesh.name
            ),
        )?;
    }
    if mesh.colors.iter().any(|v| !v.is_finite()) {
        mesh.colors.clear();
        diag.warn(
            at.clone(),
            format!("mesh {:?}: non-finite vertex colours; dropped", mesh.name),
        )?;
    }
    if mesh.tangents.iter().any(|t| !t.is_finite()) {
        mesh.tangents.clear();
        diag.warn(
            at.clone(),
            format!(
                "mesh {:?}: non-finite tangents; normal maps take their frame from the uvs",
                mesh.name
            ),
        )?;
    }
    if mesh.alphas.iter().any(|a| !a.is_finite()) {
        mesh.alphas.clear();
        diag.warn(
            at.clone(),
            format!("mesh {:?}: non-finite vertex alpha; read as 1", mesh.name),
        )?;
    }
    if mesh.uvs.iter().any(|v| !v.is_finite()) {
        mesh.uvs.clear();
        diag.warn(
            at.clone(),
            format!(
                "mesh {:?}: non-finite texture coordinates; dropped",
                mesh.name
            ),
        )?;
    }
    let before = mesh.indices.len();
    let positions = &mesh.positions;
    mesh.indices.retain(|&[a, b, c]| {
        let (a, b, c) = (
            positions[a as usize],
            positions[b as usize],
            positions[c as usize],
        );
        (b - a).cross(c - a).length_squared() > 0.0
    });
    let dropped = before - mesh.indices.len();
    if dropped > 0 {
        diag.warn(
            at.clone(),
            format!(
                "mesh {:?}: {dropped} of {before} triangles are degenerate (zero area) and were skipped",
                mesh.name
            ),
        )?;
    }
    Ok(())
}

/// Scene-level checks: emissive materials whose meshes have no area.
pub(crate) fn check_scene(
    path: &Path,
    scene: &Scene,
    diag: &mut Diagnostics,
) -> Result<(), LoadError> {
    for (mi, material) in scene.materials.iter().enumerate() {
        if !material.is_emissive() {
            continue;
        }
        let mut used = false;
        let mut area = 0.0f32;
        for inst in &scene.instances {
            let Some(mesh) = scene.meshes.get(inst.mesh) else {
                continue;
            };
            if mesh.material != mi {
                continue;
            }
            used = true;
            for t in 0..mesh.triangle_count() {
                let [a, b, c] = mesh.triangle(t).map(|p| inst.transform.transform_point3(p));
                area += 0.5 * (b - a).cross(c - a).length();
            }
        }
        if used && area <= 0.0 {
            diag.warn(
                Location::file(path),
                format!(
                    "emissive material {:?} is on surfaces of zero area and emits nothing",
                    material.name
                ),
            )?;
        }
    }
    check_extent(path, scene, diag)
}

/// Smallest scene size (largest side of its bounds) the renderer's ray offsets suit: they
/// move a ray's origin by 1e-4 units near the origin, a tenth of a 1e-3 object (whose box
/// rendered 14 % off; from 1e-2 to 1e8 the same box gives the same pixels).
const MIN_EXTENT: f32 = 1e-2;
/// Largest distance from the origin a scene may reach: at 1e10 the box above rendered
/// mostly black, and past about 1e19 squared distances overflow single precision.
const MAX_REACH: f32 = 1e8;

/// Warns when the scene's size or its distance from the origin is outside the range the
/// renderer's single-precision rays and offsets suit, instead of a silently wrong image.
fn check_extent(path: &Path, scene: &Scene, diag: &mut Diagnostics) -> Result<(), LoadError> {
    // The instances' boxes (a bound under rotation) rather than every placed vertex: a
    // scene of many instances of a large mesh is checked in one pass over the mesh.
    let mut lo = Vec3::INFINITY;
    let mut hi = Vec3::NEG_INFINITY;
    for (l, h) in scene.instance_boxes().into_iter().flatten() {
        if !(l.is_finite() && h.is_finite()) {
            // Not finite: `Scene::validate` refuses the scene with the instance's name.
            return Ok(());
        }
        (lo, hi) = (lo.min(l), hi.max(h));
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return Ok(());
    }
    let size = (hi - lo).max_element();
    let reach = lo.abs().max(hi.abs()).max_element();
    if size < MIN_EXTENT {
        diag.warn(
            Location::file(path),
            format!(
                "the scene is only {size:e} units across; lumo's ray offsets suit scenes from \
                 {MIN_EXTENT:e} to {MAX_REACH:e} units, so shadows and contacts would be wrong: \
                 scale it up (e.g. a <scale> in the shapes' to_world, or in the modelling tool)"
            ),
        )?;
    } else if reach > MAX_REACH {
        diag.warn(
            Location::file(path),
            format!(
                "the scene reaches {reach:e} units from the origin; lumo's single-precision rays \
                 suit scenes within {MAX_REACH:e} units, so surfaces may turn black or vanish: \
                 scale it down or move it to the origin"
            ),
        )?;
    }
    Ok(())
}
