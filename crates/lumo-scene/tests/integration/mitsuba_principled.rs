//! Mitsuba's `principled` BSDF: its parameters as values and textures, `specular` as an index,
//! and bad values refused by name.

use crate::common;

use common::{load, mitsuba, temp_dir, write};
use lumo_scene::{BsdfSpec, PrincipledSpec, Texture, Vec3};

/// The principled material of a one-shape scene whose BSDF body is `params`.
fn principled(name: &str, params: &str) -> Result<(PrincipledSpec, String), String> {
    let dir = temp_dir(name);
    let p = write(
        &dir,
        "p.xml",
        mitsuba(&format!(
            r#"<shape type="sphere"><bsdf type="principled">{params}</bsdf></shape>
               <emitter type="constant"/>"#
        )),
    );
    let loaded = load(&p).map_err(|e| e.to_string())?;
    let warnings: String = loaded.warnings.iter().map(|w| format!("{w}\n")).collect();
    let s = &loaded.scene;
    match &s.materials[s.meshes[0].material].bsdf {
        BsdfSpec::Principled(p) => Ok(((**p).clone(), warnings)),
        other => panic!("not a principled BSDF: {other:?}"),
    }
}

fn constant(t: &Texture) -> Vec3 {
    match t {
        Texture::Constant(c) => *c,
        other => panic!("not a constant: {other:?}"),
    }
}

#[test]
fn every_parameter_is_read_as_written() {
    let (p, warnings) = principled(
        "principled_values",
        r#"<rgb name="base_color" value="0.8, 0.2, 0.1"/>
           <float name="roughness" value="0.3"/><float name="anisotropic" value="0.4"/>
           <float name="metallic" value="0.6"/><float name="spec_trans" value="0.2"/>
           <float name="eta" value="1.33"/><float name="spec_tint" value="0.7"/>
           <float name="sheen" value="0.5"/><float name="sheen_tint" value="0.25"/>
           <float name="clearcoat" value="0.9"/><float name="clearcoat_gloss" value="0.8"/>
           <float name="flatness" value="0.1"/>
           <float name="clearcoat_sampling_rate" value="0.5"/>"#,
    )
    .unwrap();
    assert!(warnings.is_empty(), "{warnings}");
    assert_eq!(constant(&p.base_color), Vec3::new(0.8, 0.2, 0.1));
    let fields = [
        (&p.roughness, 0.3),
        (&p.anisotropic, 0.4),
        (&p.metallic, 0.6),
        (&p.spec_trans, 0.2),
        (&p.spec_tint, 0.7),
        (&p.sheen, 0.5),
        (&p.sheen_tint, 0.25),
        (&p.clearcoat, 0.9),
        (&p.clearcoat_gloss, 0.8),
        (&p.flatness, 0.1),
    ];
    for (t, v) in fields {
        assert_eq!(constant(t), Vec3::splat(v));
    }
    assert_eq!(p.eta, 1.33);
    assert_eq!(p.sampling_rates, [1.0, 1.0, 0.5]);
}

#[test]
fn defaults_and_specular_follow_mitsuba() {
    let (p, _) = principled("principled_defaults", "").unwrap();
    assert_eq!(constant(&p.base_color), Vec3::splat(0.5));
    assert_eq!(constant(&p.roughness), Vec3::splat(0.5));
    assert_eq!(constant(&p.metallic), Vec3::ZERO);
    // specular 0.5 (the default) is Mitsuba's index 1.5: F0 = 0.08 · specular = 0.04.
    assert!((p.eta - 1.5).abs() < 1e-6, "{}", p.eta);
    let (p, _) = principled(
        "principled_specular",
        r#"<float name="specular" value="1"/>"#,
    )
    .unwrap();
    let f0 = ((p.eta - 1.0) / (p.eta + 1.0)).powi(2);
    assert!((f0 - 0.08).abs() < 1e-6, "specular 1 is F0 0.08, not {f0}");
    // An index of 1 cannot refract: Mitsuba reads it as 1.001 where the surface transmits.
    let (p, _) = principled(
        "principled_eta1",
        r#"<float name="eta" value="1"/><float name="spec_trans" value="1"/>"#,
    )
    .unwrap();
    assert_eq!(p.eta, 1.001);
}

#[test]
fn parameters_take_textures() {
    let (p, warnings) = principled(
        "principled_textures",
        r#"<texture name="roughness" type="checkerboard">
               <float name="color0" value="0.1"/><float name="color1" value="0.9"/></texture>
           <texture name="base_color" type="checkerboard"/>
           <texture name="metallic" type="checkerboard"/>
           <texture name="clearcoat" type="checkerboard"/>
           <texture name="spec_trans" type="checkerboard"/>
           <texture name="sheen" type="checkerboard"/>"#,
    )
    .unwrap();
    assert!(warnings.is_empty(), "{warnings}");
    for t in [
        &p.roughness,
        &p.base_color,
        &p.metallic,
        &p.clearcoat,
        &p.spec_trans,
        &p.sheen,
    ] {
        assert!(matches!(t, Texture::Checkerboard { .. }), "{t:?}");
    }
    assert!(p.transmits(), "a textured spec_trans may transmit");
}

#[test]
fn bad_values_are_refused_by_name() {
    for (params, field) in [
        (r#"<float name="metallic" value="1.5"/>"#, "metallic"),
        (r#"<float name="roughness" value="1.01"/>"#, "roughness"),
        (r#"<float name="spec_trans" value="2"/>"#, "spec_trans"),
        (
            r#"<float name="clearcoat_gloss" value="nan"/>"#,
            "clearcoat_gloss",
        ),
        (r#"<float name="eta" value="-1.5"/>"#, "eta"),
        (r#"<float name="specular" value="3"/>"#, "specular"),
        (
            r#"<float name="eta" value="1.5"/><float name="specular" value="0.5"/>"#,
            "eta or specular",
        ),
        (
            r#"<float name="main_specular_sampling_rate" value="-1"/>"#,
            "main_specular_sampling_rate",
        ),
    ] {
        let err = principled("principled_bad", params).unwrap_err();
        assert!(err.contains(field), "{params}: {err}");
        assert!(err.contains("p.xml"), "the message names the file: {err}");
    }
}

#[test]
fn an_unknown_parameter_is_named_in_a_warning() {
    let (_, warnings) = principled(
        "principled_unknown",
        r#"<float name="subsurface" value="0.5"/>"#,
    )
    .unwrap();
    assert!(warnings.contains("subsurface"), "{warnings}");
}
