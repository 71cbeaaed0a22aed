//! A small room with participating media, and the batch statistics that compare another
//! integrator's images of it with the path tracer's: each block's difference is judged
//! against the standard error the batches show, so the tolerance follows the sample counts.
//! Shared by the light tracer's and BDPT's media tests.

use std::path::Path;

use lumo_render::camera::PinholeCamera;
use lumo_render::integrators::path::wavefront::render_pixels_from;
use lumo_render::{PathSettings, RenderScene, RenderSettings};
use lumo_scene::load::{load_mitsuba_str, LoadOptions};

/// Image side, block side (pixels), batches per integrator.
pub const SIZE: usize = 16;
pub const BLOCK: usize = 4;
pub const BATCHES: u32 = 12;
const SEED0: u32 = 1000;

/// A room (back wall, floor, a small ceiling light facing down) seen from z = 4 through a
/// box pixel filter (the light tracer's splats are box-filtered; another filter would differ
/// at the image's edges), with `sensor_medium` inside the sensor element and `shapes` added.
pub fn room(sensor_medium: &str, shapes: &str) -> RenderScene {
    RenderScene::new(room_scene(sensor_medium, shapes)).unwrap()
}

/// The scene of [`room`], before the render scene is built (for tests that add lights the
/// Mitsuba format has no words for).
pub fn room_scene(sensor_medium: &str, shapes: &str) -> lumo_scene::Scene {
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
    load_mitsuba_str(
        &xml,
        Path::new("media-room-test.xml"),
        &LoadOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"))
    .scene
}

/// Settings of batch `seed` at `spp` samples (or light paths) per pixel.
pub fn settings(seed: u32, spp: u32, spectral: bool) -> RenderSettings {
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
    mean_and_error(&blocks)
}

/// Per entry, the mean over `samples` and its standard error.
fn mean_and_error(samples: &[Vec<f64>]) -> Vec<(f64, f64)> {
    let n = samples.len() as f64;
    (0..samples[0].len())
        .map(|k| {
            let mean = samples.iter().map(|b| b[k]).sum::<f64>() / n;
            let var = samples.iter().map(|b| (b[k] - mean).powi(2)).sum::<f64>() / (n - 1.0);
            (mean, (var / n).sqrt())
        })
        .collect()
}

/// How many standard errors `mo` (± `so`) lies from the path tracer's `mp` (± `sp`).
fn deviation(mp: f64, sp: f64, mo: f64, so: f64) -> f64 {
    (mo - mp).abs() / (sp * sp + so * so).sqrt().max(1e-6)
}

/// The path tracer's image of `rs` from its samples `1..=spp`: sample 0 goes through the
/// pixel centre (the filters' guide ray), a fixed point that biases a pixel's mean by
/// (centre − mean) / spp; its jittered samples alone estimate the box-filtered pixel without
/// bias, which is what the light tracer's and BDPT's splats estimate.
pub fn path_jittered(rs: &RenderScene, s: &RenderSettings) -> Vec<f32> {
    let camera = PinholeCamera::new(&rs.scene.camera, s.width, s.height);
    (0..s.height)
        .flat_map(|y| render_pixels_from(rs, &camera, s, 1, y, 0..s.width))
        .flat_map(|e| (e.direct + e.indirect).to_array())
        .collect()
}

/// `what`'s images of `rs` (`other` renders one batch from its settings) and the path
/// tracer's, each in [`BATCHES`] batches of `spp` and `other_spp` samples, agree block by
/// block and channel by channel within 5 standard errors, and so do the image means per
/// channel. The path tracer's images leave out its pixel-centre sample ([`path_jittered`]).
pub fn assert_matches_path(
    rs: &RenderScene,
    what: &str,
    (spp, other_spp): (u32, u32),
    spectral: bool,
    other: impl Fn(&RenderScene, &RenderSettings) -> Vec<f32>,
) {
    let path: Vec<Vec<f32>> = (0..BATCHES)
        .map(|b| path_jittered(rs, &settings(b + SEED0, spp, spectral)))
        .collect();
    let others: Vec<Vec<f32>> = (0..BATCHES)
        .map(|b| other(rs, &settings(100 + b, other_spp, spectral)))
        .collect();
    let (p, o) = (block_stats(&path), block_stats(&others));
    let mut worst = 0.0f64;
    for (k, ((mp, sp), (mo, so))) in p.iter().zip(&o).enumerate() {
        let z = deviation(*mp, *sp, *mo, *so);
        worst = worst.max(z);
        assert!(
            z < 5.0,
            "{what}: block {} channel {}: path {mp:.4} ± {sp:.4}, other {mo:.4} ± {so:.4} \
             ({z:.1} standard errors)",
            k / 3,
            k % 3
        );
    }
    // The image means per channel: the same test at the whole image's scale, where a
    // bias of a few per cent shows above the noise.
    let means = |imgs: &[Vec<f32>]| {
        let per: Vec<Vec<f64>> = imgs
            .iter()
            .map(|i| {
                (0..3)
                    .map(|c| {
                        i.iter().skip(c).step_by(3).map(|&v| v as f64).sum::<f64>()
                            / (SIZE * SIZE) as f64
                    })
                    .collect()
            })
            .collect();
        mean_and_error(&per)
    };
    let (pm, om) = (means(&path), means(&others));
    for c in 0..3 {
        let ((mp, sp), (mo, so)) = (pm[c], om[c]);
        let z = deviation(mp, sp, mo, so);
        let raw = (mo - mp) / (sp * sp + so * so).sqrt().max(1e-6);
        eprintln!(
            "{what}: channel {c} mean: path {mp:.5} ± {sp:.5}, other {mo:.5} ± {so:.5} \
             ({raw:+.1} standard errors, {:+.2} %)",
            100.0 * (mo / mp - 1.0)
        );
        assert!(
            z < 5.0,
            "{what}: channel {c} mean: path {mp:.5} ± {sp:.5}, other {mo:.5} ± {so:.5} \
             ({z:.1} standard errors)"
        );
    }
    eprintln!("{what}: worst block {worst:.2} standard errors");
}
