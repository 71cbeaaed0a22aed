//! glTF vertex attributes as authored: the TEXCOORD_n set a material's textures name, and
//! KHR_mesh_quantization's integer attributes dequantised.

use crate::common::builder::Builder;
use crate::common::{load, temp_dir};
use lumo_scene::{BsdfSpec, Vec2, Vec3};

/// A 1×1 PNG.
const PNG: &str = "data:image/png;base64,iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAIAAACQd1PeAAAADElEQVR4nGNoaGgAAAMEAYFL09IQAAAAAElFTkSuQmCC";

const UV1: [f32; 6] = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];

/// A triangle with TEXCOORD_0 all zero and TEXCOORD_1 = UV1, under `material`.
fn two_sets(name: &str, material: &str) -> lumo_scene::load::LoadedScene {
    let dir = temp_dir("uv-sets");
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let uv0 = b.floats(&[0.0; 6], "VEC2");
    let uv1 = b.floats(&UV1, "VEC2");
    let rest = format!(
        r#""extensionsUsed": ["KHR_texture_transform"], "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": {pos}, "TEXCOORD_0": {uv0},
                   "TEXCOORD_1": {uv1}}}, "material": 0}}]}}],
        "materials": [{material}], "textures": [{{"source": 0}}], "images": [{{"uri": "{PNG}"}}]"#
    );
    load(&b.write(&dir, name, &rest)).unwrap()
}

fn uvs_are_set_1(s: &lumo_scene::Scene) -> bool {
    let want: Vec<Vec2> = UV1.chunks(2).map(|c| Vec2::new(c[0], c[1])).collect();
    s.meshes[0].uvs == want
}

/// The mesh keeps the set its base colour texture names (`texCoord`, or
/// KHR_texture_transform's override); a texture of the same material naming another set is
/// warned about.
#[test]
fn textures_read_the_texcoord_set_they_name() {
    let l = two_sets(
        "own.gltf",
        r#"{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "texCoord": 1}}}"#,
    );
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    assert!(uvs_are_set_1(&l.scene), "{:?}", l.scene.meshes[0].uvs);
    let l = two_sets(
        "transform.gltf",
        r#"{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0,
            "extensions": {"KHR_texture_transform": {"texCoord": 1}}}}}"#,
    );
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    assert!(uvs_are_set_1(&l.scene), "{:?}", l.scene.meshes[0].uvs);
    let l = two_sets(
        "mixed.gltf",
        r#"{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "texCoord": 1},
            "metallicRoughnessTexture": {"index": 0}}}"#,
    );
    assert!(uvs_are_set_1(&l.scene));
    let w: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
    assert!(
        w.iter()
            .any(|w| w.contains("mixed.gltf") && w.contains("texCoord 0 differs from TEXCOORD_1")),
        "{w:?}"
    );
}

/// Three little-endian i16 per element, each element padded to 8 bytes (byteStride 8).
fn i16x3(v: &[[i16; 3]]) -> Vec<u8> {
    v.iter()
        .flat_map(|e| {
            let mut b: Vec<u8> = e.iter().flat_map(|x| x.to_le_bytes()).collect();
            b.extend([0, 0]);
            b
        })
        .collect()
}

