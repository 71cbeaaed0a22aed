//! glTF skins and morph targets: linear blend skinning and morphing checked against values
//! worked out by hand, animated weights, and bad skin and morph data refused or warned about.

use std::path::{Path, PathBuf};

use crate::common::builder::Builder;
use crate::common::{load, temp_dir};
use lumo_scene::load::{load_scene, LoadOptions};
use lumo_scene::{Mat4, Vec3};

/// The bar's vertices: columns at x = 0, 1, 2, each at y = −0.1 and +0.1.
const BAR: [[f32; 3]; 6] = [
    [0.0, -0.1, 0.0],
    [0.0, 0.1, 0.0],
    [1.0, -0.1, 0.0],
    [1.0, 0.1, 0.0],
    [2.0, -0.1, 0.0],
    [2.0, 0.1, 0.0],
];

/// Skin data of the bar file; the defaults are a valid two-joint bend.
struct Bar {
    joints: Vec<u16>,
    weights: Option<Vec<f32>>,
    inverse_bind: Vec<f32>,
    skin_joints: &'static str,
    /// A second influence set (JOINTS_1, WEIGHTS_1).
    second: Option<(Vec<u16>, Vec<f32>)>,
}

impl Default for Bar {
    fn default() -> Self {
        let mut joints = Vec::new();
        let mut weights = Vec::new();
        // Column 0 follows joint 0, column 1 both (unnormalised 1 + 1), column 2 joint 1.
        for w in [[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] {
            for _ in 0..2 {
                joints.extend([0, 1, 0, 0]);
                weights.extend([w[0], w[1], 0.0, 0.0]);
            }
        }
        let mut inverse_bind = Mat4::IDENTITY.to_cols_array().to_vec();
        inverse_bind.extend(Mat4::from_translation(Vec3::new(-0.5, 0.0, 0.0)).to_cols_array());
        Bar {
            joints,
            weights: Some(weights),
            inverse_bind,
            skin_joints: "[1, 2]",
            second: None,
        }
    }
}

/// A bar skinned to two joints: node 1 at the origin and its child node 2 at x = 0.5, which
/// turns from 0° to 90° about +y in one second. The mesh's own node is moved by (5, 5, 5),
/// which glTF says skinning ignores. Node 3 is outside the scene.
fn bar(dir: &Path, name: &str, bar: Bar) -> PathBuf {
    let mut b = Builder::default();
    let flat: Vec<f32> = BAR.iter().flatten().copied().collect();
    let pos = b.floats(&flat, "VEC3");
    let nrm = b.floats(&[0.0, 0.0, 1.0].repeat(6), "VEC3");
    let idx = b.u16s(&[0, 2, 1, 1, 2, 3, 2, 4, 3, 3, 4, 5], "SCALAR");
    let joints = b.u16s(&bar.joints, "VEC4");
    let weights = bar
        .weights
        .map(|w| format!(r#", "WEIGHTS_0": {}"#, b.floats(&w, "VEC4")))
        .unwrap_or_default();
    let ibm = b.floats(&bar.inverse_bind, "MAT4");
    let second = bar
        .second
        .map(|(j, w)| {
            let (j, w) = (b.u16s(&j, "VEC4"), b.floats(&w, "VEC4"));
            format!(r#", "JOINTS_1": {j}, "WEIGHTS_1": {w}"#)
        })
        .unwrap_or_default();
    let times = b.floats(&[0.0, 1.0], "SCALAR");
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let turns = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, s, 0.0, s], "VEC4");
    let rest = format!(
        r#""scenes": [{{"nodes": [0, 1]}}],
        "nodes": [{{"mesh": 0, "skin": 0, "translation": [5, 5, 5]}}, {{"children": [2]}},
                  {{"translation": [0.5, 0, 0]}}, {{"name": "elsewhere"}}],
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": {pos}, "NORMAL": {nrm},
                   "JOINTS_0": {joints}{weights}{second}}}, "indices": {idx}}}]}}],
        "skins": [{{"joints": {}, "inverseBindMatrices": {ibm}}}],
        "animations": [{{"samplers": [{{"input": {times}, "output": {turns}}}],
                         "channels": [{{"sampler": 0, "target": {{"node": 2, "path": "rotation"}}}}]}}]"#,
        bar.skin_joints
    );
    b.write(dir, name, &rest)
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

