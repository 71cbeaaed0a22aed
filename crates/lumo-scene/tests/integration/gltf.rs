//! glTF 2.0 loading: hierarchy, cameras, lights, materials, animation and bad input.

use crate::common;

use common::{load, png8, scenes, temp_dir, write};
use lumo_scene::load::{load_scene, LoadOptions};
use lumo_scene::{BsdfSpec, FovAxis, Light, Vec3};

fn instance_origins(s: &lumo_scene::Scene) -> Vec<Vec3> {
    s.instances
        .iter()
        .map(|i| i.transform.transform_point3(Vec3::ZERO))
        .collect()
}

#[test]
fn gltf_and_glb_give_the_same_scene() {
    let a = load(&scenes().join("hierarchy.gltf")).unwrap();
    let b = load(&scenes().join("hierarchy.glb")).unwrap();
    assert!(a.warnings.is_empty(), "{:?}", a.warnings);
    assert_eq!(
        format!("{:?}", a.scene.meshes),
        format!("{:?}", b.scene.meshes)
    );
    assert_eq!(instance_origins(&a.scene), instance_origins(&b.scene));
}

#[test]
fn hierarchy_camera_lights_and_materials() {
    let loaded = load(&scenes().join("hierarchy.gltf")).unwrap();
    let s = &loaded.scene;
    assert_eq!(s.meshes.len(), 2);
    // The box is a child of the base: base translation + its own, and the base's frame scales.
    let origins = instance_origins(s);
    assert_eq!(origins[0], Vec3::new(0.0, -0.5, 0.0));
    assert_eq!(origins[1], Vec3::new(0.25, -0.5, 0.0));
    let top = s.instances[1]
        .transform
        .transform_point3(Vec3::new(0.0, 1.0, 0.0));
    assert!((top.y - 1.0).abs() < 1e-6, "scale 1.5 on y: {top}");
    // Camera from its node, looking down −z and slightly down.
    assert_eq!(s.camera.origin, Vec3::new(0.0, 1.5, 6.0));
    let fwd = (s.camera.target - s.camera.origin).normalize();
    assert!(fwd.z < -0.9 && fwd.y < 0.0, "{fwd}");
    assert_eq!(s.camera.fov_axis, FovAxis::Y);
    assert!((s.camera.fov - 0.7f32.to_degrees()).abs() < 1e-4);
    assert_eq!(loaded.settings.size, Some((768, 512)));
    // Punctual lights at their nodes.
    match s.lights[0] {
        Light::Point {
            position,
            intensity,
            range,
        } => {
            assert_eq!(range, None, "no range in the file");
            assert_eq!(position, Vec3::new(0.0, 3.0, 2.0));
            assert!(
                (intensity - Vec3::new(20.0, 18.0, 16.0))
                    .abs()
                    .max_element()
                    < 1e-4
            );
        }
        ref other => panic!("{other:?}"),
    }
    match s.lights[1] {
        Light::Spot {
            direction,
            beam_width,
            cutoff,
            falloff,
            ..
        } => {
            assert!((direction + Vec3::Y).length() < 1e-5, "{direction}");
            assert!((beam_width - 0.3f32.to_degrees()).abs() < 1e-4);
            assert!((cutoff - 0.5f32.to_degrees()).abs() < 1e-4);
            // glTF's own curve, not Mitsuba's.
            assert_eq!(falloff, lumo_scene::SpotFalloff::SquaredCosine);
        }
        ref other => panic!("{other:?}"),
    }
    assert!(matches!(
        s.materials[s.meshes[0].material].bsdf,
        BsdfSpec::GltfPbr {
            metallic: 0.0,
            roughness: 0.9,
            metallic_roughness: None,
            ..
        }
    ));
    assert!(matches!(
        &s.materials[s.meshes[1].material].bsdf,
        BsdfSpec::GltfPbr {
            metallic: 1.0,
            roughness: 0.4,
            metallic_roughness: None,
            ..
        }
    ));
    let rig = loaded.animation.as_ref().expect("rig");
    assert_eq!(rig.animations.len(), 1);
    assert_eq!(rig.animations[0].duration(), 1.0);
}

