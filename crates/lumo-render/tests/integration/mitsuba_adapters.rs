//! Mitsuba features beyond plain BSDFs: instanced shape groups (lights in them too), the thin
//! dielectric sheet, and the normal-map, bump-map and mask adapters where they must change
//! nothing. (Their agreement with Mitsuba 3 itself is checked by the validation suite,
//! tests/integration/mitsuba_suite.rs.)

use std::path::Path;

use glam::{Vec2, Vec3};
use lumo_image::Image;
use lumo_render::bsdf::{fresnel_dielectric, thin_dielectric_reflectance, Bsdf, ThinDielectric};
use lumo_render::{render, PathSettings, RenderScene, RenderSettings};
use lumo_scene::load::{load_mitsuba_str, LoadOptions};

/// A scene: a camera over a floor, with `body` added.
fn xml(body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="45"/>
    <transform name="to_world"><lookat origin="0,3,6" target="0,0.5,0" up="0,1,0"/></transform>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="-90"/><scale value="4"/></transform>
    <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.6"/></bsdf></bsdf>
  </shape>
  <emitter type="constant"><rgb name="radiance" value="0.2"/></emitter>
  {body}
</scene>"#
    )
}

fn render_xml(text: &str, spp: u32) -> Image {
    let loaded = load_mitsuba_str(text, Path::new("test.xml"), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let rs = RenderScene::new(loaded.scene).unwrap();
    let settings = RenderSettings {
        width: 32,
        height: 32,
        spp,
        seed: 3,
        path: PathSettings {
            max_depth: 6,
            ..Default::default()
        },
    };
    render(&rs, &settings, &|_| {}).0.color
}

fn mean(img: &Image) -> Vec3 {
    let n = (img.width * img.height) as f32;
    (0..img.height)
        .flat_map(|y| (0..img.width).map(move |x| (x, y)))
        .map(|(x, y)| Vec3::from(img.rgb(x, y)))
        .sum::<Vec3>()
        / n
}

#[test]
fn instanced_group_with_a_light_renders_as_its_copies() {
    let light = r#"<emitter type="area"><rgb name="radiance" value="8, 6, 4"/></emitter>"#;
    let box_bsdf = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.4, 0.2"/></bsdf>"#;
    let placements = [
        r#"<translate x="-1.5"/>"#,
        r#"<rotate y="1" angle="30"/><scale value="1.3"/><translate x="1.2" z="-0.5"/>"#,
    ];
    let mut instanced = format!(
        r#"<shape type="shapegroup" id="lamp">
             <shape type="cube"><transform name="to_world"><scale value="0.3"/><translate y="0.3"/></transform>{box_bsdf}</shape>
             <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="90"/><scale value="0.25"/><translate y="1.2"/></transform>{light}</shape>
           </shape>"#
    );
    let mut copied = String::new();
    for p in placements {
        instanced.push_str(&format!(
            r#"<shape type="instance"><ref id="lamp"/><transform name="to_world">{p}</transform></shape>"#
        ));
        // The same shapes with the group's and the instance's transforms composed.
        copied.push_str(&format!(
            r#"<shape type="cube"><transform name="to_world"><scale value="0.3"/><translate y="0.3"/>{p}</transform>{box_bsdf}</shape>
               <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="90"/><scale value="0.25"/><translate y="1.2"/>{p}</transform>{light}</shape>"#
        ));
    }
    let a = render_xml(&xml(&instanced), 64);
    let b = render_xml(&xml(&copied), 64);
    let (ma, mb) = (mean(&a), mean(&b));
    // The instanced lights must count: brighter than the scene without them.
    let dark = mean(&render_xml(&xml(&copied.replace(light, "")), 64));
    assert!(ma.x > 1.1 * dark.x, "{ma} vs {dark} unlit");
    let rel = ((ma - mb) / mb).abs().max_element();
    assert!(rel < 0.01, "instanced {ma} vs copied {mb}");
}

#[test]
fn flat_normal_and_bump_maps_and_opaque_masks_change_nothing() {
    let diffuse = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.7"/></bsdf>"#;
    let shape = |bsdf: &str| {
        xml(&format!(
            r#"<shape type="rectangle"><transform name="to_world"><scale value="0.8"/><rotate x="1" angle="-60"/><translate y="0.5"/></transform>{bsdf}</shape>
               <shape type="sphere"><point name="center" value="0, 2, 1"/><float name="radius" value="0.3"/><emitter type="area"><rgb name="radiance" value="10"/></emitter></shape>"#
        ))
    };
    let plain = render_xml(&shape(diffuse), 16);
    for adapted in [
        format!(
            r#"<bsdf type="normalmap"><rgb name="normalmap" value="0.5, 0.5, 1"/>{diffuse}</bsdf>"#
        ),
        format!(
            r#"<bsdf type="bumpmap"><texture type="checkerboard"/><float name="scale" value="3"/>{diffuse}</bsdf>"#
        ),
        format!(r#"<bsdf type="mask"><float name="opacity" value="1"/>{diffuse}</bsdf>"#),
    ] {
        let img = render_xml(&shape(&adapted), 16);
        assert_eq!(img.data, plain.data, "{adapted}");
    }
    // A tilted normal map does change it (the comparison above can fail).
    let tilted = render_xml(
        &shape(&format!(
            r#"<bsdf type="normalmap"><rgb name="normalmap" value="0.9, 0.5, 0.7"/>{diffuse}</bsdf>"#
        )),
        16,
    );
    assert_ne!(tilted.data, plain.data);
}

#[test]
fn thin_dielectric_conserves_energy_and_samples_its_lobes_in_proportion() {
    for eta in [1.0001f32, 1.33, 1.5, 2.4, 0.7] {
        for i in 0..=20 {
            let cos = (i as f32 / 20.0).max(1e-3);
            // The series the closed form sums: R + T²R (1 + R² + R⁴ + …), and what is left
            // T²(1 + R² + …) goes through.
            let r1 = fresnel_dielectric(cos, eta).0 as f64;
            let t1 = 1.0 - r1;
            let (mut bounces, mut p) = (0.0f64, 1.0f64);
            for _ in 0..100_000 {
                bounces += p;
                p *= r1 * r1;
            }
            let (r, t) = (r1 + t1 * t1 * r1 * bounces, t1 * t1 * bounces);
            let closed = thin_dielectric_reflectance(cos, eta);
            assert!(
                (closed as f64 - r).abs() < 1e-4,
                "eta {eta} cos {cos}: {closed} vs {r}"
            );
            assert!((r + t - 1.0).abs() < 1e-4, "R + T = {}", r + t);

            let bsdf = Bsdf::ThinDielectric(ThinDielectric { eta });
            let sin = (1.0 - cos * cos).sqrt();
            for wo in [Vec3::new(sin, 0.0, cos), Vec3::new(0.0, -sin, -cos)] {
                // Sampling over a fine grid of lobe numbers: the reflected fraction is R',
                // every weight is 1 (R'/R' and T'/T'), so the expected weight is R' + T' = 1.
                let n = 4000;
                let (mut reflected, mut energy) = (0usize, 0.0f64);
                for k in 0..n {
                    let u = (k as f32 + 0.5) / n as f32;
                    let s = bsdf.sample(wo, u, Vec2::splat(0.5)).unwrap();
                    assert!(s.delta && s.eta == 1.0);
                    assert_eq!(s.weight, Vec3::ONE);
                    if s.wi.z * wo.z > 0.0 {
                        reflected += 1;
                        assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
                        assert!((s.pdf - closed).abs() < 1e-6);
                    } else {
                        assert_eq!(s.wi, -wo, "straight through");
                        assert!((s.pdf - (1.0 - closed)).abs() < 1e-6);
                    }
                    energy += s.weight.x as f64;
                }
                let frac = reflected as f32 / n as f32;
                assert!((frac - closed).abs() < 2.0 / n as f32, "{frac} vs {closed}");
                assert!((energy / n as f64 - 1.0).abs() < 1e-9);
                // Delta lobes: nothing for light sampling.
                assert_eq!(bsdf.eval(wo, -wo), Vec3::ZERO);
                assert_eq!(bsdf.pdf(wo, -wo), 0.0);
                assert!(bsdf.is_delta());
            }
        }
    }
}
