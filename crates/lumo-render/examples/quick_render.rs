//! Renders a built-in scene without the CLI: `cargo run --release -p lumo-render --example
//! quick_render -- cornell 16 out.png`.

use lumo_render::{render, PathSettings, RenderScene, RenderSettings};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map(String::as_str).unwrap_or("cornell");
    let spp = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(16);
    let out = args.get(3).map(String::as_str).unwrap_or("quick.png");
    let scene = lumo_scene::builtin_scene(name)?;
    let (w, h) = (scene.defaults.width, scene.defaults.height);
    let rs = RenderScene::new(scene)?;
    let settings = RenderSettings {
        width: w,
        height: h,
        spp,
        seed: 0,
        path: PathSettings::default(),
    };
    let t = std::time::Instant::now();
    let (frame, stats) = render(&rs, &settings, &|_| {});
    let s = t.elapsed().as_secs_f64();
    println!(
        "{:.2} s, {:.2} M samples/s, {:.2} M rays/s, mean {:?}",
        s,
        stats.samples as f64 / s / 1e6,
        stats.rays as f64 / s / 1e6,
        frame.color.channel_means()
    );
    for (x, y) in [(320, 335), (320, 400), (200, 300), (250, 100), (256, 480)] {
        println!(
            "px {x},{y}: n {:?} c {:?} alb {:?}",
            frame.normal.pixel(x, y),
            frame.color.pixel(x, y),
            frame.albedo.pixel(x, y)
        );
    }
    lumo_image::write_image(std::path::Path::new(out), &frame.color)?;
    Ok(())
}
