//! KHR_materials_clearcoat on glTF's BSDF: the coat never makes a surface reflect more than
//! it receives, over any base; over a black base it is exactly a 4 % dielectric layer of its
//! roughness times its intensity; the coated BSDF is reciprocal; its albedo AOV adds the coat.

use glam::Vec3;
use lumo_render::bsdf::{Bsdf, GltfPbr};

use crate::common::bsdf_grid::{albedo, dir};

/// White bases (dielectric, metal, thin transmissive) under coats of every intensity and
/// roughness reflect no more than they receive; a full smooth coat over a white dielectric
/// loses little.
#[test]
fn a_coat_never_makes_energy() {
    for (metallic, transmission) in [(0.0f32, 0.0f32), (1.0, 0.0), (0.0, 1.0)] {
        for base_r in [0.0f32, 0.5] {
            for (c, cr) in [(1.0f32, 0.0f32), (1.0, 0.3), (0.5, 0.8), (1.0, 1.0)] {
                for cos in [1.0f32, 0.5, 0.15, 0.03] {
                    let b = Bsdf::GltfPbr(
                        GltfPbr::new(Vec3::ONE, metallic, base_r)
                            .with_transmission(transmission, true, 1.5)
                            .with_clearcoat(c, cr),
                    );
                    let a = albedo(&b, dir(cos, 0.6), 300);
                    assert!(
                        a.max_element() <= 1.01,
                        "metallic {metallic}, transmission {transmission}, roughness {base_r}, \
                         coat {c}/{cr}, cos θo {cos}: {a}"
                    );
                    if metallic == 0.0 && transmission == 0.0 && cr == 0.0 && cos >= 0.5 {
                        assert!(a.min_element() > 0.9, "{cos}: {a}");
                    }
                }
            }
        }
    }
}

/// Over a base that reflects nothing (black, specular weight 0) the coat is the core
/// dielectric layer (F0 = 0.04, GGX of the coat's roughness) scaled by its intensity.
#[test]
fn over_nothing_the_coat_is_a_four_percent_layer() {
    for cr in [0.2f32, 0.6] {
        let coated = Bsdf::GltfPbr(
            GltfPbr::new(Vec3::ZERO, 0.0, 0.9)
                .with_specular(1.5, 0.0, Vec3::ONE)
                .with_clearcoat(0.7, cr),
        );
        let layer =
            Bsdf::GltfPbr(GltfPbr::new(Vec3::ZERO, 0.0, cr).with_specular(1.5, 0.7, Vec3::ONE));
        for (co, ci) in [(0.9f32, 0.4f32), (0.3, 0.8), (0.1, 0.1)] {
            let (wo, wi) = (dir(co, 0.0), dir(ci, 2.5));
            let (a, b) = (coated.eval(wo, wi), layer.eval(wo, wi));
            assert!(
                (a - b).abs().max_element() <= 1e-5 * b.max_element(),
                "{a} vs {b}"
            );
            let (p, q) = (coated.pdf(wo, wi), layer.pdf(wo, wi));
            assert!(p > 0.0 && q > 0.0, "{p} {q}");
        }
        let (a, b) = (
            albedo(&coated, dir(0.5, 0.0), 200),
            albedo(&layer, dir(0.5, 0.0), 200),
        );
        assert!((a - b).abs().max_element() < 2e-3, "{a} vs {b}");
    }
}

/// The coated BSDF is reciprocal, and its albedo AOV adds the coat's reflectance.
#[test]
fn the_coated_bsdf_is_reciprocal_and_its_albedo_adds_the_coat() {
    let plain = GltfPbr::new(Vec3::new(0.6, 0.3, 0.1), 0.4, 0.6);
    let b = Bsdf::GltfPbr(plain.with_clearcoat(0.9, 0.25));
    for co in [0.95f32, 0.5, 0.1] {
        for ci in [0.8f32, 0.3, 0.05] {
            let (wo, wi) = (dir(co, 0.3), dir(ci, 2.4));
            let (x, y) = (b.eval(wo, wi) / wi.z, b.eval(wi, wo) / wo.z);
            assert!(
                (x - y).abs().max_element() <= 1e-4 * x.max_element(),
                "{x} vs {y}"
            );
        }
    }
    let (coated, bare) = (b.albedo(), Bsdf::GltfPbr(plain).albedo());
    assert!(
        coated.cmpgt(bare * 0.9).all() && (coated - bare).min_element() > -0.05,
        "{coated} {bare}"
    );
    assert!(
        coated.z > bare.z,
        "the coat's grey reflection lifts the dark channel: {coated} {bare}"
    );
}