#[test]
fn time_poses_the_animation() {
    let at = |t: Option<f32>| {
        let options = LoadOptions {
            time: t,
            ..Default::default()
        };
        let s = load_scene(&scenes().join("hierarchy.glb"), &options)
            .unwrap()
            .scene;
        instance_origins(&s)[1]
    };
    // Rest pose: the node's own translation (0.25); the clip runs from 0 to 1 along x.
    assert_eq!(at(None), Vec3::new(0.25, -0.5, 0.0));
    assert_eq!(at(Some(0.0)), Vec3::new(0.0, -0.5, 0.0));
    assert_eq!(at(Some(0.5)), Vec3::new(0.5, -0.5, 0.0));
    assert_eq!(at(Some(7.0)), Vec3::new(1.0, -0.5, 0.0));
}

#[test]
fn camera_choice_and_time_without_animation() {
    let options = LoadOptions {
        camera: Some(3),
        ..Default::default()
    };
    let e = load_scene(&scenes().join("hierarchy.gltf"), &options)
        .unwrap_err()
        .to_string();
    assert!(e.contains("--camera 3") && e.contains("1 camera"), "{e}");
    let options = LoadOptions {
        time: Some(1.0),
        ..Default::default()
    };
    let w = load_scene(&scenes().join("meshes/box.obj"), &options)
        .unwrap()
        .warnings;
    assert!(w[0].message.contains("glTF scenes only"));
}

/// hierarchy.gltf with one textual replacement (which must apply).
fn edited(from: &str, to: &str) -> String {
    let text = std::fs::read_to_string(scenes().join("hierarchy.gltf")).unwrap();
    assert!(text.contains(from), "{from}");
    text.replacen(from, to, 1)
}

#[test]
fn bad_gltf_is_a_clear_error() {
    let dir = temp_dir("gltf");
    let required = edited(
        "\"extensionsUsed\": [",
        "\"extensionsRequired\": [\"KHR_draco_mesh_compression\"],\n \"extensionsUsed\": [",
    );
    let e = load(&write(&dir, "req.gltf", required))
        .unwrap_err()
        .to_string();
    // lumo's message (naming what is supported), not the glTF parser's.
    assert!(
        e.contains("KHR_draco_mesh_compression")
            && e.contains("req.gltf")
            && e.contains("lumo does not support")
            && e.contains("supported: KHR_lights_punctual"),
        "{e}"
    );

    let short_buffer = edited(
        "\"byteLength\": 340,\n   \"uri\"",
        "\"byteLength\": 9340,\n   \"uri\"",
    );
    let e = load(&write(&dir, "short.gltf", short_buffer))
        .unwrap_err()
        .to_string();
    assert!(e.contains("buffer 0") && e.contains("9340"), "{e}");

    let far = edited("\"count\": 36", "\"count\": 3600");
    let e = load(&write(&dir, "far.gltf", far)).unwrap_err().to_string();
    assert!(
        e.contains("accessor 5") && e.contains("past the end"),
        "{e}"
    );

    let glb = std::fs::read(scenes().join("hierarchy.glb")).unwrap();
    let e = load(&write(&dir, "cut.glb", &glb[..glb.len() / 2]))
        .unwrap_err()
        .to_string();
    assert!(e.contains("cut.glb"), "{e}");
    let e = load(&write(&dir, "junk.gltf", "{ not json"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("junk.gltf") && e.contains("not a valid glTF"),
        "{e}"
    );
    let external = edited(
        "\"uri\": \"data:application/octet-stream;base64,",
        "\"uri\": \"missing.bin\", \"x\": \"",
    );
    let e = load(&write(&dir, "ext.gltf", external))
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing.bin"), "{e}");
    // A zero scale on the camera's node collapses its view direction: refused, not a black
    // image (the XML loader refuses a singular camera transform likewise).
    let flat = edited("\"camera\": 0,", "\"camera\": 0, \"scale\": [0, 0, 0],");
    let e = load(&write(&dir, "flat.gltf", flat))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("flat.gltf") && e.contains("camera 0") && e.contains("singular"),
        "{e}"
    );
}

