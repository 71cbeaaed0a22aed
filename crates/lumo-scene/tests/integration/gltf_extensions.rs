//! glTF material extensions lumo reads (KHR_materials_ior, KHR_materials_specular): their
//! factors and textures reach the scene, bad values warn naming the file, material and field,
//! and a file that requires them loads.

use crate::common;

use common::{load, png8, scenes, temp_dir, write};
use lumo_scene::{BsdfSpec, GltfExtensions, Vec2, Vec3};

/// A 2×1 8-bit RGBA PNG: a white and a (255, 128, 0) texel with alphas `a`.
fn png_rgba_2x1(a: [u8; 2]) -> Vec<u8> {
    png8(
        2,
        1,
        png::ColorType::Rgba,
        &[255, 255, 255, a[0], 255, 128, 0, a[1]],
    )
}

/// hierarchy.gltf with the gold material's `extensions` set to `ext`, `spec.png` as image 0
/// and `used` as its extensionsUsed.
fn gold_with_extensions(ext: &str, used: &str) -> String {
    let gltf = std::fs::read_to_string(scenes().join("hierarchy.gltf")).unwrap();
    let (old, used_old) = (
        "   \"name\": \"gold\",\n",
        "\"extensionsUsed\": [\n  \"KHR_lights_punctual\"\n ]",
    );
    assert!(gltf.contains(old) && gltf.contains(used_old));
    gltf.replace(old, &format!("{old}   \"extensions\": {{{ext}}},\n"))
        .replace(used_old, used)
        .replacen(
            "{\n",
            "{\n \"images\": [{\"uri\": \"spec.png\"}],\n \"textures\": [{\"source\": 0}],\n",
            1,
        )
}

/// The gold material's extensions in `loaded`.
fn extensions_of(loaded: &lumo_scene::load::LoadedScene) -> Option<&GltfExtensions> {
    let s = &loaded.scene;
    let BsdfSpec::GltfPbr { extensions, .. } = &s.materials[s.meshes[1].material].bsdf else {
        panic!("{:?}", s.materials[s.meshes[1].material].bsdf);
    };
    extensions.as_deref()
}

fn warnings(loaded: &lumo_scene::load::LoadedScene) -> String {
    let w: Vec<String> = loaded.warnings.iter().map(|w| w.to_string()).collect();
    w.join("\n")
}

/// ior, specularFactor × specularTexture's alpha and specularColorFactor ×
/// specularColorTexture (sRGB) reach the scene per texel; the file requires both extensions
/// and loads without a warning about them.
#[test]
fn ior_and_specular_are_read_per_texel() {
    let dir = temp_dir("gltf-specular");
    write(&dir, "spec.png", png_rgba_2x1([255, 51]));
    let ext = "\"KHR_materials_ior\": {\"ior\": 2.0}, \"KHR_materials_specular\": {\
               \"specularFactor\": 0.5, \"specularTexture\": {\"index\": 0}, \
               \"specularColorFactor\": [1, 0.5, 2], \"specularColorTexture\": {\"index\": 0}}";
    let used = "\"extensionsUsed\": [\"KHR_lights_punctual\", \"KHR_materials_ior\", \
                \"KHR_materials_specular\"], \"extensionsRequired\": [\"KHR_materials_ior\", \
                \"KHR_materials_specular\"]";
    let loaded = load(&write(&dir, "s.gltf", gold_with_extensions(ext, used))).unwrap();
    let w = warnings(&loaded);
    assert!(!w.contains("KHR_materials"), "{w}");
    let e = extensions_of(&loaded).expect("extensions");
    assert_eq!(e.ior, 2.0);
    let (left, right) = (Vec2::new(0.25, 0.5), Vec2::new(0.75, 0.5));
    assert!((e.specular.eval_1(left) - 0.5).abs() < 1e-5);
    assert!((e.specular.eval_1(right) - 0.5 * 0.2).abs() < 1e-5);
    let c = e.specular_color.eval(right);
    // sRGB 128 decodes to 0.2158.
    let expected = Vec3::new(1.0, 0.5 * 0.2158, 0.0);
    assert!((c - expected).abs().max_element() < 1e-3, "{c}");
    assert!(
        (e.specular_color.eval(left) - Vec3::new(1.0, 0.5, 2.0))
            .abs()
            .max_element()
            < 1e-5
    );
}

