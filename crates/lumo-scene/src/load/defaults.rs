//! What a lone mesh file (OBJ, PLY) gets so that it renders a useful picture: a camera framing
//! its bounds and a sky.

use std::path::Path;

use glam::Vec3;

use crate::{Camera, FovAxis, Light, Material, Mesh, RenderDefaults, Scene};

/// Field of view of the default camera (degrees, shorter image side).
const FOV: f32 = 40.0;

/// A camera looking at the box `lo..hi` from the front (+z), a little from above and the right,
/// far enough that the bounding sphere fits the field of view.
pub(crate) fn framing_camera(lo: Vec3, hi: Vec3) -> Camera {
    let center = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-3);
    let dir = Vec3::new(0.45, 0.35, 1.0).normalize();
    let distance = radius / (FOV.to_radians() * 0.5).sin() * 1.05;
    Camera {
        origin: center + dir * distance,
        target: center,
        up: Vec3::Y,
        fov: FOV,
        fov_axis: FovAxis::Smaller,
        lens: Default::default(),
        filter: Default::default(),
    }
}

/// The lights a scene without any gets: a uniform sky and a sun from the upper left front.
pub(crate) fn sky_lights() -> Vec<Light> {
    vec![
        Light::Constant {
            radiance: Vec3::splat(0.6),
        },
        Light::Directional {
            direction: Vec3::new(0.4, -1.0, -0.6).normalize(),
            irradiance: Vec3::splat(2.0),
        },
    ]
}

/// An empty scene named after `path` with the default render settings.
pub(crate) fn empty_scene(path: &Path) -> Scene {
    Scene {
        name: scene_name(path),
        meshes: vec![],
        instances: vec![],
        materials: vec![],
        lights: vec![],
        camera: framing_camera(Vec3::splat(-1.0), Vec3::splat(1.0)),
        defaults: RenderDefaults {
            width: 512,
            height: 512,
            spp: 16,
            max_depth: 8,
        },
        media: Default::default(),
    }
}

/// The file stem, used for default output names.
pub(crate) fn scene_name(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into())
}

/// A scene from meshes and their materials read from one mesh file, with a framing camera and
/// a sky (when the file brought no emitters of its own, the sky is the only light).
pub(crate) fn lone_mesh_scene(
    path: &Path,
    (meshes, materials): (Vec<Mesh>, Vec<Material>),
) -> Scene {
    let mut scene = empty_scene(path);
    scene.materials = materials;
    if scene.materials.is_empty() {
        scene
            .materials
            .push(Material::diffuse("default", Vec3::splat(0.7)));
    }
    for mesh in meshes {
        scene.add_mesh(mesh);
    }
    let (lo, hi) = scene.bounds();
    scene.camera = framing_camera(lo, hi);
    scene.lights = sky_lights();
    scene
}