/// scenes/animated.gltf (scripts/make_animated_scene.py): instances, the area light's
/// instance, the point light and the keyframed camera at keyframe times.
#[test]
fn animated_scene_poses_at_keyframes() {
    use lumo_scene::animation::NodeItem;
    let loaded = load(&scenes().join("animated.gltf")).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let rig = loaded.animation.expect("rig");
    assert!(rig.is_animated());
    assert_eq!(rig.duration(), 2.0);
    // Camera 0 stands still; the instances (ball, cube, panel) and the lamp move.
    assert!(!rig.moves(NodeItem::Camera));
    assert!(rig.moves(NodeItem::Instance(1)) && rig.moves(NodeItem::Light(0)));
    assert!(!rig.moves(NodeItem::Instance(0)), "the floor is static");
    let mut scene = loaded.scene;
    let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-5;
    // Instances in file order: floor, ball, cube (child of the turntable), panel.
    for (t, ball, cube, panel) in [
        (
            0.5,
            Vec3::new(-1.0, 1.6, 1.0),
            Vec3::new(0.75, 0.6, -1.0),
            Vec3::new(-1.0, 3.1, 0.25),
        ),
        (
            1.0,
            Vec3::new(0.0, 0.4, 1.0),
            Vec3::new(0.0, 0.6, -1.0),
            Vec3::new(0.0, 3.2, 0.5),
        ),
        (
            2.0,
            Vec3::new(2.0, 0.4, 1.0),
            Vec3::new(-1.5, 0.6, -1.0),
            Vec3::new(2.0, 3.0, 0.0),
        ),
    ] {
        rig.pose(&mut scene, Some(t));
        let o = instance_origins(&scene);
        assert!(close(o[1], ball), "t={t}: ball at {}", o[1]);
        assert!(close(o[2], cube), "t={t}: cube at {}", o[2]);
        assert!(close(o[3], panel), "t={t}: panel at {}", o[3]);
        assert_eq!(o[0], Vec3::ZERO);
    }
    // At t = 1 the cube has turned half a turn about y: its local +x points to world −x.
    rig.pose(&mut scene, Some(1.0));
    let x = scene.instances[2].transform.transform_vector3(Vec3::X);
    assert!(close(x, -Vec3::X), "{x}");
    // The lamp circles once in two seconds: half way round at t = 1.
    match scene.lights[0] {
        Light::Point { position, .. } => {
            assert!(close(position, Vec3::new(-2.5, 2.5, 0.0)), "{position}")
        }
        ref other => panic!("{other:?}"),
    }
    // Camera 1 is keyframed: it dollies from z = 10 to z = 6.
    let options = LoadOptions {
        camera: Some(1),
        ..Default::default()
    };
    let loaded = load_scene(&scenes().join("animated.gltf"), &options).unwrap();
    let rig = loaded.animation.expect("rig");
    assert!(rig.moves(NodeItem::Camera));
    let mut scene = loaded.scene;
    rig.pose(&mut scene, Some(1.0));
    assert!(
        close(scene.camera.origin, Vec3::new(0.0, 3.0, 8.0)),
        "{}",
        scene.camera.origin
    );
}

