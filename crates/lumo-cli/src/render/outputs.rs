//! Every output location of `lumo render` checked before the render, which may take hours.

use crate::cli_common::errln;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

use super::args::RenderArgs;
use super::plan::Plan;
use crate::output::check_writable;

impl Plan {
    /// Checks every output location before the render, which may take hours, and makes the
    /// `--aovs` directory once every other check has passed.
    pub fn check_outputs(&self, args: &RenderArgs) -> Result<()> {
        let (outputs, sequence) = (&self.choices.outputs, &self.choices.sequence);
        // Every output location is checked before the render, which may take hours, and before
        // anything is created: the AOV directory is made only once every other check has passed.
        if let Some(dir) = &args.aovs {
            for o in outputs {
                // In a sequence both the image and the planes' directory carry the frame number.
                let (image, planes) = match &sequence {
                    Some(seq) => (
                        seq.frame_path(o, seq.frames.first),
                        seq.frame_aov_dir(dir, seq.frames.first),
                    ),
                    None => (o.clone(), dir.clone()),
                };
                if let Some(plane) = aov_plane_named_by(&image, &planes) {
                    bail!(
                        "-o {}: the --aovs plane {plane}.exr would overwrite the image; write the \
                         image outside {} or under another name",
                        o.display(),
                        dir.display()
                    );
                }
            }
            if dir.exists() && !dir.is_dir() {
                bail!("--aovs {}: exists and is not a directory", dir.display());
            }
            // `--aovs planes.exr` makes a directory of that name: likely meant as a file.
            let image_like = dir
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| ["exr", "pfm", "png"].contains(&e.to_ascii_lowercase().as_str()));
            if image_like && !dir.exists() {
                errln!(
                    "warning: --aovs {} names a directory (one file per plane goes into it), \
                     created with an image extension; the image itself is -o",
                    dir.display()
                );
            }
        }
        // Outputs in an AOV directory that does not exist yet are checked once it is made.
        let in_new_aovs = |o: &Path| {
            args.aovs
                .as_ref()
                .is_some_and(|d| !d.exists() && parent_is(o, d))
        };
        let check_output = |o: &Path| -> Result<()> {
            check_writable(o)?;
            if let Some(seq) = &sequence {
                // The numbered name must be writable too (a long name may not be).
                check_writable(&seq.frame_path(o, seq.frames.first))?;
            }
            Ok(())
        };
        let deferred: Vec<&PathBuf> = outputs.iter().filter(|o| in_new_aovs(o)).collect();
        for o in outputs.iter().filter(|o| !in_new_aovs(o)) {
            check_output(o)?;
        }
        if let Some(dir) = &args.aovs {
            std::fs::create_dir_all(dir).with_context(|| {
                format!("--aovs {}: cannot create the directory", dir.display())
            })?;
            // The first frame's planes: DIR itself, or DIR/<frame> in a sequence (made at write
            // time, so only something in its way can fail it).
            let planes = match &sequence {
                Some(seq) => seq.frame_aov_dir(dir, seq.frames.first),
                None => dir.clone(),
            };
            if planes.exists() && !planes.is_dir() {
                bail!(
                    "--aovs {}: {} exists and is not a directory (the first frame's planes go \
                     there)",
                    dir.display(),
                    planes.display()
                );
            }
            let probe = if planes.is_dir() { &planes } else { dir };
            check_writable(&probe.join("color.exr"))
                .with_context(|| format!("--aovs {}", dir.display()))?;
            // Every plane of every frame, not only the first: a directory where one plane goes
            // failed after the render, with half the planes overwritten.
            let frame_dirs: Vec<PathBuf> = match &sequence {
                Some(seq) => (seq.frames.first..=seq.frames.last)
                    .map(|f| seq.frame_aov_dir(dir, f))
                    .collect(),
                None => vec![dir.clone()],
            };
            for planes in &frame_dirs {
                if planes.exists() && !planes.is_dir() {
                    bail!(
                        "--aovs {}: {} exists and is not a directory (a frame's planes go there)",
                        dir.display(),
                        planes.display()
                    );
                }
                if !planes.is_dir() {
                    continue;
                }
                for name in lumo_render::AOV_NAMES
                    .iter()
                    .chain(lumo_pipeline::PLANE_NAMES)
                {
                    let plane = planes.join(format!("{name}.exr"));
                    if plane.symlink_metadata().is_ok() && !plane.is_file() {
                        bail!(
                            "--aovs {}: {} is not a regular file, and the {name} plane is written \
                             there; move it or choose another directory",
                            dir.display(),
                            plane.display()
                        );
                    }
                }
            }
        }
        for o in deferred {
            check_output(o)?;
        }
        Ok(())
    }
}

/// The name of the `--aovs` plane that output `o` would be overwritten by: `o` is
/// `<dir>/<plane>.exr` for a plane of the frame or of a pipeline.
fn aov_plane_named_by(o: &Path, dir: &Path) -> Option<&'static str> {
    let exr = o.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let stem = o.file_stem()?.to_str()?;
    if !exr || !parent_is(o, dir) {
        return None;
    }
    lumo_render::AOV_NAMES
        .iter()
        .chain(lumo_pipeline::PLANE_NAMES)
        .find(|&&n| n == stem)
        .copied()
}
/// Whether file `o` lies directly in directory `dir` (compared as canonical paths where both
/// exist, else lexically: `./av` is `av`).
fn parent_is(o: &Path, dir: &Path) -> bool {
    let lexical = |p: &Path| -> PathBuf {
        p.components()
            .filter(|c| !matches!(c, std::path::Component::CurDir))
            .collect()
    };
    let Some(parent) = o.parent() else {
        return false;
    };
    let parent = if parent.as_os_str().is_empty() {
        Path::new(".")
    } else {
        parent
    };
    match (parent.canonicalize(), dir.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => lexical(parent) == lexical(dir),
    }
}
