//! `lumo render`: path-trace a built-in scene and write the image (and optionally its AOVs).
//!
//! A run is checked ([`validate`]), planned ([`plan`]: the scene loaded, the settings worked
//! out, every output checked, the render scene built) and carried out ([`execute`]: one image
//! through a [`job::Job`], or a [`sequence`] of frames, filtered by [`temporal`] or measured by
//! [`temporal_eval`]).

use crate::cli_common::outln;

use anyhow::Result;
use lumo_scene::BUILTIN_SCENES;

pub mod args;
pub mod execute;
pub mod frames;
pub mod job;
pub mod outputs;
pub mod plan;
pub mod reshade;
pub mod sequence;
pub mod stage_clock;
pub mod temporal;
pub mod temporal_eval;
pub mod validate;

pub use args::RenderArgs;
pub use job::{Job, Rendered};
pub use plan::{Choices, Plan, Ready};

/// Runs `lumo render`.
pub fn run(args: RenderArgs) -> Result<()> {
    if args.list {
        for s in BUILTIN_SCENES {
            outln!("{:<16} {}", s.name, s.description);
        }
        return Ok(());
    }
    let valid = validate::validate(&args)?;
    let plan = Plan::from_valid(&args, valid)?;
    plan.check_outputs(&args)?;
    let ready = plan.build(&args, true)?;
    execute::execute(&args, ready)
}
