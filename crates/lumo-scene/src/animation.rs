//! Keyframed node animation (from glTF): a node hierarchy with rest transforms, the scene items
//! each node carries, and clips of translation / rotation / scale keyframes. [`AnimatedScene::pose`]
//! places instances, lights and the camera at a time, so a dynamic renderer can play the clips.

use glam::{Mat4, Quat, Vec3, Vec4};

use crate::deform::Deformer;
use crate::{Light, Scene};

/// How values between keyframes are found (glTF's sampler interpolation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// Hold the previous key.
    Step,
    /// Linear (spherical for rotations).
    Linear,
    /// Cubic Hermite with per-key in and out tangents.
    CubicSpline,
}

/// Which part of a node's transform a channel drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AnimatedProperty {
    /// Translation (xyz).
    Translation,
    /// Rotation quaternion (xyzw).
    Rotation,
    /// Scale (xyz).
    Scale,
}

/// Keyframes of one property of one node.
#[derive(Clone, Debug)]
pub struct AnimationChannel {
    /// Index into [`AnimatedScene::nodes`].
    pub node: usize,
    /// The driven property.
    pub property: AnimatedProperty,
    /// Interpolation between keys.
    pub interpolation: Interpolation,
    /// Key times in seconds, increasing.
    pub times: Vec<f32>,
    /// Key values (xyz in the first three lanes, or a quaternion); for cubic splines three per
    /// key: in-tangent, value, out-tangent.
    pub values: Vec<Vec4>,
}

/// Keyframed morph-target weights of the mesh on one node.
#[derive(Clone, Debug)]
pub struct WeightsChannel {
    /// Index into [`AnimatedScene::nodes`].
    pub node: usize,
    /// Interpolation between keys.
    pub interpolation: Interpolation,
    /// Key times in seconds, increasing.
    pub times: Vec<f32>,
    /// Number of weights per key (the mesh's morph targets).
    pub count: usize,
    /// `count` weights per key; for cubic splines three groups per key: in-tangents, values,
    /// out-tangents.
    pub values: Vec<f32>,
}

/// A named clip.
#[derive(Clone, Debug, Default)]
pub struct Animation {
    /// Name from the file (or its index).
    pub name: String,
    /// Its channels.
    pub channels: Vec<AnimationChannel>,
    /// Its morph-weight channels.
    pub weights: Vec<WeightsChannel>,
}

impl Animation {
    /// Time of the last key.
    pub fn duration(&self) -> f32 {
        self.channels
            .iter()
            .filter_map(|c| c.times.last().copied())
            .chain(self.weights.iter().filter_map(|c| c.times.last().copied()))
            .fold(0.0, f32::max)
    }
}

/// A node of the hierarchy with its rest (unanimated) local transform.
#[derive(Clone, Debug)]
pub struct AnimatedNode {
    /// Parent node.
    pub parent: Option<usize>,
    /// Rest translation.
    pub translation: Vec3,
    /// Rest rotation.
    pub rotation: Quat,
    /// Rest scale.
    pub scale: Vec3,
}

/// What a node carries in the [`Scene`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeItem {
    /// An instance (index into `Scene::instances`).
    Instance(usize),
    /// A point, spot or directional light (index into `Scene::lights`), at the node's origin
    /// pointing along its −z.
    Light(usize),
    /// The camera, looking along the node's −z with +y up.
    Camera,
}

/// A scene's node hierarchy and clips.
#[derive(Clone, Debug, Default)]
pub struct AnimatedScene {
    /// Nodes, parents before children.
    pub nodes: Vec<AnimatedNode>,
    /// (node, item) pairs.
    pub items: Vec<(usize, NodeItem)>,
    /// The clips.
    pub animations: Vec<Animation>,
    /// Meshes that skins or morph targets deform.
    pub deformers: Vec<Deformer>,
}

impl AnimatedScene {
    /// Time of the last key of any clip, in seconds (0 without clips).
    pub fn duration(&self) -> f32 {
        self.animations
            .iter()
            .map(Animation::duration)
            .fold(0.0, f32::max)
    }

