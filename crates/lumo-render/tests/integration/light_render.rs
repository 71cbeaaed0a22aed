//! `render_light`, the light tracer over a whole image: the same bits on one and two threads,
//! and the path tracer's image in expectation.

use lumo_render::{render_light, PathSettings, RenderScene, RenderSettings};

use crate::common::media_room::path_jittered;

fn settings(spp: u32) -> RenderSettings {
    RenderSettings {
        width: 24,
        height: 24,
        spp,
        seed: 2,
        path: PathSettings {
            max_depth: 4,
            ..PathSettings::default()
        },
    }
}

#[test]
fn light_traced_images_are_thread_independent_and_agree_with_path_tracing() {
    let rs = RenderScene::new(lumo_scene::builtin_scene("cornell").expect("built-in")).unwrap();
    let s = settings(256);
    let on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| render_light(&rs, &s, &|_| {}))
    };
    let (one, stats) = on(1);
    let (two, _) = on(2);
    assert_eq!(one.data, two.data, "thread count changed the image");
    assert_eq!(stats.samples, 24 * 24 * 256);
    let light: f64 = one.data.iter().map(|&v| v as f64).sum();
    // The path tracer's jittered samples only (its sample 0 through the pixel centre biases
    // each pixel by (centre − mean) / spp; media_room.rs).
    let path: f64 = path_jittered(&rs, &settings(256))
        .iter()
        .map(|&v| v as f64)
        .sum();
    // 0.14 % apart when written (3 % allowed while the centre sample was in the path
    // tracer's means).
    assert!(
        (light / path - 1.0).abs() < 0.005,
        "light tracer {light:.3} vs path tracer {path:.3}"
    );
}
