//! The light tracer in participating media converges to the path tracer's image: a fog box
//! under a light, and chromatic forward-scattering fog around the camera holding a denser
//! chromatic ball (a medium interface with media on both sides), in RGB and spectral
//! transport ([`crate::common::media_room`] judges the differences by the batches' standard
//! errors, with no allowance beyond them); and the same room without media.

use lumo_render::{render_light, RenderScene, RenderSettings};

use crate::common::media_room::{assert_matches_path, room};

/// Light paths per pixel per batch, as many as the path tracer's samples.
const SPP: u32 = 32;

fn light(rs: &RenderScene, s: &RenderSettings) -> Vec<f32> {
    render_light(rs, s, &|_| {}).0.data
}

fn assert_light_matches_path(rs: &RenderScene, what: &str, spectral: bool) {
    assert_matches_path(rs, what, (SPP, SPP), spectral, light);
}

/// The room without media: the light tracer read 0.55 % darker than the path tracer here (3.6
/// standard errors) while the path tracer's sample 0, always through the pixel centre, was in
/// its pixel means; with the path tracer's jittered samples alone the two agree within the
/// statistics (docs/media.md, "Light tracer against path tracer").
#[test]
fn light_tracing_the_room_without_media_matches_path_tracing() {
    let rs = room("", "");
    assert!(!rs.scene.media.is_active());
    assert_light_matches_path(&rs, "room", false);
}

#[test]
fn light_tracing_a_fog_box_matches_path_tracing() {
    let fog = r#"<shape type="cube"><transform name="to_world"><scale value="0.9"/></transform>
    <bsdf type="null"/>
    <medium type="homogeneous" name="interior"><float name="sigma_t" value="1.2"/>
      <float name="albedo" value="0.8"/></medium></shape>"#;
    assert_light_matches_path(&room("", fog), "fog box", false);
}

#[test]
fn light_tracing_chromatic_fog_around_the_camera_matches_path_tracing() {
    let air = r#"<medium type="homogeneous" id="air"><rgb name="sigma_t" value="0.08, 0.2, 0.4"/>
      <rgb name="albedo" value="0.9, 0.7, 0.95"/><phase type="hg"><float name="g" value="0.4"/></phase></medium>"#;
    let ball = r#"<shape type="sphere"><float name="radius" value="0.7"/><bsdf type="null"/>
    <medium type="homogeneous" name="interior"><rgb name="sigma_t" value="3, 1, 0.4"/>
      <rgb name="albedo" value="0.95, 0.6, 0.8"/></medium>
    <ref name="exterior" id="air"/></shape>"#;
    let rs = room(r#"<ref id="air"/>"#, &format!("{air}{ball}"));
    assert_light_matches_path(&rs, "chromatic fog", false);
    assert_light_matches_path(&rs, "chromatic fog, spectral", true);
}