/// An animation channel names what is wrong with it: times that do not increase, or a value
/// that is not finite (which used to be reported as bad times).
#[test]
fn a_bad_animation_channel_says_which_part_is_wrong() {
    let dir = temp_dir("gltf-anim");
    let gltf = r#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "n"}],
        "animations": [{"samplers": [{"input": 0, "output": 1}],
                        "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "SCALAR", "min": [0], "max": [2]},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 12},
                        {"buffer": 0, "byteOffset": 12, "byteLength": 36}],
        "buffers": [{"byteLength": 48, "uri": "anim.bin"}]}"#;
    let path = write(&dir, "anim.gltf", gltf);
    let bin = |times: [f32; 3], values: [f32; 9]| -> Vec<u8> {
        times
            .iter()
            .chain(&values)
            .flat_map(|v| v.to_le_bytes())
            .collect()
    };
    let ok_values = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0];
    let mut nan_values = ok_values;
    nan_values[4] = f32::NAN;
    std::fs::write(dir.join("anim.bin"), bin([0.0, 1.0, 2.0], nan_values)).unwrap();
    let e = load(&path).unwrap_err().to_string();
    assert!(e.contains("value 1 is not finite"), "{e}");
    std::fs::write(dir.join("anim.bin"), bin([0.0, 2.0, 1.0], ok_values)).unwrap();
    let e = load(&path).unwrap_err().to_string();
    assert!(e.contains("key times must be finite and increase"), "{e}");
}

/// An orthographic camera keeps its projection (it was a perspective camera with a warning):
/// xmag and ymag are the view's half extents, and the image takes their shape.
#[test]
fn orthographic_camera_is_kept() {
    let text = std::fs::read_to_string(scenes().join("hierarchy.gltf")).unwrap();
    let ortho = text.replace(
        r#""type": "perspective",
   "perspective": {
    "yfov": 0.7,
    "aspectRatio": 1.5,
    "znear": 0.1
   }"#,
        r#""type": "orthographic",
   "orthographic": { "xmag": 3.0, "ymag": 1.5, "znear": 0.1, "zfar": 100.0 }"#,
    );
    assert_ne!(
        ortho, text,
        "the test's camera text no longer matches hierarchy.gltf"
    );
    let dir = temp_dir("ortho");
    let loaded = load(&write(&dir, "ortho.gltf", ortho)).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    assert_eq!(
        loaded.scene.camera.lens,
        lumo_scene::Lens::Orthographic {
            half_width: 3.0,
            half_height: 1.5
        }
    );
    let (w, h) = loaded.settings.size.unwrap();
    assert_eq!(w, 2 * h);
}

/// A 1×1 8-bit RGB PNG of `rgb`.
fn png_1x1(rgb: [u8; 3]) -> Vec<u8> {
    png8(1, 1, png::ColorType::Rgb, &rgb)
}

/// hierarchy.gltf with the gold material's roughness factor `roughness` and, if given, a
/// metallicRoughnessTexture read from `mr.png`.
fn gold_with(roughness: &str, texture: bool) -> String {
    let gltf = std::fs::read_to_string(scenes().join("hierarchy.gltf")).unwrap();
    let old = "    \"metallicFactor\": 1,\n    \"roughnessFactor\": 0.4";
    assert!(
        gltf.contains(old),
        "the gold material is where the test expects it"
    );
    let mut new = format!("    \"metallicFactor\": 1,\n    \"roughnessFactor\": {roughness}");
    let mut gltf = gltf;
    if texture {
        new += ",\n    \"metallicRoughnessTexture\": {\"index\": 0}";
        gltf = gltf.replacen(
            "{\n",
            "{\n \"images\": [{\"uri\": \"mr.png\"}],\n \"textures\": [{\"source\": 0}],\n",
            1,
        );
    }
    gltf.replace(old, &new)
}

