//! Scene edits from the viewer: what a pick finds under a pixel, which edits a scene accepts,
//! and applying them to the render scene between renders.
//!
//! A pick casts the camera ray through the pixel on the server (the viewer only has colour:
//! no id plane travels, and one ray costs microseconds), so the answer is exact for any
//! integrator or mode. Edits carry absolute values and are checked twice: their numbers by
//! [`Edit::validate`] when decoded, their index and kind against the scene by
//! [`EditTargets::check`] before the hub queues them, so the worker applies only edits that
//! succeed.

use std::sync::Arc;

use glam::{Vec2, Vec3};
use lumo_render::{camera::PinholeCamera, RenderScene, SceneUpdate};
use lumo_scene::{AnimatedScene, BsdfSpec, Camera, Light, Material, SceneError, Texture};

use crate::protocol::{Edit, EditOp, ErrorCode, PickHit, PickTarget, ProtocolError};

/// Pixels from the click within which a point or spot light is picked (they have no surface a
/// ray could hit).
pub const LIGHT_PICK_RADIUS: f32 = 16.0;

/// What the scene offers to edit: counts and kinds, taken once (edits never change them).
#[derive(Clone, Debug)]
pub struct EditTargets {
    instances: usize,
    /// Per light: whether it has a position (point, spot) and an intensity (not an
    /// environment map).
    lights: Vec<(bool, bool)>,
    /// Per material: whether it has a base colour.
    colored: Vec<bool>,
}

impl EditTargets {
    /// The targets of `rs`.
    pub fn of(rs: &RenderScene) -> Self {
        let s = &rs.scene;
        Self {
            instances: s.instances.len(),
            lights: s
                .lights
                .iter()
                .map(|l| (l.position().is_some(), l.intensity().is_some()))
                .collect(),
            colored: s
                .materials
                .iter()
                .map(|m| base_color(m, Vec2::ZERO).is_some())
                .collect(),
        }
    }

    /// Refuses an edit whose index is not in the scene or whose target cannot take it (a
    /// directional light has no position, a glass no base colour).
    pub fn check(&self, e: &Edit) -> Result<(), ProtocolError> {
        let i = e.index as usize;
        let invalid = |m: String| Err(ProtocolError::new(ErrorCode::InvalidValue, m));
        let (what, count) = match e.op {
            EditOp::MoveInstance => ("instance", self.instances),
            EditOp::MoveLight | EditOp::LightIntensity => ("light", self.lights.len()),
            EditOp::Emission | EditOp::BaseColor => ("material", self.colored.len()),
        };
        if i >= count {
            return invalid(format!(
                "edit: {what} {i} does not exist (the scene has {count})"
            ));
        }
        match e.op {
            EditOp::MoveLight if !self.lights[i].0 => {
                invalid(format!("edit: light {i} has no position (only point and spot lights move)"))
            }
            EditOp::LightIntensity if !self.lights[i].1 => {
                invalid(format!("edit: light {i} is an environment (only point, spot and directional lights take an intensity)"))
            }
            EditOp::BaseColor if !self.colored[i] => invalid(format!(
                "edit: material {i} has no base colour (only diffuse, plastic and mirror do)"
            )),
            _ => Ok(()),
        }
    }
}

/// Whether an edit changes the lighting everywhere (intensity, emission): the temporal
/// history's illumination is then stale in every pixel. Moves and base colours leave it valid
/// where the reprojection's depth and normal tests pass (the history holds colour / albedo).
pub fn relights(e: &Edit) -> bool {
    matches!(e.op, EditOp::LightIntensity | EditOp::Emission)
}

/// A material's base colour at `uv`, if it has one.
fn base_color(m: &Material, uv: Vec2) -> Option<Vec3> {
    Some(m.bsdf.base_color()?.at(uv))
}

/// What is under image position `uv` ∈ [0,1]² of a `width`×`height` view through `camera`:
/// the nearest surface hit, or a point or spot light drawn within [`LIGHT_PICK_RADIUS`] pixels
/// of it and in front of that surface.
pub fn pick(
    rs: &RenderScene,
    camera: &Camera,
    width: usize,
    height: usize,
    uv: [f32; 2],
) -> PickHit {
    let cam = PinholeCamera::new(camera, width, height);
    let film = Vec2::new(uv[0] * width as f32, uv[1] * height as f32);
    let (origin, dir) = (cam.origin(), cam.direction(film));
    let hit = rs.accel.intersect(origin, dir, 0.0, f32::INFINITY);
    let depth = hit.map_or(f32::INFINITY, |h| h.t);
    let s = &rs.scene;
    let light = s
        .lights
        .iter()
        .enumerate()
        .filter_map(|(i, l)| {
            let p = l.position()?;
            let (at, _) = cam.project_point(p)?;
            let d = at.distance(film);
            (d <= LIGHT_PICK_RADIUS && p.distance(origin) < depth).then_some((i, l, p, d))
        })
        .min_by(|a, b| a.3.total_cmp(&b.3));
    if let Some((i, l, p, _)) = light {
        let kind = if matches!(l, Light::Spot { .. }) {
            "spot"
        } else {
            "point"
        };
        return PickHit {
            target: PickTarget::Light,
            index: i as u32,
            position: p,
            point: p,
            emission: l.intensity().unwrap_or(Vec3::ZERO),
            name: format!("{kind} light {i}"),
            ..PickHit::nothing()
        };
    }
    let Some(h) = hit else {
        return PickHit::nothing();
    };
    let surface = rs.surface(&h, origin, dir);
    let inst = &s.instances[h.instance as usize];
    let material = &s.materials[surface.material];
    let color = base_color(material, surface.uv);
    PickHit {
        target: PickTarget::Object,
        has_color: color.is_some(),
        index: h.instance,
        mesh: inst.mesh as u32,
        material: surface.material as u32,
        position: inst.transform.w_axis.truncate(),
        point: origin + dir * h.t,
        color: color.unwrap_or(Vec3::ZERO),
        emission: material.emission,
        name: format!("{} · {}", s.meshes[inst.mesh].name, material.name),
    }
}