/// Linear blend skinning of the bar at the rest pose, at 90° (t = 1) and half way (45°, the
/// rotation keys slerped): each vertex is the weighted sum of its joints' transforms (world ×
/// inverse bind) applied to it, worked out by hand here.
#[test]
fn a_two_joint_bend_matches_hand_computed_blend_skinning() {
    let dir = temp_dir("skin-bend");
    let path = bar(&dir, "bar.gltf", Bar::default());
    let loaded = load(&path).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let rig = loaded.animation.expect("rig");
    assert!(rig.is_animated());
    let mut scene = loaded.scene;
    // The still is the bind pose, the node's (5, 5, 5) ignored; the instance stays put.
    assert_eq!(scene.instances.len(), 1);
    assert_eq!(scene.instances[0].transform, Mat4::IDENTITY);
    let mesh = scene.instances[0].mesh;
    for (p, want) in scene.meshes[mesh].positions.iter().zip(BAR) {
        assert!(close(*p, Vec3::from(want)), "{p} vs {want:?}");
    }
    let moved = rig.pose(&mut scene, Some(1.0));
    assert_eq!(moved, vec![mesh]);
    let m = &scene.meshes[mesh];
    for (v, y) in [(0, -0.1), (1, 0.1)] {
        // Column 0: joint 0 only, which stays.
        assert!(close(m.positions[v], Vec3::new(0.0, y, 0.0)), "{v}");
        // Column 1, half each: (1, y, 0) and, turned about x = 0.5, (0.5, y, −0.5).
        let p = m.positions[v + 2];
        assert!(close(p, Vec3::new(0.75, y, -0.25)), "{}: {p}", v + 2);
        // Column 2, joint 1: (2, y, 0) turned 90° about y through x = 0.5.
        let p = m.positions[v + 4];
        assert!(close(p, Vec3::new(0.5, y, -1.5)), "{}: {p}", v + 4);
    }
    // Normals: +z turned with joint 1 to +x; half way between, the inverse transpose of
    // ½(I + R) turns it by 45°.
    assert!(close(m.normals[4], Vec3::X), "{}", m.normals[4]);
    assert!(close(m.normals[2], Vec3::new(1.0, 0.0, 1.0).normalize()));
    assert!(close(m.normals[0], Vec3::Z));
    // t = 0.5: 45°.
    rig.pose(&mut scene, Some(0.5));
    let c = std::f32::consts::FRAC_1_SQRT_2 * 1.5;
    let p = scene.meshes[mesh].positions[5];
    assert!(close(p, Vec3::new(0.5 + c, 0.1, -c)), "{p}");
    // Back at rest.
    rig.pose(&mut scene, None);
    assert!(close(scene.meshes[mesh].positions[5], Vec3::from(BAR[5])));
    // A still at --time 1 is the pose at t = 1.
    let options = LoadOptions {
        time: Some(1.0),
        ..Default::default()
    };
    let posed = load_scene(&path, &options).unwrap().scene;
    let p = posed.meshes[posed.instances[0].mesh].positions[4];
    assert!(close(p, Vec3::new(0.5, -0.1, -1.5)), "{p}");
}

/// A second influence set counts as four more influences: column 1's two joints split across
/// JOINTS_0 and JOINTS_1 bend it as one set did.
#[test]
fn a_second_joints_set_adds_influences() {
    let dir = temp_dir("skin-second");
    let mut b = Bar::default();
    let (mut j1, mut w1) = (vec![0; 24], vec![0.0; 24]);
    for v in [2, 3] {
        b.weights.as_mut().unwrap()[4 * v + 1] = 0.0;
        j1[4 * v] = 1;
        w1[4 * v] = 1.0;
    }
    b.second = Some((j1, w1));
    let loaded = load(&bar(&dir, "second.gltf", b)).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let mut scene = loaded.scene;
    loaded.animation.unwrap().pose(&mut scene, Some(1.0));
    let p = scene.meshes[0].positions[3];
    assert!(close(p, Vec3::new(0.75, 0.1, -0.25)), "{p}");
}