/// The metallicRoughnessTexture is kept per texel, linear (not sRGB), roughness from its
/// green channel and metalness from its blue one, multiplying the factors (it used to be
/// replaced by its mean with a warning).
#[test]
fn the_metallic_roughness_texture_is_kept_per_texel() {
    let dir = temp_dir("gltf-mr");
    write(&dir, "mr.png", png_1x1([0, 128, 64]));
    let loaded = load(&write(&dir, "mr.gltf", gold_with("0.4", true))).unwrap();
    let w = loaded
        .warnings
        .iter()
        .map(|w| w.to_string())
        .collect::<Vec<_>>();
    assert!(!w.iter().any(|w| w.contains("mean")), "{w:?}");
    let s = &loaded.scene;
    let BsdfSpec::GltfPbr {
        metallic_roughness: Some(t),
        metallic,
        roughness,
        ..
    } = &s.materials[s.meshes[1].material].bsdf
    else {
        panic!("{:?}", s.materials[s.meshes[1].material].bsdf);
    };
    assert_eq!((*metallic, *roughness), (1.0, 0.4));
    let texel = t.eval(lumo_scene::Vec2::splat(0.5));
    let expected = Vec3::new(0.0, 128.0 / 255.0, 64.0 / 255.0);
    assert!((texel - expected).abs().max_element() < 1e-6, "{texel}");
}

/// A factor outside glTF's [0, 1] is clamped with a warning naming the file, the material and
/// the field.
#[test]
fn an_out_of_range_roughness_factor_is_clamped_with_a_warning() {
    let dir = temp_dir("gltf-rough");
    let loaded = load(&write(&dir, "rough.gltf", gold_with("1.5", false))).unwrap();
    let w = loaded
        .warnings
        .iter()
        .map(|w| w.to_string())
        .collect::<Vec<_>>()
        .join("\n");
    assert!(
        w.contains("rough.gltf") && w.contains("material 1") && w.contains("roughnessFactor 1.5"),
        "{w}"
    );
    let s = &loaded.scene;
    assert!(matches!(
        s.materials[s.meshes[1].material].bsdf,
        BsdfSpec::GltfPbr { roughness: 1.0, .. }
    ));
}

/// hierarchy.gltf with `extra` JSON members added to the gold material and `mr.png` as image 0.
fn gold_material_with(extra: &str) -> String {
    let gltf = std::fs::read_to_string(scenes().join("hierarchy.gltf")).unwrap();
    let old = "   \"name\": \"gold\",\n";
    assert!(
        gltf.contains(old),
        "the gold material is where the test expects it"
    );
    gltf.replace(old, &format!("{old}   {extra},\n")).replacen(
        "{\n",
        "{\n \"images\": [{\"uri\": \"mr.png\"}],\n \"textures\": [{\"source\": 0}],\n",
        1,
    )
}

/// normalTexture becomes a normal map over the glTF BSDF whose texels carry `scale` on x and
/// y (read linear), and emissiveTexture a per-texel emission × emissiveFactor (sRGB decoded).
#[test]
fn normal_and_emissive_textures_are_kept_per_texel() {
    let dir = temp_dir("gltf-normal");
    write(&dir, "mr.png", png_1x1([255, 128, 255]));
    let extra = "\"normalTexture\": {\"index\": 0, \"scale\": 0.5}, \"emissiveTexture\": {\"index\": 0}, \"emissiveFactor\": [2, 2, 2]";
    let loaded = load(&write(&dir, "n.gltf", gold_material_with(extra))).unwrap();
    let w = loaded
        .warnings
        .iter()
        .map(|w| w.to_string())
        .collect::<Vec<_>>();
    assert!(
        !w.iter()
            .any(|w| w.contains("normal") || w.contains("emissive")),
        "{w:?}"
    );
    let m = &loaded.scene.materials[loaded.scene.meshes[1].material];
    let BsdfSpec::NormalMap { normals, nested } = &m.bsdf else {
        panic!("{:?}", m.bsdf);
    };
    assert!(matches!(**nested, BsdfSpec::GltfPbr { metallic: 1.0, .. }));
    let uv = lumo_scene::Vec2::splat(0.5);
    let g = 128.0 / 255.0;
    let expected = (Vec3::new(0.5, (2.0 * g - 1.0) * 0.5, 1.0) + Vec3::ONE) * 0.5;
    let texel = normals.eval(uv);
    assert!(
        (texel - expected).abs().max_element() < 1e-6,
        "{texel} vs {expected}"
    );
    let map = m.emission_map.as_ref().expect("an emission map");
    // sRGB 128 decodes to 0.2158; 255 to 1.
    let e = map.eval(uv);
    assert!(
        (e - Vec3::new(2.0, 2.0 * 0.2158, 2.0)).abs().max_element() < 1e-3,
        "{e}"
    );
    assert!(
        (m.emission - e).abs().max_element() < 1e-6,
        "the mean of a 1×1 map is its texel"
    );
}

