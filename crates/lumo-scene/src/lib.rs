//! The scene model of lumo: triangle meshes placed by instances, materials, lights and a
//! pinhole camera. Loaders (built-in scenes, and scene files in [`load`]) fill it; the renderer
//! reads it. Plain data: no acceleration structures, no threads.
#![forbid(unsafe_code)]

pub mod animation;
mod bsdf_spec;
mod builtin;
mod camera;
pub mod deform;
mod error;
pub mod export;
mod gltf_extensions;
mod light;
pub mod load;
mod material;
pub mod media;
mod mesh;
mod mipmap;
mod principled;
mod scene;
pub mod shapes;
mod texture;

pub use animation::{AnimatedScene, Animation};
pub use bsdf_spec::{BaseColor, BsdfFlags, BsdfSpec, SMOOTH_ALPHA};
pub use builtin::{builtin_scene, BuiltinScene, BUILTIN_SCENES};
pub use camera::{Camera, FovAxis, Lens, PixelFilter};
pub use error::SceneError;
pub use gltf_extensions::GltfExtensions;
pub use light::{range_window, EnvMap, Light, SpotFalloff, MAX_EMISSION};
pub use material::{Distribution, Material, Roughness, RoughnessMaps, Spectra};
pub use media::{Boundary, Medium, MediumInterface, MediumSpectra, PhaseFunction, SceneMedia};
pub use mesh::{Analytic, AnalyticKind, Instance, Mesh};
pub use mipmap::{MipFilter, MipMap};
pub use principled::PrincipledSpec;
pub use scene::{
    box_reach, positions_box, reach_error, singular_instance, transformed_box, RenderDefaults,
    Scene, COORDINATE_LIMIT, DEPTH_LIMIT,
};
pub use texture::{Texture, TextureFilter, WrapMode};

pub use glam::{Mat4, Vec2, Vec3, Vec4};
