//! The light tracer in participating media converges to the path tracer's image: a fog box
//! under a light, and chromatic forward-scattering fog around the camera holding a denser
//! chromatic ball (a medium interface with media on both sides), in RGB and spectral
//! transport. Both images are rendered in independent batches; each block's difference is
//! judged against the standard error the batches show, so the tolerance follows the sample
//! counts.

use std::path::Path;

use lumo_render::{render, render_light, PathSettings, RenderScene, RenderSettings};
use lumo_scene::load::{load_mitsuba_str, LoadOptions};

/// Image side, block side (pixels), batches per integrator.
const SIZE: usize = 16;
const BLOCK: usize = 4;
const BATCHES: u32 = 12;
const SEED0: u32 = 1000;

/// A room (back wall, floor, a small ceiling light facing down) seen from z = 4 through a
/// box pixel filter (the light tracer's splats are box-filtered; another filter would differ
/// at the image's edges), with
/// `sensor_medium` inside the sensor element and `shapes` added.
fn room(sensor_medium: &str, shapes: &str) -> RenderScene {
    let xml = format!(
        r#"<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="50"/>
    <transform name="to_world"><lookat origin="0,0,4" target="0,0,0" up="0,1,0"/></transform>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/>
      <rfilter type="box"/></film>
    {sensor_medium}
  </sensor>
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><translate z="-1.5"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.5, 0.3"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/><scale value="3"/><translate y="-1.2"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="90"/><scale value="0.5"/><translate y="1.4"/></transform>
    <emitter type="area"><rgb name="radiance" value="10"/></emitter></shape>
  {shapes}
</scene>"#
    );
    let scene = load_mitsuba_str(
        &xml,
        Path::new("media-light-test.xml"),
        &LoadOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"))
    .scene;
    assert!(scene.media.is_active());
    RenderScene::new(scene).unwrap()
}

fn settings(seed: u32, spp: u32, spectral: bool) -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        spp,
        seed,
        path: PathSettings {
            max_depth: 12,
            rr_depth: 4,
            spectral,
            ..Default::default()
        },
    }
}

/// Per block and channel (index `(block * 3 + channel)`), the mean over the batches and its
/// standard error.
fn block_stats(images: &[Vec<f32>]) -> Vec<(f64, f64)> {
    let nb = SIZE / BLOCK;
    let per = |img: &[f32]| {
        let mut out = vec![0.0f64; nb * nb * 3];
        for y in 0..SIZE {
            for x in 0..SIZE {
                for c in 0..3 {
                    out[((y / BLOCK) * nb + x / BLOCK) * 3 + c] +=
                        img[(y * SIZE + x) * 3 + c] as f64 / (BLOCK * BLOCK) as f64;
                }
            }
        }
        out
    };
    let blocks: Vec<Vec<f64>> = images.iter().map(|i| per(i)).collect();
    let n = blocks.len() as f64;
    (0..nb * nb * 3)
        .map(|k| {
            let mean = blocks.iter().map(|b| b[k]).sum::<f64>() / n;
            let var = blocks.iter().map(|b| (b[k] - mean).powi(2)).sum::<f64>() / (n - 1.0);
            (mean, (var / n).sqrt())
        })
        .collect()
}

/// How many standard errors the light tracer's `ml` (± `sl`) lies from the path tracer's
/// `mp` (± `sp`), after an allowance of 1 % of `mp`: without any medium, this room's light-
/// and path-traced means differ by 0.55 % (3.6 standard errors at these counts), a
/// surface-only difference older than media that this test does not judge.
fn deviation(mp: f64, sp: f64, ml: f64, sl: f64) -> f64 {
    let off = ((ml - mp).abs() - 0.01 * mp.abs()).max(0.0);
    off / (sp * sp + sl * sl).sqrt().max(1e-6)
}

/// Light tracing and path tracing `rs` in batches agree block by block and channel by
/// channel within 1 % plus 5 standard errors, and so do the image means.
fn assert_light_matches_path(rs: &RenderScene, what: &str, spectral: bool) {
    let path: Vec<Vec<f32>> = (0..BATCHES)
        .map(|b| {
            render(rs, &settings(b + SEED0, 32, spectral), &|_| {})
                .0
                .color
                .data
        })
        .collect();
    let light: Vec<Vec<f32>> = (0..BATCHES)
        .map(|b| {
            render_light(rs, &settings(100 + b, 32, spectral), &|_| {})
                .0
                .data
        })
        .collect();
    let (p, l) = (block_stats(&path), block_stats(&light));
    let mut worst = 0.0f64;
    for (k, ((mp, sp), (ml, sl))) in p.iter().zip(&l).enumerate() {
        let z = deviation(*mp, *sp, *ml, *sl);
        worst = worst.max(z.abs());
        assert!(
            z.abs() < 5.0,
            "{what}: block {} channel {}: path {mp:.4} ± {sp:.4}, light {ml:.4} ± {sl:.4} \
             ({z:.1} standard errors)",
            k / 3,
            k % 3
        );
    }
    // The image means per channel: the same test at the whole image's scale, where a
    // bias of a few per cent shows above the noise.
    for c in 0..3 {
        let means = |imgs: &[Vec<f32>]| {
            let m: Vec<f64> = imgs
                .iter()
                .map(|i| i.iter().skip(c).step_by(3).map(|&v| v as f64).sum::<f64>())
                .map(|v| v / (SIZE * SIZE) as f64)
                .collect();
            let n = m.len() as f64;
            let mean = m.iter().sum::<f64>() / n;
            let var = m.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
            (mean, (var / n).sqrt())
        };
        let ((mp, sp), (ml, sl)) = (means(&path), means(&light));
        let z = deviation(mp, sp, ml, sl);
        eprintln!("{what}: channel {c} mean: path {mp:.4} ± {sp:.4}, light {ml:.4} ± {sl:.4} ({z:.1} standard errors)");
        assert!(
            z.abs() < 5.0,
            "{what}: channel {c} mean: path {mp:.4} ± {sp:.4}, light {ml:.4} ± {sl:.4} \
             ({z:.1} standard errors)"
        );
    }
    eprintln!("{what}: worst block {worst:.2} standard errors");
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