/// A 2×1 8-bit RGBA PNG of white texels with alphas `a`.
fn png_rgba_2x1(a: [u8; 2]) -> Vec<u8> {
    png8(
        2,
        1,
        png::ColorType::Rgba,
        &[255, 255, 255, a[0], 255, 255, 255, a[1]],
    )
}

/// hierarchy.gltf with `pbr` JSON members added to the gold material's pbrMetallicRoughness,
/// `extra` to the material, and `mr.png` as image 0.
fn gold_pbr_with(pbr: &str, extra: &str) -> String {
    let old = "    \"roughnessFactor\": 0.4";
    let text = gold_material_with(extra);
    assert!(text.contains(old));
    text.replace(old, &format!("{old},\n    {pbr}"))
}

/// alphaMode MASK thresholds the base colour's alpha (texture × factor) at alphaCutoff, BLEND
/// keeps it as the probability of being opaque; both wrap the glTF BSDF in a mask.
#[test]
fn alpha_modes_become_opacity_masks() {
    let dir = temp_dir("gltf-alpha");
    write(&dir, "mr.png", png_rgba_2x1([255, 77]));
    let opacity = |pbr: &str, extra: &str, name: &str| {
        let loaded = load(&write(&dir, name, gold_pbr_with(pbr, extra))).unwrap();
        let m = &loaded.scene.materials[loaded.scene.meshes[1].material];
        let BsdfSpec::Mask {
            opacity, nested, ..
        } = &m.bsdf
        else {
            panic!("{:?}", m.bsdf);
        };
        assert!(matches!(**nested, BsdfSpec::GltfPbr { .. }), "{nested:?}");
        let at = |u: f32| opacity.eval_1(lumo_scene::Vec2::new(u, 0.5));
        (at(0.25), at(0.75))
    };
    let textured = "\"baseColorTexture\": {\"index\": 0}";
    // Alpha 77/255 = 0.30: opaque above a cutoff of 0.25, absent below the default 0.5.
    let (l, r) = opacity(
        textured,
        "\"alphaMode\": \"MASK\", \"alphaCutoff\": 0.25",
        "mask.gltf",
    );
    assert!((l - 1.0).abs() < 1e-6 && (r - 1.0).abs() < 1e-6, "{l} {r}");
    let (l, r) = opacity(textured, "\"alphaMode\": \"MASK\"", "mask2.gltf");
    assert!(
        (l - 1.0).abs() < 1e-6 && r == 0.0,
        "default cutoff 0.5: {l} {r}"
    );
    let (l, r) = opacity(textured, "\"alphaMode\": \"BLEND\"", "blend.gltf");
    assert!(
        (l - 1.0).abs() < 1e-6 && (r - 77.0 / 255.0).abs() < 1e-6,
        "{l} {r}"
    );
    // Without a texture the factor's alpha alone.
    let gltf = gold_material_with("\"alphaMode\": \"BLEND\"")
        .replace("     0.34,\n     1\n", "     0.34,\n     0.25\n");
    let loaded = load(&write(&dir, "factor.gltf", gltf)).unwrap();
    let m = &loaded.scene.materials[loaded.scene.meshes[1].material];
    assert!(
        matches!(&m.bsdf, BsdfSpec::Mask { opacity: lumo_scene::Texture::Constant(c), .. } if *c == Vec3::splat(0.25)),
        "{:?}",
        m.bsdf
    );
}