/// A unit normal tilted by `deg` degrees from z towards +x.
fn tilted(deg: f32) -> Vec3 {
    let t = deg.to_radians();
    Vec3::new(t.sin(), 0.0, t.cos())
}

/// An orthonormal frame (s, t, n) around unit `n`.
fn frame_of(n: Vec3) -> [Vec3; 3] {
    let s = (Vec3::X - n * n.x).normalize();
    [s, n.cross(s), n]
}

/// Over a base that reflects nothing, a coat with its own normal is the untilted coat turned
/// with that normal: its value and density at (wo, wi) are the untilted coat's at the two
/// directions in the normal's frame (where both lie above the surface and the coat).
#[test]
fn a_tilted_coat_is_the_coat_turned_to_its_normal() {
    let black = GltfPbr::new(Vec3::ZERO, 0.0, 0.9).with_specular(1.5, 0.0, Vec3::ONE);
    for (deg, cr) in [(20.0f32, 0.3f32), (35.0, 0.6)] {
        let n = tilted(deg);
        let flat = Bsdf::GltfPbr(black.with_clearcoat(0.8, cr));
        let turned = Bsdf::GltfPbr(black.with_clearcoat(0.8, cr).with_coat_normal(n));
        let [s, t, _] = frame_of(n);
        let local = |w: Vec3| Vec3::new(w.dot(s), w.dot(t), w.dot(n));
        let mut checked = 0;
        for (co, po) in [(0.9f32, 0.0f32), (0.6, 3.0), (0.4, 0.5)] {
            for (ci, pi) in [(0.8f32, 2.0f32), (0.5, 0.2), (0.3, 4.0)] {
                let (wo, wi) = (dir(co, po), dir(ci, pi));
                let (lo, li) = (local(wo), local(wi));
                if lo.z <= 0.0 || li.z <= 0.0 {
                    continue;
                }
                checked += 1;
                let (a, b) = (turned.eval(wo, wi), flat.eval(lo, li));
                assert!(
                    (a - b).abs().max_element() <= 1e-4 * b.max_element().max(1e-3),
                    "{deg}°: {a} vs {b}"
                );
                let (p, q) = (turned.pdf(wo, wi), flat.pdf(lo, li));
                assert!((p - q).abs() <= 1e-4 * q.max(1e-3), "{deg}°: {p} vs {q}");
            }
        }
        assert!(checked >= 6, "{checked}");
    }
}

/// White bases under coats whose normal is tilted away from the base's reflect no more than
/// they receive, from views on either side of the tilt (grazing ones see the coat's normal
/// from behind); with the base's normal the coat is what it was, bit for bit. (The coat lobe
/// takes its cosine factor from its own normal, as a normal-mapped lobe does: it is reciprocal
/// in the coat's frame, `a_tilted_coat_is_the_coat_turned_to_its_normal`, not in the base's.)
#[test]
fn a_tilted_coat_never_makes_energy() {
    for (metallic, transmission) in [(0.0f32, 0.0f32), (1.0, 0.0), (0.0, 1.0)] {
        for (c, cr) in [(1.0f32, 0.0f32), (1.0, 0.3), (0.6, 0.8)] {
            for deg in [15.0f32, 40.0] {
                let g = GltfPbr::new(Vec3::ONE, metallic, 0.5)
                    .with_transmission(transmission, true, 1.5)
                    .with_clearcoat(c, cr);
                let b = Bsdf::GltfPbr(g.with_coat_normal(tilted(deg)));
                for (cos, phi) in [(1.0f32, 0.0f32), (0.5, 0.0), (0.5, 3.0), (0.1, 3.0)] {
                    let a = albedo(&b, dir(cos, phi), 300);
                    assert!(
                        a.max_element() <= 1.01,
                        "metallic {metallic}, transmission {transmission}, coat {c}/{cr}, \
                         tilt {deg}°, cos θo {cos}, φ {phi}: {a}"
                    );
                }
                let (untilted, wo, wi) = (Bsdf::GltfPbr(g), dir(0.7, 0.4), dir(0.5, 2.0));
                let same = Bsdf::GltfPbr(g.with_coat_normal(Vec3::Z));
                assert_eq!(untilted.eval(wo, wi), same.eval(wo, wi));
            }
        }
    }
}

/// A quad seen head-on, lit by a point light beside the camera: a highlight's column is where
/// its normal faces the camera.
const HIGHLIGHT_QUAD: &str = r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0,0,2" target="0,0,0" up="0,1,0"/></transform>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
  </sensor>
  <shape type="rectangle"><bsdf type="diffuse"/></shape>
  <emitter type="point"><point name="position" value="0,0.02,2"/><rgb name="intensity" value="4"/></emitter>
</scene>"#;

