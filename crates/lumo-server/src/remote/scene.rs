//! A worker loads the hub's scene itself, from the name or path the hub sends (a shared path:
//! every worker's machine must see the file, and its textures and meshes beside it, where the
//! hub does), with the same loaders and defines as `lumo serve`.

use std::path::Path;

use lumo_scene::{AnimatedScene, Scene};

use crate::protocol::remote::{SceneKind, SceneSource};

/// Loads `src` as `lumo serve` did; with `animate`, also the scene's animation, posed at 0
/// (as the hub's first frame). Errors are sentences naming the scene, for the hub's log.
pub fn load_scene_source(
    src: &SceneSource,
    animate: bool,
) -> Result<(Scene, Option<AnimatedScene>), String> {
    let (mut scene, rig) = match src.kind {
        SceneKind::Builtin => (
            lumo_scene::builtin_scene(&src.spec).map_err(|e| e.to_string())?,
            None,
        ),
        SceneKind::File => {
            let path = Path::new(&src.spec);
            if !path.is_absolute() {
                return Err(format!("scene path {:?} is not absolute", src.spec));
            }
            // Said plainly: the usual failure is a path the worker's machine does not share.
            std::fs::metadata(path).map_err(|e| {
                format!(
                    "cannot read scene file {} on this machine: {e} (workers need the hub's \
                     scene at the same path: a shared directory)",
                    path.display()
                )
            })?;
            let options = lumo_scene::load::LoadOptions {
                defines: src.defines.clone(),
                ..Default::default()
            };
            let loaded = lumo_scene::load::load_scene(path, &options)
                .map_err(|e| format!("scene file {}: {e}", path.display()))?;
            (loaded.scene, loaded.animation)
        }
    };
    let rig = match (animate, rig) {
        (false, _) => None,
        (true, Some(rig)) if rig.is_animated() => {
            rig.pose(&mut scene, Some(0.0));
            Some(rig)
        }
        (true, _) => return Err(format!("scene {:?} has no animation", src.spec)),
    };
    Ok((scene, rig))
}