/// Vertices whose weights sum to zero follow the mesh's node (warned); a joint index beyond
/// the skin's joints, a joint outside the scene, JOINTS without WEIGHTS, NaN or negative
/// weights and singular or non-finite bind matrices are refused, naming the file and field.
#[test]
fn bad_skins_are_refused_or_warned() {
    let dir = temp_dir("skin-bad");
    let mut zero = Bar::default();
    zero.weights.as_mut().unwrap()[..8].fill(0.0);
    let loaded = load(&bar(&dir, "zero.gltf", zero)).unwrap();
    let w: Vec<String> = loaded.warnings.iter().map(|w| w.to_string()).collect();
    assert!(
        w.iter().any(|w| w.contains("zero.gltf")
            && w.contains("2 of 6 vertices")
            && w.contains("WEIGHTS_0")),
        "{w:?}"
    );
    let s = loaded.scene;
    let p = s.meshes[s.instances[0].mesh].positions[0];
    assert!(close(p, Vec3::new(5.0, 4.9, 5.0)), "follows its node: {p}");

    let refused = |name: &str, b: Bar, want: &[&str]| {
        let e = load(&bar(&dir, name, b)).unwrap_err().to_string();
        assert!(e.contains(name), "{e}");
        for w in want {
            assert!(e.contains(w), "{name}: {w:?} not in {e}");
        }
    };
    let mut b = Bar::default();
    b.joints[4 * 5 + 1] = 7;
    refused(
        "range.gltf",
        b,
        &["JOINTS", "vertex 5 uses joint 7", "2 joints"],
    );
    let b = Bar {
        skin_joints: "[1, 3]",
        ..Bar::default()
    };
    refused(
        "missing.gltf",
        b,
        &["skin 0 joints", "node 3", "not in the rendered scene"],
    );
    let b = Bar {
        weights: None,
        ..Bar::default()
    };
    refused(
        "noweights.gltf",
        b,
        &["JOINTS_0 but no WEIGHTS_0", "add WEIGHTS_0"],
    );
    let mut b = Bar::default();
    b.weights.as_mut().unwrap()[9] = f32::NAN;
    refused("nan.gltf", b, &["WEIGHTS_0", "vertex 2", "finite"]);
    let mut b = Bar::default();
    b.weights.as_mut().unwrap()[9] = -1.0;
    refused("negative.gltf", b, &["WEIGHTS_0", "vertex 2", "negative"]);
    let mut b = Bar::default();
    b.inverse_bind[16..32].fill(0.0);
    refused(
        "singular.gltf",
        b,
        &["inverseBindMatrices", "matrix 1", "not invertible"],
    );
    let mut b = Bar::default();
    b.inverse_bind[3] = f32::INFINITY;
    refused(
        "infinite.gltf",
        b,
        &["inverseBindMatrices", "matrix 0", "not finite"],
    );
    let mut b = Bar::default();
    b.inverse_bind.truncate(16);
    refused(
        "short.gltf",
        b,
        &["inverseBindMatrices", "1 matrices for 2 joints"],
    );
}

/// A triangle with two morph targets: +z everywhere (and a normal displacement), and +x on
/// vertex 0 only. Node 0 takes the mesh's weights, node 1 (moved by x = 3) its own; `anim`
/// adds clips on the nodes' weights.
fn morph(dir: &Path, name: &str, mesh_weights: &str, anim: Option<(&str, &[f32])>) -> PathBuf {
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let nrm = b.floats(&[0.0, 0.0, 1.0].repeat(3), "VEC3");
    let up = b.floats(&[0.0, 0.0, 1.0].repeat(3), "VEC3");
    let tilt = b.floats(&[1.0, 0.0, 0.0].repeat(3), "VEC3");
    let push = b.floats(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], "VEC3");
    let animations = match anim {
        None => String::new(),
        Some((interp, values)) => {
            let t0 = b.floats(&[0.0, 2.0], "SCALAR");
            let v0 = b.floats(values, "SCALAR");
            let t1 = b.floats(&[0.0, 1.0], "SCALAR");
            let v1 = b.floats(&[0.0, 0.0, 1.0, 1.0], "SCALAR");
            format!(
                r#", "animations": [{{"samplers": [{{"input": {t0}, "output": {v0}, "interpolation": "{interp}"}},
                                     {{"input": {t1}, "output": {v1}, "interpolation": "STEP"}}],
                   "channels": [{{"sampler": 0, "target": {{"node": 0, "path": "weights"}}}},
                                {{"sampler": 1, "target": {{"node": 1, "path": "weights"}}}}]}}]"#
            )
        }
    };
    let rest = format!(
        r#""scenes": [{{"nodes": [0, 1]}}],
        "nodes": [{{"mesh": 0}}, {{"mesh": 0, "weights": [0, 1], "translation": [3, 0, 0]}}],
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": {pos}, "NORMAL": {nrm}}},
                   "targets": [{{"POSITION": {up}, "NORMAL": {tilt}}}, {{"POSITION": {push}}}]}}]
                   {mesh_weights}}}]{animations}"#
    );
    b.write(dir, name, &rest)
}

