//! `render_light`, the light tracer over a whole image: the same bits on one and two threads,
//! and the path tracer's image in expectation.

use lumo_render::{render, render_light, PathSettings, RenderScene, RenderSettings};

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
    let path: f64 = render(&rs, &settings(256), &|_| {})
        .0
        .color
        .data
        .iter()
        .map(|&v| v as f64)
        .sum();
    assert!(
        (light / path - 1.0).abs() < 0.03,
        "light tracer {light:.3} vs path tracer {path:.3}"
    );
}
