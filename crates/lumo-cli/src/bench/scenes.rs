//! Scene arguments of the benchmarks: built-in names or scene files, loaded and checked up
//! front so a bad path fails before any rendering.

use anyhow::{bail, Context, Result};
use lumo_render::{PathSettings, RenderScene, RenderSettings};
use lumo_scene::load::{FileSettings, LoadOptions};
use lumo_scene::BUILTIN_SCENES;

use super::cache::{scene_identity, slug};

/// A loaded benchmark scene.
pub struct BenchScene {
    /// Short name for tables and file names.
    pub name: String,
    /// Identity for the reference cache.
    pub id: String,
    /// Ready to trace.
    pub rs: RenderScene,
    /// Longest path depth the scene (file) asks for.
    pub max_depth: u32,
    /// Russian-roulette depth the scene file asks for, else 5.
    pub rr_depth: u32,
}

/// The scenes a `--scenes` list names, or every built-in scene when it is empty.
pub fn scene_names(given: &[String]) -> Vec<String> {
    if given.is_empty() {
        BUILTIN_SCENES.iter().map(|s| s.name.to_string()).collect()
    } else {
        given.to_vec()
    }
}

/// Whether `lumo render` treats `arg` as a file (the same rule as `scene_load::names_scene_file`).
fn is_file(arg: &str) -> bool {
    std::path::Path::new(arg).extension().is_some() || arg.contains('/')
}

/// Loads every scene and builds its BVH (inside `pool`).
pub fn load_all(args: &[String], pool: &rayon::ThreadPool) -> Result<Vec<BenchScene>> {
    let mut out = Vec::with_capacity(args.len());
    for arg in args {
        let (scene, file): (_, FileSettings) =
            crate::scene_load::load_scene_with(arg, &LoadOptions::default())
                .with_context(|| format!("scene {arg}"))?;
        let id = scene_identity(arg, is_file(arg))?;
        let max_depth = file.max_depth.unwrap_or(scene.defaults.max_depth);
        let rr_depth = file.rr_depth.unwrap_or(5);
        // Files are named with their extension, so `cornell` and `scenes/cornell.xml` can sit
        // side by side in one table.
        let name = if is_file(arg) {
            std::path::Path::new(arg)
                .file_name()
                .map_or_else(|| slug(arg), |n| n.to_string_lossy().into_owned())
        } else {
            arg.clone()
        };
        if out.iter().any(|s: &BenchScene| s.name == name) {
            bail!("scene {arg}: another scene is already named {name:?}; give each scene once");
        }
        let rs = pool
            .install(|| RenderScene::new(scene))
            .with_context(|| format!("scene {arg}: cannot build its acceleration structure"))?;
        out.push(BenchScene {
            name,
            id,
            rs,
            max_depth,
            rr_depth,
        });
    }
    Ok(out)
}

/// Render settings for a benchmark image.
pub fn settings(
    size: (usize, usize),
    spp: u32,
    seed: u32,
    max_depth: u32,
    rr_depth: u32,
) -> RenderSettings {
    RenderSettings {
        width: size.0,
        height: size.1,
        spp,
        seed,
        path: PathSettings {
            max_depth,
            rr_depth,
            ..Default::default()
        },
    }
}