/// Static weights: the mesh's at 0.5 put the triangle half way to its target; a node's own
/// weights override them (on a copy of the mesh); animated weights are interpolated
/// (linear half way, step holds).
#[test]
fn morph_targets_blend_by_static_and_animated_weights() {
    let dir = temp_dir("morph");
    let loaded = load(&morph(&dir, "m.gltf", r#", "weights": [0.5, 0]"#, None)).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let s = &loaded.scene;
    let (a, b) = (s.instances[0].mesh, s.instances[1].mesh);
    assert_ne!(a, b, "each morphing node deforms its own mesh");
    let half = &s.meshes[a];
    for (p, rest) in half.positions.iter().zip([Vec3::ZERO, Vec3::X, Vec3::Y]) {
        assert!(close(*p, rest + Vec3::new(0.0, 0.0, 0.5)), "{p}");
    }
    assert!(close(half.normals[1], Vec3::new(0.5, 0.0, 1.0).normalize()));
    let own = &s.meshes[b];
    assert!(close(own.positions[0], Vec3::X) && close(own.positions[1], Vec3::X));
    assert!(close(
        s.instances[1].transform.transform_point3(own.positions[2]),
        Vec3::new(3.0, 1.0, 0.0)
    ));

    let path = morph(
        &dir,
        "anim.gltf",
        "",
        Some(("LINEAR", &[0.0, 0.0, 1.0, 0.5])),
    );
    let loaded = load(&path).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let rig = loaded.animation.unwrap();
    assert!(rig.is_animated());
    assert_eq!(rig.duration(), 2.0);
    let mut s = loaded.scene;
    let (a, b) = (s.instances[0].mesh, s.instances[1].mesh);
    let moved = rig.pose(&mut s, Some(1.0));
    assert_eq!(moved.len(), 2);
    // Linear at t = 1 of 2: weights (0.5, 0.25).
    let p = s.meshes[a].positions[0];
    assert!(close(p, Vec3::new(0.25, 0.0, 0.5)), "{p}");
    // Step: (1, 1) from t = 1 on, (0, 0) before.
    assert!(close(s.meshes[b].positions[0], Vec3::new(1.0, 0.0, 1.0)));
    rig.pose(&mut s, Some(0.5));
    assert!(close(s.meshes[b].positions[0], Vec3::ZERO));
    // Without a time the static weights hold: node 1's own (0, 1).
    rig.pose(&mut s, None);
    assert!(close(s.meshes[b].positions[0], Vec3::X));
}

/// Weights that do not match the morph targets, in number or finiteness, are refused.
#[test]
fn bad_morph_weights_are_refused() {
    let dir = temp_dir("morph-bad");
    let e = load(&morph(&dir, "count.gltf", r#", "weights": [0.5]"#, None))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("count.gltf") && e.contains("mesh 0 weights") && e.contains("has 1 weights"),
        "{e}"
    );
    let short: &[f32] = &[0.0, 0.0, 1.0];
    let e = load(&morph(&dir, "keys.gltf", "", Some(("LINEAR", short))))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("keys.gltf") && e.contains("animation 0 channel 0") && e.contains("3 weights"),
        "{e}"
    );
    let nan: &[f32] = &[0.0, 0.0, f32::NAN, 0.5];
    let e = load(&morph(&dir, "nan.gltf", "", Some(("LINEAR", nan))))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("nan.gltf") && e.contains("weight 2 is NaN"),
        "{e}"
    );
}