/// KHR_mesh_quantization (required): short positions as integers, normalised byte normals
/// and normalised short uvs and morph displacements, dequantised as the extension defines;
/// a type it does not allow is refused naming the accessor.
#[test]
fn quantized_attributes_are_dequantized() {
    let dir = temp_dir("quantized");
    let write = |name: &str, normal_type: u32, normal_normalized: bool| {
        let mut b = Builder::default();
        let pos = b.add_strided(
            &i16x3(&[[0, 0, 0], [100, 0, 0], [0, 100, 0]]),
            Some(8),
            3,
            "VEC3",
            5122,
            r#", "min": [0, 0, 0], "max": [100, 100, 0]"#,
        );
        let nrm: Vec<u8> = [[0i8, 0, 127], [0, 0, 127], [-128, 0, 0]]
            .iter()
            .flat_map(|n| [n[0] as u8, n[1] as u8, n[2] as u8, 0])
            .collect();
        let normalized = format!(r#", "normalized": {normal_normalized}"#);
        let nrm = b.add_strided(&nrm, Some(4), 3, "VEC3", normal_type, &normalized);
        let uv: Vec<u8> = [0u16, 0, 65535, 0, 0, 32768]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let uv = b.add(&uv, 3, "VEC2", 5123, r#", "normalized": true"#);
        let up = b.add_strided(
            &i16x3(&[[0, 0, 32767]; 3]),
            Some(8),
            3,
            "VEC3",
            5122,
            r#", "normalized": true"#,
        );
        let rest = format!(
            r#""extensionsUsed": ["KHR_mesh_quantization"],
            "extensionsRequired": ["KHR_mesh_quantization"],
            "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": {pos}, "NORMAL": {nrm},
                       "TEXCOORD_0": {uv}}}, "targets": [{{"POSITION": {up}}}]}}],
                       "weights": [0.5]}}]"#
        );
        b.write(&dir, name, &rest)
    };
    let l = load(&write("q.gltf", 5120, true)).unwrap();
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    let m = &l.scene.meshes[0];
    // Integer positions keep their values; the morph target's normalised +1 at weight 0.5.
    assert_eq!(
        m.positions,
        vec![
            Vec3::new(0.0, 0.0, 0.5),
            Vec3::new(100.0, 0.0, 0.5),
            Vec3::new(0.0, 100.0, 0.5)
        ]
    );
    // 127 → 1 and −128 → −1 (clamped, as the extension says).
    assert_eq!(m.normals, vec![Vec3::Z, Vec3::Z, -Vec3::X]);
    assert_eq!(m.uvs[1], Vec2::new(1.0, 0.0));
    assert!((m.uvs[2].y - 32768.0 / 65535.0).abs() < 1e-7);
    // Normals must be normalised signed integers.
    let e = load(&write("bad.gltf", 5121, false))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bad.gltf") && e.contains("(NORMAL)") && e.contains("normalised signed byte"),
        "{e}"
    );
}

/// COLOR_0 alpha under MASK or BLEND is kept per vertex and its material's mask leaves
/// MASK's cutoff to the hit (where the vertex alpha multiplies in); a primitive of the same
/// material without vertex alpha keeps the per-texel mask; OPAQUE ignores alpha.
#[test]
fn vertex_alpha_multiplies_the_opacity() {
    let dir = temp_dir("vertex-alpha");
    let write = |name: &str, mode: &str| {
        let mut b = Builder::default();
        let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
        let colors = b.floats(
            &[1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.5, 1.0, 1.0, 1.0, 0.0],
            "VEC4",
        );
        let rest = format!(
            r#""scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
            "meshes": [{{"primitives": [
                {{"attributes": {{"POSITION": {pos}, "COLOR_0": {colors}}}, "material": 0}},
                {{"attributes": {{"POSITION": {pos}}}, "material": 0}}]}}],
            "materials": [{{"alphaMode": "{mode}", "alphaCutoff": 0.4,
                           "pbrMetallicRoughness": {{"baseColorFactor": [1, 1, 1, 0.8]}}}}]"#
        );
        let l = load(&b.write(&dir, name, &rest)).unwrap();
        assert!(l.warnings.is_empty(), "{name}: {:?}", l.warnings);
        l
    };
    let mask_of = |l: &lumo_scene::load::LoadedScene, mesh: usize| {
        let m = &l.scene.materials[l.scene.meshes[mesh].material];
        match &m.bsdf {
            BsdfSpec::Mask {
                opacity, cutoff, ..
            } => Some((opacity.eval_1(Vec2::ZERO), *cutoff)),
            _ => None,
        }
    };
    let l = write("mask.gltf", "MASK");
    assert_eq!(l.scene.meshes[0].alphas, vec![1.0, 0.5, 0.0]);
    // Factor alpha 0.8 unthresholded, the cutoff left to the hit.
    assert_eq!(mask_of(&l, 0), Some((0.8, Some(0.4))));
    // Without vertex alpha 0.8 ≥ 0.4 is opaque everywhere: no mask at all, as before.
    assert!(l.scene.meshes[1].alphas.is_empty());
    assert_eq!(mask_of(&l, 1), None);
    let l = write("blend.gltf", "BLEND");
    assert_eq!(l.scene.meshes[0].alphas, vec![1.0, 0.5, 0.0]);
    assert_eq!(mask_of(&l, 0), Some((0.8, None)));
    assert_eq!(mask_of(&l, 1), Some((0.8, None)));
    let l = write("opaque.gltf", "OPAQUE");
    assert!(l.scene.meshes[0].alphas.is_empty());
    assert_eq!(mask_of(&l, 0), None);
}