/// The filters and wrap mode of the bitmap under a texture (through any transform): the
/// lookup where a texel is larger than the footprint, and the mip-map's filters if any.
type Lookup = (
    lumo_scene::TextureFilter,
    lumo_scene::WrapMode,
    Option<(lumo_scene::TextureFilter, lumo_scene::MipFilter)>,
);

fn bitmap_of(t: &lumo_scene::Texture) -> Lookup {
    match t {
        lumo_scene::Texture::Bitmap { filter, wrap, .. } => (*filter, *wrap, None),
        lumo_scene::Texture::Mipmapped {
            magnify,
            minify,
            between,
            wrap,
            ..
        } => (*magnify, *wrap, Some((*minify, *between))),
        lumo_scene::Texture::Transformed { texture, .. } => bitmap_of(texture),
        other => panic!("{other:?}"),
    }
}

/// Samplers: magFilter NEAREST or LINEAR (the default when unset); minFilter NEAREST or
/// LINEAR without a mip-map, each `*_MIPMAP_*` with one, and unset as LINEAR_MIPMAP_LINEAR
/// (glTF's "auto"); wrapS as the wrap mode, a warning where wrapT differs.
#[test]
fn samplers_choose_the_filter_and_wrap_mode() {
    use lumo_scene::{MipFilter, TextureFilter, WrapMode};
    let dir = temp_dir("gltf-sampler");
    write(&dir, "mr.png", png_1x1([0, 128, 64]));
    let base = |samplers: &str, name: &str| {
        let text = gold_pbr_with(
            "\"baseColorTexture\": {\"index\": 0}",
            "\"doubleSided\": true",
        )
        .replacen(
            "\"textures\": [{\"source\": 0}]",
            &format!(
                "\"textures\": [{{\"source\": 0{}}}],\n \"samplers\": [{samplers}]",
                if samplers.is_empty() {
                    ""
                } else {
                    ", \"sampler\": 0"
                }
            ),
            1,
        );
        let loaded = load(&write(&dir, name, text)).unwrap();
        let m = &loaded.scene.materials[loaded.scene.meshes[1].material];
        let BsdfSpec::GltfPbr { base_color, .. } = &m.bsdf else {
            panic!("{:?}", m.bsdf);
        };
        let w = loaded
            .warnings
            .iter()
            .map(|w| w.to_string())
            .collect::<Vec<_>>()
            .join("\n");
        (bitmap_of(base_color), w)
    };
    let (near, linear) = (TextureFilter::Nearest, TextureFilter::Bilinear);
    let trilinear = Some((linear, MipFilter::Linear));
    let (fw, w) = base("", "default.gltf");
    assert_eq!(fw, (linear, WrapMode::Repeat, trilinear), "{w}");
    let (fw, w) = base(
        "{\"magFilter\": 9728, \"wrapS\": 33071, \"wrapT\": 33071}",
        "nearest.gltf",
    );
    assert_eq!(fw, (near, WrapMode::Clamp, trilinear));
    assert!(!w.contains("wrapT"), "{w}");
    let (fw, w) = base("{\"wrapS\": 33648, \"wrapT\": 10497}", "mixed.gltf");
    assert_eq!(fw, (linear, WrapMode::Mirror, trilinear));
    assert!(w.contains("wrapT Repeat differ"), "{w}");
    // minFilter: 9728 NEAREST, 9729 LINEAR, 9984 NEAREST_MIPMAP_NEAREST,
    // 9985 LINEAR_MIPMAP_NEAREST, 9986 NEAREST_MIPMAP_LINEAR, 9987 LINEAR_MIPMAP_LINEAR.
    for (code, mips) in [
        (9728, None),
        (9729, None),
        (9984, Some((near, MipFilter::Nearest))),
        (9985, Some((linear, MipFilter::Nearest))),
        (9986, Some((near, MipFilter::Linear))),
        (9987, trilinear),
    ] {
        let (fw, w) = base(
            &format!("{{\"minFilter\": {code}}}"),
            &format!("min{code}.gltf"),
        );
        assert_eq!(
            fw,
            (linear, WrapMode::Repeat, mips),
            "minFilter {code}: {w}"
        );
    }
}

