//! Shadow rays through opacity masks (`integrators/path/mask_shadow.rs`): a floor lit by a
//! small panel through a masked sheet. The light sample now crosses the sheet with
//! transmittance 1 − opacity and the BSDF samples that cross it are MIS-weighted against it,
//! so the image keeps its mean (against the BSDF-sampling-only estimator, which never asks a
//! shadow ray) and, where the sheet is see-through, its noise stays that of the open scene.

use std::path::Path;

use lumo_render::{render, PathSettings, RenderScene, RenderSettings};
use lumo_scene::load::{load_mitsuba_str, LoadOptions};

/// The floor, the panel 2 above it facing down, and a sheet of `opacity` at height 1 between
/// them (none for `None`).
fn xml(opacity: Option<f32>) -> String {
    let sheet = opacity.map_or(String::new(), |o| {
        format!(
            r#"<shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="-90"/><scale value="1.5"/><translate y="1"/></transform>
    <bsdf type="mask"><float name="opacity" value="{o}"/>
      <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.7, 0.3"/></bsdf></bsdf></bsdf>
  </shape>"#
        )
    });
    format!(
        r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="50"/>
    <transform name="to_world"><lookat origin="0,0.6,3.5" target="0,0,0" up="0,1,0"/></transform>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="-90"/><scale value="3"/></transform>
    <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.6"/></bsdf></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="90"/><scale value="0.25"/><translate y="2"/></transform>
    <emitter type="area"><rgb name="radiance" value="30"/></emitter>
  </shape>
  {sheet}
</scene>"#
    )
}

/// Per-pixel luminance of `seeds` renders.
fn renders(opacity: Option<f32>, nee: bool, max_depth: u32, spp: u32, seeds: u32) -> Vec<Vec<f64>> {
    let loaded = load_mitsuba_str(
        &xml(opacity),
        Path::new("mask.xml"),
        &LoadOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let rs = RenderScene::new(loaded.scene).unwrap();
    (0..seeds)
        .map(|seed| {
            let settings = RenderSettings {
                width: 24,
                height: 24,
                spp,
                seed,
                path: PathSettings {
                    max_depth,
                    nee,
                    ..Default::default()
                },
            };
            let img = render(&rs, &settings, &|_| {}).0.color;
            img.data
                .chunks(3)
                .map(|p| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64)
                .collect()
        })
        .collect()
}

/// Image mean over the seeds and its standard error.
fn mean_and_error(imgs: &[Vec<f64>]) -> (f64, f64) {
    let means: Vec<f64> = imgs
        .iter()
        .map(|i| i.iter().sum::<f64>() / i.len() as f64)
        .collect();
    let n = means.len() as f64;
    let m = means.iter().sum::<f64>() / n;
    let var = means.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// Mean per-pixel variance across the seeds, relative to the pixel's mean squared.
fn relative_variance(imgs: &[Vec<f64>]) -> f64 {
    let n = imgs.len() as f64;
    let px = imgs[0].len();
    (0..px)
        .map(|k| {
            let m = imgs.iter().map(|i| i[k]).sum::<f64>() / n;
            let v = imgs.iter().map(|i| (i[k] - m).powi(2)).sum::<f64>() / (n - 1.0);
            v / (m * m + 1e-3)
        })
        .sum::<f64>()
        / px as f64
}

#[test]
fn a_see_through_mask_leaves_the_image_and_its_noise_as_without_it() {
    let open = renders(None, true, 6, 16, 8);
    let sheet = renders(Some(0.0), true, 6, 16, 8);
    let ((mo, so), (ms, ss)) = (mean_and_error(&open), mean_and_error(&sheet));
    assert!(
        (ms - mo).abs() < 4.0 * (so * so + ss * ss).sqrt() + 0.002 * mo,
        "open {mo:.5} ± {so:.5}, behind a see-through mask {ms:.5} ± {ss:.5}"
    );
    // Opaque shadow rays left the floor's direct light to BSDF samples through the sheet:
    // 5,600× the open scene's relative variance when written; now the light sample
    // crosses it.
    let (vo, vs) = (relative_variance(&open), relative_variance(&sheet));
    assert!(
        vs < 1.5 * vo,
        "relative variance open {vo:.3e}, behind the mask {vs:.3e}"
    );
}

#[test]
fn light_samples_through_masks_agree_with_bsdf_sampling_alone() {
    // BSDF sampling alone asks no shadow ray: an independent estimator of the same image.
    // Depth 3 limits the crossings (a light sample from the floor may cross the sheet only
    // where a BSDF sample through it still reaches the light within the depth).
    for (opacity, depth) in [(0.5, 6), (0.3, 3), (0.8, 4)] {
        let with_nee = mean_and_error(&renders(Some(opacity), true, depth, 16, 8));
        let bsdf_only = mean_and_error(&renders(Some(opacity), false, depth, 64, 8));
        let ((m1, s1), (m2, s2)) = (with_nee, bsdf_only);
        let z = (m1 - m2).abs() / (s1 * s1 + s2 * s2).sqrt();
        assert!(
            z < 4.0,
            "opacity {opacity}, depth {depth}: light sampling {m1:.5} ± {s1:.5}, BSDF sampling \
             {m2:.5} ± {s2:.5} ({z:.1} standard errors)"
        );
    }
}