/// Sparse accessors: POSITION over a base view, a morph target and COLOR_0 over zeros (no
/// view) give the mesh their dense equivalents give; bad sparse indices are refused naming the
/// accessor and the rule.
#[test]
fn sparse_accessors_substitute_their_elements() {
    let dir = temp_dir("sparse");
    let tri = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let rest = |pos: usize, target: usize, colors: usize| {
        format!(
            r#""scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": {pos}, "COLOR_0": {colors}}},
                       "targets": [{{"POSITION": {target}}}]}}], "weights": [0.5]}}]"#
        )
    };
    let bounds = r#", "min": [0, 0, 0], "max": [1, 3, 0]"#;
    let sparse = |name: &str, indices: &[u16]| {
        let mut b = Builder::default();
        let base = b.floats(&tri, "VEC3");
        let pos = b.sparse(
            Some(base),
            (3, "VEC3"),
            &indices[..1],
            &[0.0, 3.0, 0.0],
            bounds,
        );
        let target = b.sparse(
            None,
            (3, "VEC3"),
            &indices[1..],
            &[0.0, 0.0, 2.0, 0.0, 0.0, 4.0],
            "",
        );
        let colors = b.sparse(None, (3, "VEC3"), &[0], &[1.0, 0.0, 0.0], "");
        load(&b.write(&dir, name, &rest(pos, target, colors)))
    };
    let l = sparse("sparse.gltf", &[2, 0, 1]).unwrap();
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 3.0, 0.0], "VEC3");
    let target = b.floats(&[0.0, 0.0, 2.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0], "VEC3");
    let colors = b.floats(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], "VEC3");
    let dense = load(&b.write(&dir, "dense.gltf", &rest(pos, target, colors))).unwrap();
    let (s, d) = (&l.scene.meshes[0], &dense.scene.meshes[0]);
    assert_eq!(s.positions, d.positions);
    assert_eq!(
        s.positions,
        vec![
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 2.0),
            Vec3::new(0.0, 3.0, 0.0)
        ]
    );
    assert_eq!(s.colors, d.colors);
    assert_eq!(s.colors[0], Vec3::X);
    let e = sparse("unsorted.gltf", &[2, 1, 0]).unwrap_err().to_string();
    assert!(
        e.contains("unsorted.gltf") && e.contains("accessor") && e.contains("increase strictly"),
        "{e}"
    );
    let e = sparse("past.gltf", &[2, 0, 7]).unwrap_err().to_string();
    assert!(
        e.contains("past.gltf") && e.contains("names element 7"),
        "{e}"
    );
}

/// TANGENT is kept per vertex (w reduced to its sign); a skinned or morphing primitive's is
/// dropped with a warning (it is not deformed with the mesh).
#[test]
fn tangents_are_kept_per_vertex() {
    let dir = temp_dir("tangent");
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let tangents = b.floats(
        &[0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 1.0, 0.0, -0.5],
        "VEC4",
    );
    let up = b.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], "VEC3");
    let rest = |targets: &str| {
        format!(
            r#""scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": {pos}, "TANGENT": {tangents}}}
                       {targets}}}]}}]"#
        )
    };
    let l = load(&b.write(&dir, "t.gltf", &rest(""))).unwrap();
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    use lumo_scene::Vec4;
    assert_eq!(
        l.scene.meshes[0].tangents,
        vec![
            Vec4::new(0.0, 1.0, 0.0, 1.0),
            Vec4::new(0.0, 1.0, 0.0, -1.0),
            Vec4::new(0.0, 1.0, 0.0, -1.0)
        ]
    );
    // Animated morph weights make the primitive a deforming one.
    let targets = format!(r#", "targets": [{{"POSITION": {up}}}]"#);
    let anim = r#", "animations": [{"channels": [{"sampler": 0, "target": {"node": 0, "path": "weights"}}],
                    "samplers": [{"input": 3, "output": 4}]}]"#;
    let times = b.floats(&[0.0, 1.0], "SCALAR");
    let weights = b.floats(&[0.0, 1.0], "SCALAR");
    assert_eq!((times, weights), (3, 4));
    let path = b.write(&dir, "m.gltf", &format!("{}{anim}", rest(&targets)));
    let l = load(&path).unwrap();
    assert!(l.scene.meshes[0].tangents.is_empty());
    assert!(
        l.warnings.iter().any(|w| w
            .to_string()
            .contains("TANGENT of a skinned or morphing primitive")),
        "{:?}",
        l.warnings
    );
}