/// KHR_lights_punctual's `range` is read onto point and spot lights (in world units, the
/// node's scale left out as the extension says) without a warning; a range that is not a
/// finite distance above 0 is refused with a message naming the file, the light and the fix.
#[test]
fn a_light_range_is_read_and_checked() {
    let dir = temp_dir("gltf-range");
    let with_ranges = |point: &str, spot: &str| {
        edited(
            "     \"intensity\": 20\n",
            &format!("     \"intensity\": 20,\n     \"range\": {point}\n"),
        )
        .replacen(
            "     \"intensity\": 30,\n",
            &format!("     \"intensity\": 30,\n     \"range\": {spot},\n"),
            1,
        )
    };
    let loaded = load(&write(&dir, "range.gltf", with_ranges("4", "2.5"))).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    assert!(
        matches!(loaded.scene.lights[0], Light::Point { range: Some(r), .. } if r == 4.0),
        "{:?}",
        loaded.scene.lights[0]
    );
    assert!(
        matches!(loaded.scene.lights[1], Light::Spot { range: Some(r), .. } if r == 2.5),
        "{:?}",
        loaded.scene.lights[1]
    );
    // A directional light's range means nothing (the extension defines it for point and spot
    // lights): warned about and dropped, not refused.
    let sun =
        with_ranges("4", "2.5").replacen("\"type\": \"point\"", "\"type\": \"directional\"", 1);
    let loaded = load(&write(&dir, "sun-range.gltf", sun)).unwrap();
    let w = loaded
        .warnings
        .iter()
        .map(|w| w.to_string())
        .collect::<Vec<_>>()
        .join("\n");
    assert!(
        w.contains("sun-range.gltf") && w.contains("light 0") && w.contains("range 4 ignored"),
        "{w}"
    );
    assert!(matches!(loaded.scene.lights[0], Light::Directional { .. }));
    for (bad, shown) in [("0", "range 0"), ("-3", "range -3"), ("1e39", "range inf")] {
        let name = format!("bad-range{bad}.gltf");
        let e = load(&write(&dir, &name, with_ranges("4", bad)))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&name)
                && e.contains("light 1")
                && e.contains(shown)
                && e.contains("finite distance above 0")
                && e.contains("remove range"),
            "{e}"
        );
    }
}

/// A normalTexture's KHR_texture_transform (which the `gltf` crate leaves in its JSON) moves
/// the lookup as on the other textures: offset 0.5 along u reads the other texel of a 2×1
/// image.
#[test]
fn a_normal_texture_transform_moves_the_lookup() {
    let dir = temp_dir("gltf-normal-transform");
    let png = png8(2, 1, png::ColorType::Rgb, &[128, 128, 255, 255, 128, 128]);
    write(&dir, "mr.png", png);
    let normal = |transform: &str| {
        let extra = format!("\"normalTexture\": {{\"index\": 0{transform}}}");
        let loaded = load(&write(&dir, "n.gltf", gold_material_with(&extra))).unwrap();
        let m = &loaded.scene.materials[loaded.scene.meshes[1].material];
        let BsdfSpec::NormalMap { normals, .. } = &m.bsdf else {
            panic!("{:?}", m.bsdf);
        };
        normals.eval(lumo_scene::Vec2::new(0.25, 0.5))
    };
    let g = 128.0 / 255.0;
    let plain = normal("");
    assert!(
        (plain - Vec3::new(g, g, 1.0)).abs().max_element() < 1e-6,
        "{plain}"
    );
    let moved = normal(
        ", \"extensions\": {\"KHR_texture_transform\": {\"offset\": [0.5, 0], \"scale\": [1, 1]}}",
    );
    assert!(
        (moved - Vec3::new(1.0, g, g)).abs().max_element() < 1e-6,
        "{moved}"
    );
}
