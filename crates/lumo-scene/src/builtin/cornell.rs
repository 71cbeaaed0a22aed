//! The Cornell box exactly as Mitsuba 3's `mitsuba.cornell_box()` defines it (see
//! docs/cornell-box-mitsuba.md), and a variant with spheres.

use glam::{Mat4, Vec3};

use crate::shapes::{cube, rectangle, sphere};
use crate::{BsdfSpec, Camera, FovAxis, Material, RenderDefaults, Roughness, Scene, Texture};

fn deg(a: f32) -> f32 {
    a.to_radians()
}

/// Builds the box; `with_boxes` adds Mitsuba's two white boxes.
fn cornell_shell(name: &str, with_boxes: bool) -> (Scene, usize) {
    let mut scene = Scene {
        name: name.into(),
        meshes: vec![],
        instances: vec![],
        materials: vec![],
        lights: vec![],
        camera: Camera {
            origin: Vec3::new(0.0, 0.0, 3.9),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov: 39.3077,
            fov_axis: FovAxis::Smaller,
            lens: Default::default(),
            filter: Default::default(),
        },
        defaults: RenderDefaults {
            width: 512,
            height: 512,
            spp: 16,
            max_depth: 8,
        },
        media: Default::default(),
    };
    let white = scene.add_material(Material::diffuse(
        "white",
        Vec3::new(0.885809, 0.698859, 0.666422),
    ));
    let green = scene.add_material(Material::diffuse(
        "green",
        Vec3::new(0.105421, 0.37798, 0.076425),
    ));
    let red = scene.add_material(Material::diffuse(
        "red",
        Vec3::new(0.570068, 0.0430135, 0.0443706),
    ));
    let light = scene.add_material(
        Material::diffuse("light", Vec3::new(0.885809, 0.698859, 0.666422))
            .with_emission(Vec3::new(18.387, 13.9873, 6.75357)),
    );
    // Mitsuba's cornell_box() uses plain (one-sided) diffuse BSDFs: the back of the light,
    // reached through the gap below the ceiling, is black there. Matching it keeps
    // scenes/cornell.xml bit-identical to this scene.
    for m in [white, green, red, light] {
        scene.materials[m].two_sided = false;
    }
    let t = Mat4::from_translation;
    let rx = |a: f32| Mat4::from_axis_angle(Vec3::X, deg(a));
    let ry = |a: f32| Mat4::from_axis_angle(Vec3::Y, deg(a));
    let s = Mat4::from_scale;
    let walls = [
        (
            "light",
            t(Vec3::new(0.0, 0.99, 0.01)) * rx(90.0) * s(Vec3::new(0.23, 0.19, 0.19)),
            light,
        ),
        ("floor", t(Vec3::new(0.0, -1.0, 0.0)) * rx(-90.0), white),
        ("ceiling", t(Vec3::new(0.0, 1.0, 0.0)) * rx(90.0), white),
        ("back", t(Vec3::new(0.0, 0.0, -1.0)), white),
        ("green-wall", t(Vec3::new(1.0, 0.0, 0.0)) * ry(-90.0), green),
        ("red-wall", t(Vec3::new(-1.0, 0.0, 0.0)) * ry(90.0), red),
    ];
    for (name, m, mat) in walls {
        let mut mesh = rectangle(&m, mat);
        mesh.name = name.into();
        scene.add_mesh(mesh);
    }
    if with_boxes {
        let boxes = [
            (
                "small-box",
                t(Vec3::new(0.335, -0.7, 0.38)) * ry(-17.0) * s(Vec3::splat(0.3)),
            ),
            (
                "large-box",
                t(Vec3::new(-0.33, -0.4, -0.28)) * ry(18.25) * s(Vec3::new(0.3, 0.61, 0.3)),
            ),
        ];
        for (name, m) in boxes {
            let mut mesh = cube(&m, white);
            mesh.name = name.into();
            scene.add_mesh(mesh);
        }
    }
    (scene, white)
}

/// Mitsuba 3's `cornell_box()`.
pub(crate) fn cornell() -> Scene {
    cornell_shell("cornell", true).0
}

/// The box with a rough gold sphere, a glass sphere and a checkerboard floor.
pub(crate) fn cornell_spheres() -> Scene {
    let (mut scene, _white) = cornell_shell("cornell-spheres", false);
    let checker = scene.add_material(Material {
        name: "checker".into(),
        bsdf: BsdfSpec::Diffuse {
            reflectance: Texture::Checkerboard {
                color0: Vec3::new(0.8, 0.8, 0.8),
                color1: Vec3::new(0.2, 0.2, 0.25),
                scale: 8.0,
            },
        },
        emission: Vec3::ZERO,
        two_sided: true,
        emission_map: None,
        spectra: Default::default(),
    });
    // Replace the floor's material with the checkerboard.
    if let Some(floor) = scene.meshes.iter_mut().find(|m| m.name == "floor") {
        floor.material = checker;
    }
    let gold = scene.add_material(Material {
        name: "rough-gold".into(),
        bsdf: BsdfSpec::Conductor {
            // Au at R, G, B (650, 550, 450 nm), Johnson & Christy.
            eta: Vec3::new(0.143, 0.374, 1.442),
            k: Vec3::new(3.983, 2.385, 1.603),
            roughness: Roughness::ggx(0.15),
        },
        emission: Vec3::ZERO,
        two_sided: true,
        emission_map: None,
        spectra: Default::default(),
    });
    let glass = scene.add_material(Material::glass("glass", 1.5));
    let r = 0.35;
    let mut metal = sphere(
        &(Mat4::from_translation(Vec3::new(-0.42, -1.0 + r, -0.3))
            * Mat4::from_scale(Vec3::splat(r))),
        gold,
        48,
        96,
    );
    metal.name = "metal-sphere".into();
    scene.add_mesh(metal);
    let mut glass_sphere = sphere(
        &(Mat4::from_translation(Vec3::new(0.42, -1.0 + r, 0.25))
            * Mat4::from_scale(Vec3::splat(r))),
        glass,
        48,
        96,
    );
    glass_sphere.name = "glass-sphere".into();
    scene.add_mesh(glass_sphere);
    scene
}