/// Applies `edits` (checked by [`EditTargets::check`]) to the scene and brings the render
/// scene up to date: a moved instance is re-placed in the two-level BVH, lights and the
/// per-instance tables are recomputed ([`RenderScene::update`]). Checked edits cannot fail
/// (a translation keeps a transform invertible); an unchecked one that does not fit the scene
/// is an error, with the edits before it applied.
pub fn apply(rs: &mut RenderScene, edits: &[Edit]) -> Result<SceneUpdate, SceneError> {
    for e in edits {
        let i = e.index as usize;
        let s = &mut rs.scene;
        let bad = || {
            SceneError::Invalid(format!(
                "edit {:?} of index {i} does not fit the scene",
                e.op
            ))
        };
        match e.op {
            EditOp::MoveInstance => {
                let inst = s.instances.get_mut(i).ok_or_else(bad)?;
                inst.transform.w_axis = e.value.extend(1.0);
            }
            EditOp::MoveLight => {
                let p = s.lights.get_mut(i).and_then(Light::position_mut);
                *p.ok_or_else(bad)? = e.value;
            }
            EditOp::LightIntensity => {
                let v = s.lights.get_mut(i).and_then(Light::intensity_mut);
                *v.ok_or_else(bad)? = e.value;
            }
            EditOp::Emission => {
                let m = s.materials.get_mut(i).ok_or_else(bad)?;
                m.emission = e.value;
                // A per-texel emission would override the constant; the edit sets one value.
                m.emission_map = None;
            }
            EditOp::BaseColor => {
                let m = s.materials.get_mut(i).ok_or_else(bad)?;
                match m.bsdf.innermost_mut() {
                    BsdfSpec::Diffuse { reflectance } => *reflectance = Texture::Constant(e.value),
                    BsdfSpec::Plastic { diffuse, .. } => *diffuse = Texture::Constant(e.value),
                    BsdfSpec::GltfPbr { base_color, .. } => {
                        *base_color = Texture::Constant(e.value)
                    }
                    BsdfSpec::Mirror { reflectance } => *reflectance = e.value,
                    BsdfSpec::Principled(p) => {
                        std::sync::Arc::make_mut(p).base_color = Texture::Constant(e.value)
                    }
                    // No single colour to set (η and k, glass, two branches); the adapters
                    // are not innermost.
                    BsdfSpec::Conductor { .. }
                    | BsdfSpec::Dielectric { .. }
                    | BsdfSpec::ThinDielectric { .. }
                    | BsdfSpec::TwoSided { .. }
                    | BsdfSpec::Blend { .. }
                    | BsdfSpec::NormalMap { .. }
                    | BsdfSpec::BumpMap { .. }
                    | BsdfSpec::Mask { .. } => return Err(bad()),
                }
            }
        }
    }
    rs.update(&[])
}

/// Poses `rig` at `t` in `rs`, in place: the render threads dropped their references before
/// saying they were done ([`start`]), so the worker holds the only one.
/// Returns whether the scene is now at `t`.
pub(crate) fn pose(rs: &mut Arc<RenderScene>, rig: &AnimatedScene, t: f32) -> bool {
    match Arc::get_mut(rs) {
        Some(scene) => match pose_or_keep(scene, rig, t) {
            Ok(()) => true,
            Err(e) => {
                eprintln!("warning: animation at t = {t} s cannot be rendered ({e}); the scene stays at its last pose");
                false
            }
        },
        None => {
            eprintln!("warning: the scene is shared; animation frame at t = {t} s skipped");
            false
        }
    }
}

/// [`RenderScene::pose`], restoring the previous instance transforms and lights when the pose
/// is invalid (a singular transform in a clip), so the scene stays consistent.
fn pose_or_keep(
    scene: &mut RenderScene,
    rig: &AnimatedScene,
    t: f32,
) -> Result<(), lumo_scene::SceneError> {
    let before = (scene.scene.instances.clone(), scene.scene.lights.clone());
    if let Err(e) = scene.pose(rig, t) {
        (scene.scene.instances, scene.scene.lights) = before;
        return Err(e);
    }
    Ok(())
}

/// Applies checked `edits` in place (the worker holds the only reference between renders, as
/// for [`pose`]). Returns whether they were applied; a failure is reported and the scene keeps
/// what it had.
pub(crate) fn edit(rs: &mut Arc<RenderScene>, edits: &[Edit]) -> bool {
    let Some(scene) = Arc::get_mut(rs) else {
        eprintln!(
            "warning: the scene is shared; {} edit(s) skipped",
            edits.len()
        );
        return false;
    };
    match apply(scene, edits) {
        Ok(_) => true,
        Err(e) => {
            eprintln!("warning: an edit could not be applied ({e})");
            false
        }
    }
}
