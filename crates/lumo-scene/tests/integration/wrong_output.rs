//! Inputs that used to render silently wrong images with exit 0 (issue 49): each is now an
//! error or a warning naming the file and the field.

use crate::common;

use common::{load, temp_dir, write};

/// An emissive factor × strength that overflows f32 (or whose film sums of squares would)
/// rendered all black with exit 0; refused naming the material and the product.
#[test]
fn emission_beyond_what_the_film_can_sum_is_refused() {
    let dir = temp_dir("emission-overflow");
    let gltf = std::fs::read_to_string(common::scenes().join("hierarchy.gltf")).unwrap();
    let at = "\"name\": \"gold\",";
    assert!(
        gltf.contains(at),
        "the gold material is where the test expects it"
    );
    for (strength, says) in [("1e39", "not finite"), ("1e20", "too bright")] {
        let edited = gltf
            .replacen(
                at,
                &format!(
                    "{at} \"emissiveFactor\": [1, 1, 1], \"extensions\": \
                     {{\"KHR_materials_emissive_strength\": {{\"emissiveStrength\": {strength}}}}},"
                ),
                1,
            )
            .replacen(
                "\"KHR_lights_punctual\"\n",
                "\"KHR_lights_punctual\", \"KHR_materials_emissive_strength\"\n",
                1,
            );
        let e = load(&write(&dir, "bright.gltf", &edited))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bright.gltf")
                && e.contains("emissiveFactor × KHR_materials_emissive_strength")
                && e.contains(says),
            "{e}"
        );
    }
    let xml = common::mitsuba(
        r#"<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1e38"/></emitter></shape>"#,
    );
    let e = load(&write(&dir, "bright.xml", xml))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bright.xml:3")
            && e.contains("[1e38, 1e38, 1e38]")
            && e.contains("radiance")
            && e.contains("too bright"),
        "{e}"
    );
}
