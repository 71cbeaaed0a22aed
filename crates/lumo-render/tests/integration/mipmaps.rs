//! Mip-mapped textures: a finely textured floor seen towards the horizon, where a pixel
//! covers hundreds of texels. Read over one sample's footprint, a 1-spp frame is far closer
//! to the converged image than point lookups, and many samples still converge to it.

use std::sync::Arc;

use glam::{Affine2, Mat4, Vec2, Vec3};
use lumo_image::Image;
use lumo_render::{render, PathSettings, RenderScene, RenderSettings};
use lumo_scene::shapes::rectangle;
use lumo_scene::{
    BsdfSpec, Camera, FovAxis, Light, Material, MipFilter, MipMap, Scene, Texture, TextureFilter,
    WrapMode,
};

/// A 40×40 floor facing up under a white sky, its 64×64 texture repeated 40 times (64 texels
/// per world unit), seen from half a unit above it.
fn floor_scene() -> Scene {
    let mut scene = Scene::empty(Camera {
        origin: Vec3::new(0.0, 0.5, 0.0),
        target: Vec3::new(0.0, 0.0, -6.0),
        up: Vec3::Y,
        fov: 60.0,
        fov_axis: FovAxis::X,
        lens: Default::default(),
        filter: Default::default(),
    });
    // Waves 16 and 8 texels long (which mip levels 1–3 keep) over a checker of one-texel
    // squares (which they average away).
    let data = (0..64 * 64)
        .flat_map(|i| {
            let (x, y) = ((i % 64) as f32, (i / 64) as f32);
            let wave =
                (x * std::f32::consts::TAU / 16.0).sin() * (y * std::f32::consts::TAU / 8.0).cos();
            let v = 0.45
                + 0.3 * wave
                + if (i % 64 + i / 64) % 2 == 0 {
                    -0.1
                } else {
                    0.1
                };
            [v, v * 0.9, v * 0.7]
        })
        .collect();
    let checker = Texture::Mipmapped {
        mips: Arc::new(MipMap::new(Arc::new(Image::from_vec(64, 64, 3, data)))),
        magnify: TextureFilter::Bilinear,
        minify: TextureFilter::Bilinear,
        between: MipFilter::Linear,
        wrap: WrapMode::Repeat,
    };
    let mut m = Material::diffuse("floor", Vec3::splat(0.5));
    m.bsdf = BsdfSpec::Diffuse {
        reflectance: Texture::Transformed {
            texture: Arc::new(checker),
            uv: Affine2::from_scale(Vec2::splat(40.0)),
        },
    };
    let m = scene.add_material(m);
    scene.add_mesh(rectangle(
        &(Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2)
            * Mat4::from_scale(Vec3::splat(20.0))),
        m,
    ));
    scene.lights.push(Light::Constant {
        radiance: Vec3::ONE,
    });
    scene
}

/// The colour and albedo planes.
fn frame(rs: &RenderScene, spp: u32, seed: u32) -> (Image, Image) {
    let settings = RenderSettings {
        width: 64,
        height: 40,
        spp,
        seed,
        path: PathSettings {
            max_depth: 2,
            ..Default::default()
        },
    };
    let f = render(rs, &settings, &|_| {}).0;
    (f.color, f.albedo)
}

/// Mean over pixels of (a − r)² / (r² + 0.01), per channel.
fn rel_mse(a: &Image, r: &Image) -> f64 {
    let n = a.data.len() as f64;
    a.data
        .iter()
        .zip(&r.data)
        .map(|(&a, &r)| ((a - r) as f64).powi(2) / ((r as f64).powi(2) + 0.01))
        .sum::<f64>()
        / n
}

fn mean(a: &Image) -> f64 {
    a.data.iter().map(|&v| v as f64).sum::<f64>() / a.data.len() as f64
}

#[test]
fn a_mip_mapped_floor_converges_at_one_sample_and_keeps_its_mean() {
    let plain = RenderScene::new(floor_scene()).expect("scene");
    let (reference, reference_albedo) = frame(&plain, 256, 1);
    let (point, point_albedo) = frame(&plain, 1, 2);

    let mut mipped = RenderScene::new(floor_scene()).expect("scene");
    mipped.set_texture_footprint(64, 40, 1);
    let (filtered, filtered_albedo) = frame(&mipped, 1, 2);
    // The albedo plane is the texture alone (the lighting's own noise left out).
    let (e_point, e_filtered) = (
        rel_mse(&point_albedo, &reference_albedo),
        rel_mse(&filtered_albedo, &reference_albedo),
    );
    assert!(
        e_filtered < 0.4 * e_point,
        "1 spp albedo relMSE: mip-mapped {e_filtered:.3e} against point lookups {e_point:.3e}"
    );
    let (e_point, e_filtered) = (rel_mse(&point, &reference), rel_mse(&filtered, &reference));
    eprintln!("1 spp colour relMSE: mip-mapped {e_filtered:.3e}, point lookups {e_point:.3e}");
    assert!(
        e_filtered < 0.7 * e_point,
        "1 spp relMSE: mip-mapped {e_filtered:.3e} against point lookups {e_point:.3e}"
    );

    // At 64 spp a sample spans an eighth of a pixel: the image converges to the reference.
    mipped.set_texture_footprint(64, 40, 64);
    let (many, many_albedo) = frame(&mipped, 64, 2);
    let (m, r) = (mean(&many), mean(&reference));
    assert!((m - r).abs() < 0.01 * r, "mean {m} against {r}");
    let (m, r) = (mean(&many_albedo), mean(&reference_albedo));
    assert!((m - r).abs() < 0.005 * r, "albedo mean {m} against {r}");
    let (_, point_many_albedo) = frame(&plain, 64, 2);
    let (e_many, e_point_many) = (
        rel_mse(&many_albedo, &reference_albedo),
        rel_mse(&point_many_albedo, &reference_albedo),
    );
    eprintln!("64 spp albedo relMSE: mip-mapped {e_many:.3e}, point lookups {e_point_many:.3e}");
    assert!(
        e_many < e_point_many,
        "64 spp albedo relMSE: mip-mapped {e_many:.3e} against point lookups {e_point_many:.3e}"
    );
}