/// A material without the extensions carries none (the core BSDF, F0 = 0.04).
#[test]
fn no_extensions_is_the_core_material() {
    let loaded = load(&scenes().join("hierarchy.gltf")).unwrap();
    assert!(extensions_of(&loaded).is_none());
}

/// An ior below 1 (other than 0) and a specularFactor above 1 warn naming the file, the
/// material and the field, and read as the default and the clamped value.
#[test]
fn bad_ior_and_specular_factors_warn() {
    let dir = temp_dir("gltf-bad-ior");
    write(&dir, "spec.png", png_rgba_2x1([255, 255]));
    let ext = "\"KHR_materials_ior\": {\"ior\": 0.5}, \
               \"KHR_materials_specular\": {\"specularFactor\": 3}";
    let used = "\"extensionsUsed\": [\"KHR_lights_punctual\", \"KHR_materials_ior\", \
                \"KHR_materials_specular\"]";
    let loaded = load(&write(&dir, "bad.gltf", gold_with_extensions(ext, used))).unwrap();
    let w = warnings(&loaded);
    assert!(
        w.contains("bad.gltf")
            && w.contains("material 1")
            && w.contains("KHR_materials_ior ior 0.5")
            && w.contains("specularFactor 3"),
        "{w}"
    );
    let e = extensions_of(&loaded).expect("extensions");
    assert_eq!(e.ior, 1.5);
    assert_eq!(e.specular.eval_1(Vec2::splat(0.5)), 1.0);
}

/// A required extension lumo does not read is refused with a message that lists the
/// material extensions it does read.
#[test]
fn the_required_extension_message_lists_ior_and_specular() {
    let dir = temp_dir("gltf-req-iridescence");
    write(&dir, "spec.png", png_rgba_2x1([255, 255]));
    let used = "\"extensionsUsed\": [\"KHR_lights_punctual\", \"KHR_materials_iridescence\"], \
                \"extensionsRequired\": [\"KHR_materials_iridescence\"]";
    let text = gold_with_extensions("\"KHR_materials_iridescence\": {}", used);
    let e = load(&write(&dir, "iridescence.gltf", text))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("KHR_materials_iridescence")
            && e.contains("KHR_materials_ior")
            && e.contains("KHR_materials_specular"),
        "{e}"
    );
}

/// transmissionFactor × transmissionTexture's red channel per texel; KHR_materials_volume's
/// thickness and σ_a = −ln(attenuationColor) / attenuationDistance, which becomes a
/// homogeneous absorbing medium inside the material's mesh.
#[test]
fn transmission_and_volume_make_an_absorbing_medium_inside_the_mesh() {
    let dir = temp_dir("gltf-volume");
    write(&dir, "spec.png", png_rgba_2x1([255, 255]));
    let ext = "\"KHR_materials_transmission\": {\"transmissionFactor\": 0.8, \
               \"transmissionTexture\": {\"index\": 0}}, \"KHR_materials_volume\": {\
               \"thicknessFactor\": 0.5, \"attenuationDistance\": 2, \
               \"attenuationColor\": [1, 0.5, 0.25]}";
    let used = "\"extensionsUsed\": [\"KHR_lights_punctual\", \"KHR_materials_transmission\", \
                \"KHR_materials_volume\"], \"extensionsRequired\": [\
                \"KHR_materials_transmission\", \"KHR_materials_volume\"]";
    let loaded = load(&write(&dir, "v.gltf", gold_with_extensions(ext, used))).unwrap();
    let w = warnings(&loaded);
    assert!(!w.contains("KHR_materials"), "{w}");
    let e = extensions_of(&loaded).expect("extensions");
    // Red channel 255 on the left texel, 255 on the right: 0.8 both.
    assert!((e.transmission.eval_1(Vec2::new(0.75, 0.5)) - 0.8).abs() < 1e-5);
    assert_eq!(e.thickness, 0.5);
    let sigma = e.absorption.expect("absorption");
    let want = Vec3::new(0.0, 2f32.ln() / 2.0, 4f32.ln() / 2.0);
    assert!((sigma - want).abs().max_element() < 1e-6, "{sigma}");
    let s = &loaded.scene;
    assert!(s.materials[s.meshes[1].material].bsdf.flags().transmission);
    assert_eq!(s.media.media.len(), 1);
    assert_eq!(s.media.media[0].sigma_t, want);
    assert_eq!(s.media.media[0].albedo, Vec3::ZERO);
    let b = s.media.boundary(1);
    assert!(!b.null);
    assert_eq!(b.interface.and_then(|i| i.interior), Some(0));
    assert_eq!(
        s.media.boundary(0).interface,
        None,
        "the other mesh is no volume"
    );
}