    /// Whether any clip drives a node: posing at different times can move something.
    pub fn is_animated(&self) -> bool {
        let n = self.nodes.len();
        self.animations.iter().any(|a| {
            a.channels.iter().any(|c| c.node < n && !c.times.is_empty())
                || a.weights.iter().any(|c| c.node < n && !c.times.is_empty())
        })
    }

    /// Whether posing moves `item` (a clip drives its node or one of the node's ancestors).
    pub fn moves(&self, item: NodeItem) -> bool {
        let driven: Vec<usize> = self
            .animations
            .iter()
            .flat_map(|a| &a.channels)
            .filter(|c| !c.times.is_empty())
            .map(|c| c.node)
            .collect();
        self.items
            .iter()
            .filter(|(_, i)| *i == item)
            .any(|&(node, _)| {
                // Parents come before children, so the walk up ends; the bound guards bad input.
                let mut n = Some(node);
                for _ in 0..=self.nodes.len() {
                    let Some(k) = n else { break };
                    if driven.contains(&k) {
                        return true;
                    }
                    n = self.nodes.get(k).and_then(|x| x.parent).filter(|&p| p < k);
                }
                false
            })
    }

    /// World matrix of every node with all clips applied at time `t` (rest pose for `None`).
    pub fn world_matrices(&self, t: Option<f32>) -> Vec<Mat4> {
        let mut local: Vec<(Vec3, Quat, Vec3)> = self
            .nodes
            .iter()
            .map(|n| (n.translation, n.rotation, n.scale))
            .collect();
        if let Some(t) = t {
            for c in self.animations.iter().flat_map(|a| &a.channels) {
                let Some(l) = local.get_mut(c.node) else {
                    continue;
                };
                let Some(v) = sample(c, t) else { continue };
                match c.property {
                    AnimatedProperty::Translation => l.0 = v.truncate(),
                    AnimatedProperty::Rotation => l.1 = Quat::from_vec4(v).normalize(),
                    AnimatedProperty::Scale => l.2 = v.truncate(),
                }
            }
        }
        let mut world = vec![Mat4::IDENTITY; self.nodes.len()];
        for (i, n) in self.nodes.iter().enumerate() {
            let (t, r, s) = local[i];
            let m = Mat4::from_scale_rotation_translation(s, r, t);
            world[i] = match n.parent {
                Some(p) if p < i => world[p] * m,
                _ => m,
            };
        }
        world
    }

    /// Moves the scene's instances, lights and camera to their places at time `t`, and
    /// rewrites the positions and normals of the meshes that skins and morph targets deform.
    /// Returns the indices of those meshes (for [`Scene`] users that refit).
    pub fn pose(&self, scene: &mut Scene, t: Option<f32>) -> Vec<usize> {
        let world = self.world_matrices(t);
        let mut deformed = Vec::with_capacity(self.deformers.len());
        for d in &self.deformers {
            let weights = t.and_then(|t| self.morph_weights(d.node, t));
            let Some(mesh) = scene.meshes.get_mut(d.mesh) else {
                continue;
            };
            (mesh.positions, mesh.normals) = d.deform(&world, weights.as_deref());
            deformed.push(d.mesh);
        }
        for &(node, item) in &self.items {
            let Some(m) = world.get(node) else { continue };
            match item {
                NodeItem::Instance(i) => {
                    if let Some(inst) = scene.instances.get_mut(i) {
                        inst.transform = *m;
                    }
                }
                NodeItem::Light(l) => {
                    let pos = m.transform_point3(Vec3::ZERO);
                    let dir = m.transform_vector3(-Vec3::Z).normalize_or_zero();
                    match scene.lights.get_mut(l) {
                        Some(Light::Point { position, .. }) => *position = pos,
                        Some(Light::Spot {
                            position,
                            direction,
                            ..
                        }) => {
                            *position = pos;
                            *direction = dir;
                        }
                        Some(Light::Directional { direction, .. }) => *direction = dir,
                        _ => {}
                    }
                }
                NodeItem::Camera => {
                    let origin = m.transform_point3(Vec3::ZERO);
                    let forward = m.transform_vector3(-Vec3::Z).normalize_or_zero();
                    scene.camera.origin = origin;
                    scene.camera.target = origin + forward;
                    scene.camera.up = m.transform_vector3(Vec3::Y);
                }
            }
        }
        deformed
    }

