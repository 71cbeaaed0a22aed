//! What lumo renders differently from Mitsuba 3, or with other noise, is said: clip planes
//! that may cut geometry, `direct`'s sample counts, a sampler type Mitsuba does not have.
//! Mitsuba's defaults and its own sampler types load without a word.

use lumo_scene::load::{load_mitsuba_str, LoadOptions};

use crate::common::scenes;

/// The warnings of a one-sphere scene with `sensor` children and the `integrator` element.
fn warnings(sensor: &str, integrator: &str) -> String {
    let text = format!(
        r#"<scene version="3.0.0">
  {integrator}
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
    {sensor}
  </sensor>
  <shape type="sphere"><bsdf type="diffuse"/></shape>
  <emitter type="constant"/>
</scene>"#
    );
    let loaded = load_mitsuba_str(
        &text,
        &scenes().join("virtual.xml"),
        &LoadOptions::default(),
    )
    .expect("the scene loads");
    loaded
        .warnings
        .iter()
        .map(|w| w.to_string())
        .collect::<Vec<_>>()
        .join("\n")
}

const PATH: &str = r#"<integrator type="path"/>"#;

#[test]
fn clip_planes_other_than_mitsubas_defaults_are_warned_about() {
    let quiet = r#"<float name="near_clip" value="0.01"/><float name="far_clip" value="10000"/>"#;
    assert_eq!(warnings(quiet, PATH), "");
    let w = warnings(r#"<float name="near_clip" value="2"/>"#, PATH);
    assert!(
        w.contains("near_clip 2") && w.contains("nearer than 2"),
        "{w}"
    );
    let w = warnings(r#"<float name="far_clip" value="50"/>"#, PATH);
    assert!(w.contains("far_clip 50") && w.contains("farther"), "{w}");
}

#[test]
fn direct_sample_counts_other_than_one_are_warned_about() {
    let direct = |n: u32| {
        format!(
            r#"<integrator type="direct"><integer name="emitter_samples" value="{n}"/><integer name="bsdf_samples" value="1"/></integrator>"#
        )
    };
    assert_eq!(warnings("", &direct(1)), "");
    let w = warnings("", &direct(4));
    assert!(
        w.contains("emitter_samples 4") && !w.contains("bsdf_samples"),
        "{w}"
    );
}

#[test]
fn mitsubas_sampler_types_load_quietly_and_others_are_named() {
    for kind in [
        "independent",
        "stratified",
        "multijitter",
        "orthogonal",
        "ldsampler",
    ] {
        let sampler =
            format!(r#"<sampler type="{kind}"><integer name="sample_count" value="8"/></sampler>"#);
        assert_eq!(warnings(&sampler, PATH), "", "{kind}");
    }
    let w = warnings(r#"<sampler type="halton"/>"#, PATH);
    assert!(
        w.contains("sampler \"halton\" is not one of Mitsuba 3's"),
        "{w}"
    );
}