/// Thin-walled transmission (thickness 0) needs no medium; a non-positive attenuation
/// distance warns and absorbs nothing.
#[test]
fn thin_walls_and_bad_distances_make_no_medium() {
    let dir = temp_dir("gltf-thin");
    write(&dir, "spec.png", png_rgba_2x1([255, 255]));
    let used = "\"extensionsUsed\": [\"KHR_lights_punctual\", \"KHR_materials_transmission\", \
                \"KHR_materials_volume\"]";
    let thin = "\"KHR_materials_transmission\": {\"transmissionFactor\": 1}, \
                \"KHR_materials_volume\": {\"attenuationDistance\": 1, \
                \"attenuationColor\": [0.5, 0.5, 0.5]}";
    let loaded = load(&write(&dir, "t.gltf", gold_with_extensions(thin, used))).unwrap();
    assert!(loaded.scene.media.media.is_empty());
    assert_eq!(extensions_of(&loaded).expect("extensions").thickness, 0.0);
    let bad = "\"KHR_materials_transmission\": {\"transmissionFactor\": 1}, \
               \"KHR_materials_volume\": {\"thicknessFactor\": 1, \"attenuationDistance\": -1}";
    let loaded = load(&write(&dir, "b.gltf", gold_with_extensions(bad, used))).unwrap();
    let w = warnings(&loaded);
    assert!(
        w.contains("b.gltf") && w.contains("material 1") && w.contains("attenuationDistance -1"),
        "{w}"
    );
    assert!(loaded.scene.media.media.is_empty());
}

/// KHR_materials_unlit: the base colour (factor × texture, sRGB) becomes the emitted radiance
/// over a black BSDF; the file may require the extension.
#[test]
fn unlit_materials_emit_their_base_colour() {
    let dir = temp_dir("gltf-unlit");
    write(&dir, "spec.png", png_rgba_2x1([255, 255]));
    let used = "\"extensionsUsed\": [\"KHR_lights_punctual\", \"KHR_materials_unlit\"], \
                \"extensionsRequired\": [\"KHR_materials_unlit\"]";
    let text = gold_with_extensions("\"KHR_materials_unlit\": {}", used);
    let loaded = load(&write(&dir, "u.gltf", &text)).unwrap();
    let s = &loaded.scene;
    let m = &s.materials[s.meshes[1].material];
    assert!(
        matches!(&m.bsdf, BsdfSpec::Diffuse { reflectance: lumo_scene::Texture::Constant(c) } if *c == Vec3::ZERO),
        "{:?}",
        m.bsdf
    );
    // hierarchy.gltf's gold baseColorFactor.
    let gold = Vec3::new(1.0, 0.77, 0.34);
    assert!(
        (m.emission - gold).abs().max_element() < 1e-6,
        "{}",
        m.emission
    );
    assert!(m.emission_map.is_none());
    // With a base colour texture: emitted per texel, × the factor.
    let factor = "\"baseColorFactor\": [\n     1.0,\n     0.77,\n     0.34,\n     1\n    ],";
    assert!(text.contains(factor));
    let textured = text.replace(
        factor,
        "\"baseColorTexture\": {\"index\": 0}, \"baseColorFactor\": [0.5, 0.5, 0.5, 1],",
    );
    let loaded = load(&write(&dir, "ut.gltf", textured)).unwrap();
    let s = &loaded.scene;
    let m = &s.materials[s.meshes[1].material];
    let map = m.emission_map.as_ref().expect("an emission map");
    let right = map.eval(Vec2::new(0.75, 0.5));
    // sRGB (255, 128, 0) × 0.5.
    assert!(
        (right - Vec3::new(0.5, 0.5 * 0.2158, 0.0))
            .abs()
            .max_element()
            < 1e-3,
        "{right}"
    );
}