    /// The morph weights a clip gives `node` at time `t` (the last clip driving it wins, as
    /// for transforms); `None` where no clip drives them.
    fn morph_weights(&self, node: usize, t: f32) -> Option<Vec<f32>> {
        self.animations
            .iter()
            .flat_map(|a| &a.weights)
            .rev()
            .filter(|c| c.node == node)
            .find_map(|c| sample_weights(c, t))
    }
}

/// Where `t` falls among `times`: the key before it, the fraction of the way to the next
/// and the gap; `Err(k)` where `t` is clamped to key `k`. `times` must not be empty.
fn segment(times: &[f32], t: f32) -> Result<(usize, f32, f32), usize> {
    let n = times.len();
    if t <= times[0] || n == 1 {
        return Err(0);
    }
    if t >= times[n - 1] {
        return Err(n - 1);
    }
    let k = times.partition_point(|&x| x <= t).clamp(1, n - 1) - 1;
    let dt = times[k + 1] - times[k];
    let s = if dt > 0.0 { (t - times[k]) / dt } else { 0.0 };
    Ok((k, s, dt))
}

/// Cubic Hermite basis weights (value 0, out-tangent 0, value 1, in-tangent 1) at `s`.
fn hermite(s: f32, dt: f32) -> [f32; 4] {
    let (s2, s3) = (s * s, s * s * s);
    [
        2.0 * s3 - 3.0 * s2 + 1.0,
        dt * (s3 - 2.0 * s2 + s),
        -2.0 * s3 + 3.0 * s2,
        dt * (s3 - s2),
    ]
}

/// The weights channel's values at `t`; `None` for an empty or malformed channel.
fn sample_weights(c: &WeightsChannel, t: f32) -> Option<Vec<f32>> {
    let per_key = if c.interpolation == Interpolation::CubicSpline {
        3
    } else {
        1
    };
    let n = c.count;
    if c.times.is_empty() || c.values.len() != c.times.len() * per_key * n {
        return None;
    }
    // Group `g` (0 in-tangent, 1 value, 2 out-tangent for splines) of key `k`.
    let group = |k: usize, g: usize| {
        let at = (k * per_key + g) * n;
        &c.values[at..at + n]
    };
    let mid = per_key / 2;
    let (k, s, dt) = match segment(&c.times, t) {
        Err(k) => return Some(group(k, mid).to_vec()),
        Ok(seg) => seg,
    };
    Some(match c.interpolation {
        Interpolation::Step => group(k, mid).to_vec(),
        Interpolation::Linear => {
            let (a, b) = (group(k, 0), group(k + 1, 0));
            a.iter().zip(b).map(|(a, b)| a + (b - a) * s).collect()
        }
        Interpolation::CubicSpline => {
            let h = hermite(s, dt);
            let (v0, out0, v1, in1) = (group(k, 1), group(k, 2), group(k + 1, 1), group(k + 1, 0));
            (0..n)
                .map(|i| v0[i] * h[0] + out0[i] * h[1] + v1[i] * h[2] + in1[i] * h[3])
                .collect()
        }
    })
}

