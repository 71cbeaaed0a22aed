//! Scene arguments: a built-in scene's name or a scene file, loaded with the loader's warnings
//! printed.

use crate::cli_common::errln;
use std::path::Path;

use anyhow::{bail, Result};
use lumo_scene::load::{FileSettings, LoadOptions};
use lumo_scene::{builtin_scene, AnimatedScene, Scene, BUILTIN_SCENES};

/// Loads a built-in scene by name, or a scene file with default options.
pub fn load_scene(name: &str) -> Result<Scene> {
    Ok(load_scene_with(name, &LoadOptions::default())?.0)
}

/// Loads a built-in scene by name or a scene file (.xml, .gltf, .glb, .obj, .ply), printing
/// the loader's warnings to stderr; returns the scene and the render settings the file asks for.
pub fn load_scene_with(name: &str, options: &LoadOptions) -> Result<(Scene, FileSettings)> {
    let (scene, settings, _) = load_scene_animated(name, options)?;
    Ok((scene, settings))
}

/// [`load_scene_with`], also returning the scene's node animation (glTF files; `None` for
/// the built-ins and other formats).
pub fn load_scene_animated(
    name: &str,
    options: &LoadOptions,
) -> Result<(Scene, FileSettings, Option<AnimatedScene>)> {
    let path = Path::new(name);
    if names_scene_file(name) {
        if let Err(e) = std::fs::metadata(path) {
            // A link that leads nowhere (a loop, a missing target) was reported as a file
            // that "does not exist", though `ls` shows it.
            if path.symlink_metadata().is_ok() {
                let why = if e.raw_os_error() == Some(40) {
                    "it is part of a loop of symbolic links".to_string()
                } else {
                    lumo_image::describe_io_error(&e)
                };
                bail!(
                    "scene file {name:?} is a symbolic link that cannot be followed: {why}; \
                     point it at a scene file"
                );
            }
            bail!(
                "scene file {name:?} does not exist; built-in scenes: {}",
                builtin_names()
            );
        }
        let loaded = lumo_scene::load::load_scene(path, options)?;
        for w in &loaded.warnings {
            errln!("{w}");
        }
        return Ok((loaded.scene, loaded.settings, loaded.animation));
    }
    let scene = builtin_scene(name)?;
    // The file loader warns about these for non-glTF files; built-ins have one camera and
    // no animation, so say so rather than ignore the options silently.
    if options.camera.is_some() {
        errln!(
            "warning: --camera applies to glTF scenes; the built-in {name} has one camera, ignored"
        );
    }
    if options.time.is_some() {
        errln!("warning: --time applies to animated glTF scenes; the built-in {name} is static, ignored");
    }
    Ok((scene, FileSettings::default(), None))
}

/// Whether a scene argument names a file (it has an extension or a `/`) rather than a
/// built-in scene.
pub fn names_scene_file(name: &str) -> bool {
    Path::new(name).extension().is_some() || name.contains('/')
}

fn builtin_names() -> String {
    BUILTIN_SCENES
        .iter()
        .map(|s| s.name)
        .collect::<Vec<_>>()
        .join(", ")
}