/// KHR_materials_clearcoat's factors reach the scene and the file may require the extension;
/// its clearcoatNormalTexture is read as a normalTexture is: `scale` on x and y, with its
/// KHR_texture_transform (mirrored in u here), and without a warning.
#[test]
fn clearcoat_factors_and_normal_texture_are_read() {
    let dir = temp_dir("gltf-coat");
    // Raw texels (255, 51, 0) and (102, 255, 0): normals (1, −0.6, −1) and (−0.2, 1, −1).
    let png = png8(2, 1, png::ColorType::Rgb, &[255, 51, 0, 102, 255, 0]);
    write(&dir, "spec.png", png);
    let used = "\"extensionsUsed\": [\"KHR_lights_punctual\", \"KHR_materials_clearcoat\"], \
                \"extensionsRequired\": [\"KHR_materials_clearcoat\"]";
    let ext = "\"KHR_materials_clearcoat\": {\"clearcoatFactor\": 0.75, \
               \"clearcoatRoughnessFactor\": 0.2, \"clearcoatNormalTexture\": {\"index\": 0, \
               \"scale\": 0.5, \"extensions\": {\"KHR_texture_transform\": \
               {\"offset\": [1, 0], \"scale\": [-1, 1]}}}}";
    let loaded = load(&write(&dir, "c.gltf", gold_with_extensions(ext, used))).unwrap();
    let e = extensions_of(&loaded).expect("extensions");
    assert_eq!((e.clearcoat, e.clearcoat_roughness), (0.75, 0.2));
    let w = warnings(&loaded);
    assert!(
        !w.contains("clearcoat") && !w.contains("not supported"),
        "{w}"
    );
    let normals = e.clearcoat_normal.as_ref().expect("clearcoatNormalTexture");
    // x and y halved, stored back as (n + 1) / 2; the left half reads the right texel.
    let (left, right) = (
        normals.eval(Vec2::new(0.25, 0.5)),
        normals.eval(Vec2::new(0.75, 0.5)),
    );
    assert!(
        (left - Vec3::new(0.45, 0.75, 0.0)).abs().max_element() < 2e-3,
        "{left}"
    );
    assert!(
        (right - Vec3::new(0.75, 0.35, 0.0)).abs().max_element() < 2e-3,
        "{right}"
    );
    // A scale that is not a number is refused, naming the field.
    let ext = "\"KHR_materials_clearcoat\": {\"clearcoatFactor\": 1, \
               \"clearcoatNormalTexture\": {\"index\": 0, \"scale\": \"big\"}}";
    let err = load(&write(&dir, "d.gltf", gold_with_extensions(ext, used)))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("d.gltf") && err.contains("clearcoatNormalTexture.scale"),
        "{err}"
    );
    // Without a coat there is nothing to read it for.
    let ext = "\"KHR_materials_clearcoat\": {\"clearcoatNormalTexture\": {\"index\": 0}}";
    let loaded = load(&write(&dir, "e.gltf", gold_with_extensions(ext, used))).unwrap();
    assert!(extensions_of(&loaded)
        .expect("extensions")
        .clearcoat_normal
        .is_none());
}

/// KHR_materials_sheen's colour (factor × sRGB texture) and roughness (factor × the alpha of
/// its texture, with KHR_texture_transform) reach the scene per texel; the file requires the
/// extension and loads without a warning about it.
#[test]
fn sheen_factors_and_textures_are_read_per_texel() {
    let dir = temp_dir("gltf-sheen");
    write(&dir, "spec.png", png_rgba_2x1([255, 51]));
    let used = "\"extensionsUsed\": [\"KHR_lights_punctual\", \"KHR_materials_sheen\"], \
                \"extensionsRequired\": [\"KHR_materials_sheen\"]";
    // The roughness texture is mirrored in u (scale −1, offset 1): its left texel is read on
    // the right.
    let ext = "\"KHR_materials_sheen\": {\"sheenColorFactor\": [0.5, 1, 0.25], \
               \"sheenColorTexture\": {\"index\": 0}, \"sheenRoughnessFactor\": 0.8, \
               \"sheenRoughnessTexture\": {\"index\": 0, \"extensions\": \
               {\"KHR_texture_transform\": {\"offset\": [1, 0], \"scale\": [-1, 1]}}}}";
    let loaded = load(&write(&dir, "s.gltf", gold_with_extensions(ext, used))).unwrap();
    let w = warnings(&loaded);
    assert!(!w.contains("KHR_materials"), "{w}");
    let e = extensions_of(&loaded).expect("extensions");
    assert!(e.has_sheen());
    let (left, right) = (Vec2::new(0.25, 0.5), Vec2::new(0.75, 0.5));
    let c = e.sheen_color.eval(left);
    assert!(
        (c - Vec3::new(0.5, 1.0, 0.25)).abs().max_element() < 1e-4,
        "{c}"
    );
    // sRGB (255, 128, 0) decodes to (1, 0.2158, 0).
    let c = e.sheen_color.eval(right);
    let expected = Vec3::new(0.5, 0.2158, 0.0);
    assert!((c - expected).abs().max_element() < 1e-3, "{c}");
    let (l, r) = (
        e.sheen_roughness.eval_1(left),
        e.sheen_roughness.eval_1(right),
    );
    assert!(
        (l - 0.8 * 0.2).abs() < 1e-3 && (r - 0.8).abs() < 1e-3,
        "{l} {r}"
    );
    // Without the extension there is no sheen.
    assert!(!GltfExtensions::default().has_sheen());
}