/// The channel's value at `t` (clamped to its key range); `None` for an empty channel.
fn sample(c: &AnimationChannel, t: f32) -> Option<Vec4> {
    let n = c.times.len();
    let per_key = if c.interpolation == Interpolation::CubicSpline {
        3
    } else {
        1
    };
    if n == 0 || c.values.len() < n * per_key {
        return None;
    }
    let value = |k: usize| c.values[k * per_key + (per_key / 2)];
    let (k, s, dt) = match segment(&c.times, t) {
        Err(k) => return Some(value(k)),
        Ok(seg) => seg,
    };
    let rotation = c.property == AnimatedProperty::Rotation;
    Some(match c.interpolation {
        Interpolation::Step => value(k),
        Interpolation::Linear if rotation => {
            let (a, b) = (Quat::from_vec4(value(k)), Quat::from_vec4(value(k + 1)));
            Vec4::from(a.normalize().slerp(b.normalize(), s))
        }
        Interpolation::Linear => value(k).lerp(value(k + 1), s),
        Interpolation::CubicSpline => {
            let h = hermite(s, dt);
            value(k) * h[0]
                + c.values[k * 3 + 2] * h[1]
                + value(k + 1) * h[2]
                + c.values[(k + 1) * 3] * h[3]
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(interpolation: Interpolation, values: Vec<Vec4>) -> AnimationChannel {
        AnimationChannel {
            node: 0,
            property: AnimatedProperty::Translation,
            interpolation,
            times: vec![0.0, 2.0],
            values,
        }
    }

    #[test]
    fn linear_step_and_clamping() {
        let c = channel(
            Interpolation::Linear,
            vec![Vec4::ZERO, Vec4::new(2.0, 4.0, 0.0, 0.0)],
        );
        assert_eq!(sample(&c, 1.0), Some(Vec4::new(1.0, 2.0, 0.0, 0.0)));
        assert_eq!(sample(&c, -1.0), Some(Vec4::ZERO));
        assert_eq!(sample(&c, 5.0), Some(Vec4::new(2.0, 4.0, 0.0, 0.0)));
        let c = channel(Interpolation::Step, vec![Vec4::ZERO, Vec4::ONE]);
        assert_eq!(sample(&c, 1.9), Some(Vec4::ZERO));
    }

    #[test]
    fn cubic_spline_with_zero_tangents_is_smoothstep() {
        let z = Vec4::ZERO;
        let c = channel(Interpolation::CubicSpline, vec![z, z, z, z, Vec4::ONE, z]);
        let v = sample(&c, 0.5).unwrap();
        // s = 0.25: 3s² − 2s³ = 0.15625.
        assert!((v.x - 0.15625).abs() < 1e-6, "{v}");
    }

    #[test]
    fn weights_interpolate_per_target_like_the_transform_channels() {
        let c = |interpolation, values: Vec<f32>| WeightsChannel {
            node: 0,
            interpolation,
            times: vec![0.0, 2.0],
            count: 2,
            values,
        };
        let linear = c(Interpolation::Linear, vec![0.0, 1.0, 1.0, 3.0]);
        assert_eq!(sample_weights(&linear, 0.5), Some(vec![0.25, 1.5]));
        assert_eq!(sample_weights(&linear, 9.0), Some(vec![1.0, 3.0]));
        let step = c(Interpolation::Step, vec![0.0, 1.0, 1.0, 3.0]);
        assert_eq!(sample_weights(&step, 1.9), Some(vec![0.0, 1.0]));
        // Per key: in-tangents, values, out-tangents; zero tangents give smoothstep.
        let mut values = vec![0.0; 12];
        values[8..10].copy_from_slice(&[1.0, 2.0]);
        let cubic = c(Interpolation::CubicSpline, values);
        let w = sample_weights(&cubic, 0.5).unwrap();
        assert!(
            (w[0] - 0.15625).abs() < 1e-6 && (w[1] - 0.3125).abs() < 1e-6,
            "{w:?}"
        );
        // A wrong value count samples nothing rather than reading out of range.
        assert_eq!(
            sample_weights(&c(Interpolation::Linear, vec![0.0; 3]), 1.0),
            None
        );
    }

    #[test]
    fn parent_transforms_compose() {
        let scene = AnimatedScene {
            nodes: vec![
                AnimatedNode {
                    parent: None,
                    translation: Vec3::X,
                    rotation: Quat::IDENTITY,
                    scale: Vec3::splat(2.0),
                },
                AnimatedNode {
                    parent: Some(0),
                    translation: Vec3::Y,
                    rotation: Quat::IDENTITY,
                    scale: Vec3::ONE,
                },
            ],
            items: vec![],
            deformers: vec![],
            animations: vec![Animation {
                weights: vec![],
                name: "a".into(),
                channels: vec![AnimationChannel {
                    node: 1,
                    ..channel(
                        Interpolation::Linear,
                        vec![Vec4::ZERO, Vec4::new(0.0, 0.0, 2.0, 0.0)],
                    )
                }],
            }],
        };
        let rest = scene.world_matrices(None);
        assert_eq!(
            rest[1].transform_point3(Vec3::ZERO),
            Vec3::new(1.0, 2.0, 0.0)
        );
        let posed = scene.world_matrices(Some(1.0));
        assert_eq!(
            posed[1].transform_point3(Vec3::ZERO),
            Vec3::new(1.0, 0.0, 2.0)
        );
    }
}