/// The tangent-space texel of a normal tilted by `deg` degrees towards +u.
fn normal_texel(deg: f32) -> lumo_scene::Texture {
    lumo_scene::Texture::Constant((tilted(deg) + Vec3::ONE) * 0.5)
}

/// The columns of the brightest coat (green: the coat alone) and base (red − green: the
/// base's red specular layer) highlights in `image` (RGB rows of 32).
fn highlight_columns(image: &[f32], channels: usize) -> (usize, usize) {
    let (mut coat, mut base) = ([0.0f64; 32], [0.0f64; 32]);
    for (i, px) in image.chunks(channels).enumerate() {
        coat[i % 32] += f64::from(px[1]);
        base[i % 32] += f64::from(px[0] - px[1]);
    }
    let argmax = |v: &[f64; 32]| (0..32).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap_or(0);
    (argmax(&coat), argmax(&base))
}

/// Through the render scene and every integrator that shades surfaces (path tracer, light
/// tracer, BDPT): a black glTF material whose specular layer reflects red only, under a grey
/// clear coat. A clearcoatNormalTexture tilted 12° moves the coat's highlight sideways to
/// where the tilted normal faces the camera (2·tan 12° of the view's 0.73 half-width: ~9 of
/// 32 columns, measured 9.5) while the base's stays in the middle; a base normal map without a coat normal texture moves the
/// base's highlight and leaves the coat on the mesh's normal, as the extension defines.
#[test]
fn a_coat_normal_map_moves_the_coat_highlight_only() {
    use lumo_render::integrators::bdpt::BdptSettings;
    use lumo_render::{render, render_bdpt, render_light, RenderScene, RenderSettings};
    use lumo_scene::{BsdfSpec, GltfExtensions, Texture};
    let render_all = |coat_deg: Option<f32>, base_deg: Option<f32>| {
        let loaded = lumo_scene::load::load_mitsuba_str(
            HIGHLIGHT_QUAD,
            std::path::Path::new("quad.xml"),
            &Default::default(),
        )
        .unwrap();
        let mut scene = loaded.scene;
        let ext = GltfExtensions {
            ior: 3.0,
            specular_color: Texture::Constant(Vec3::X),
            clearcoat: 1.0,
            clearcoat_roughness: 0.25,
            clearcoat_normal: coat_deg.map(normal_texel),
            ..Default::default()
        };
        let mut bsdf = BsdfSpec::GltfPbr {
            base_color: Texture::Constant(Vec3::ZERO),
            metallic_roughness: None,
            metallic: 0.0,
            roughness: 0.25,
            extensions: Some(std::sync::Arc::new(ext)),
        };
        if let Some(deg) = base_deg {
            bsdf = BsdfSpec::NormalMap {
                normals: normal_texel(deg),
                nested: Box::new(bsdf),
            };
        }
        scene.materials[0].bsdf = bsdf;
        let rs = RenderScene::new(scene).unwrap();
        let settings = |spp| RenderSettings {
            width: 32,
            height: 32,
            spp,
            seed: 3,
            path: Default::default(),
        };
        let path = render(&rs, &settings(16), &|_| {}).0.color;
        let light = render_light(&rs, &settings(64), &|_| {}).0;
        let b = BdptSettings {
            path: settings(8).path,
            only: None,
        };
        let bdpt = render_bdpt(&rs, &settings(8), &b, &|_| {}).0;
        [
            ("path", highlight_columns(&path.data, path.channels)),
            ("light", highlight_columns(&light.data, light.channels)),
            ("bdpt", highlight_columns(&bdpt.data, bdpt.channels)),
        ]
    };
    let centre = |c: usize| (c as f32 - 15.5).abs() <= 1.5;
    // The point whose tilted normal faces the camera: x = −2·tan 12°, 0.58 of the half-width
    // 2·tan 20° left of the centre (world −x is the image's left).
    let expected = 15.5 - 16.0 * (12.0f32.to_radians().tan() / 20.0f32.to_radians().tan());
    let moved = |c: usize| (c as f32 - expected).abs() <= 1.5;
    for (name, (coat, base)) in render_all(None, None) {
        println!("untilted, {name}: coat column {coat}, base column {base}");
        assert!(
            centre(coat) && centre(base),
            "{name} untilted: {coat} {base}"
        );
    }
    for (name, (coat, base)) in render_all(Some(12.0), None) {
        println!("coat map, {name}: coat column {coat}, base column {base}");
        assert!(
            moved(coat) && centre(base),
            "{name} coat map: {coat} {base}"
        );
    }
    for (name, (coat, base)) in render_all(None, Some(12.0)) {
        println!("base map, {name}: coat column {coat}, base column {base}");
        assert!(
            centre(coat) && moved(base),
            "{name} base map: {coat} {base}"
        );
    }
}