/// Bad sheen input: a factor above 1 is clamped with a warning naming the file, material and
/// field; a texture index that names no texture is refused naming the field and the fix.
#[test]
fn bad_sheen_input_warns_or_is_refused() {
    let dir = temp_dir("gltf-sheen-bad");
    write(&dir, "spec.png", png_rgba_2x1([255, 255]));
    let used = "\"extensionsUsed\": [\"KHR_lights_punctual\", \"KHR_materials_sheen\"]";
    let ext = "\"KHR_materials_sheen\": {\"sheenColorFactor\": [2, 0.5, 0.5], \
               \"sheenRoughnessFactor\": 0.3}";
    let loaded = load(&write(&dir, "c.gltf", gold_with_extensions(ext, used))).unwrap();
    let w = warnings(&loaded);
    assert!(
        w.contains("c.gltf") && w.contains("material 1") && w.contains("sheenColorFactor"),
        "{w}"
    );
    let e = extensions_of(&loaded).expect("extensions");
    assert_eq!(e.sheen_color.eval(Vec2::ZERO), Vec3::new(1.0, 0.5, 0.5));
    assert_eq!(e.sheen_roughness.eval_1(Vec2::ZERO), 0.3);
    let ext = "\"KHR_materials_sheen\": {\"sheenColorFactor\": [1, 1, 1], \
               \"sheenColorTexture\": {\"index\": 7}}";
    let err = load(&write(&dir, "d.gltf", gold_with_extensions(ext, used)))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("d.gltf")
            && err.contains("sheenColorTexture.index 7")
            && err.contains("has 1"),
        "{err}"
    );
}

/// clearcoatFactor × clearcoatTexture's red channel and clearcoatRoughnessFactor ×
/// clearcoatRoughnessTexture's green channel reach the scene per texel, read linear.
#[test]
fn clearcoat_textures_are_read_per_texel() {
    let dir = temp_dir("gltf-coat-textures");
    let png = png8(2, 1, png::ColorType::Rgb, &[255, 51, 0, 102, 255, 0]);
    write(&dir, "spec.png", png);
    let used = "\"extensionsUsed\": [\"KHR_lights_punctual\", \"KHR_materials_clearcoat\"]";
    let ext = "\"KHR_materials_clearcoat\": {\"clearcoatFactor\": 0.8, \
               \"clearcoatTexture\": {\"index\": 0}, \"clearcoatRoughnessFactor\": 0.5, \
               \"clearcoatRoughnessTexture\": {\"index\": 0}}";
    let loaded = load(&write(&dir, "t.gltf", gold_with_extensions(ext, used))).unwrap();
    let w = warnings(&loaded);
    assert!(!w.contains("clearcoat"), "{w}");
    let e = extensions_of(&loaded).expect("extensions");
    let (left, right) = (Vec2::new(0.25, 0.5), Vec2::new(0.75, 0.5));
    let coat = e.clearcoat_texture.as_ref().expect("clearcoatTexture");
    let (l, r) = (coat.eval_1(left), coat.eval_1(right));
    assert!(
        (l - 0.8).abs() < 1e-3 && (r - 0.8 * 0.4).abs() < 1e-3,
        "{l} {r}"
    );
    let rough = e.clearcoat_roughness_texture.as_ref().expect("roughness");
    let (l, r) = (rough.eval_1(left), rough.eval_1(right));
    assert!(
        (l - 0.5 * 0.2).abs() < 1e-3 && (r - 0.5).abs() < 1e-3,
        "{l} {r}"
    );
}
