//! `lumo export SCENE -o DIR/scene.xml`: a scene (a built-in one, or any file lumo reads) as a
//! Mitsuba 3 XML file with its meshes as PLY, so another renderer can render it as it is
//! (`tools/peers/render_peers.py` compares lumo with Mitsuba 3 on the atrium this way).

use crate::cli_common::outln;
use std::path::PathBuf;

use anyhow::{Context, Result};
use lumo_scene::export::write_mitsuba;
use lumo_scene::load::LoadOptions;

use crate::arguments::parse_define;
use crate::scene_load::load_scene_with;

/// Arguments of `lumo export`.
#[derive(clap::Args, Debug)]
pub struct ExportArgs {
    /// Built-in scene name (see `lumo render --list`) or scene file.
    pub scene: String,
    /// The Mitsuba 3 XML file to write; its meshes go to `meshes/` beside it.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Set a Mitsuba `$name` parameter of a scene file (overrides its `<default>`); repeatable.
    #[arg(short = 'D', long = "define", value_name = "NAME=VALUE", value_parser = parse_define)]
    pub defines: Vec<(String, String)>,
}

/// Runs `lumo export`.
pub fn run(args: ExportArgs) -> Result<()> {
    let options = LoadOptions {
        defines: args.defines.clone(),
        ..Default::default()
    };
    let (scene, _) = load_scene_with(&args.scene, &options)?;
    let files = write_mitsuba(&scene, &args.output)
        .with_context(|| format!("exporting {} to {}", args.scene, args.output.display()))?;
    outln!(
        "{}: {} triangles, {} materials → {} ({} mesh files)",
        scene.name,
        scene.triangle_count(),
        scene.materials.len(),
        args.output.display(),
        files.len() - 1
    );
    Ok(())
}
