//! `lumo bench inputs`: the noisy frame `lumo bench quality` scores as its `none` row, with
//! every AOV, written as PFM (readable with a few lines of NumPy) so other denoisers
//! (tools/peers) can run on exactly the same inputs.

use crate::cli_common::outln;
use std::path::PathBuf;

use anyhow::{bail, Result};
use lumo_pipeline::{run_pipeline, Pipeline, PipelineOptions};

use super::atomic::{check_dir_writable, write_image_atomic};
use super::scenes::{load_all, settings};
use crate::arguments::parse_size;

/// Arguments of `lumo bench inputs`.
#[derive(clap::Args, Debug)]
pub struct InputsArgs {
    /// Built-in scene name or scene file.
    pub scene: String,
    /// Image size.
    #[arg(long, value_parser = parse_size, default_value = "256x256")]
    pub size: (usize, usize),
    /// Samples per pixel.
    #[arg(long, default_value_t = 1, value_parser = crate::cli_common::parse_spp)]
    pub spp: u32,
    /// Seed, as given to `lumo bench quality`.
    #[arg(long, default_value_t = 0, value_parser = crate::cli_common::parse_seed)]
    pub seed: u32,
    /// Longest path depth [default: the scene's].
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Directory for color.pfm, albedo.pfm, normal.pfm, … (created if needed).
    #[arg(long)]
    pub out: PathBuf,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = crate::cli_common::parse_threads)]
    pub threads: Option<usize>,
}

/// Runs `lumo bench inputs`; prints the trace time as `trace <ms> ms`.
pub fn run(args: InputsArgs) -> Result<()> {
    if args.spp == 0 {
        bail!("--spp must be at least 1");
    }
    crate::cli_common::check_max_depth(args.max_depth)?;
    check_dir_writable(&args.out)?;
    let pool = crate::cli_common::worker_pool(args.threads)?;
    let scenes = load_all(std::slice::from_ref(&args.scene), &pool)?;
    let s = &scenes[0];
    let rs = settings(
        args.size,
        args.spp,
        args.seed,
        args.max_depth.unwrap_or(s.max_depth),
        s.rr_depth,
    );
    let out = pool.install(|| {
        run_pipeline(
            &s.rs,
            Pipeline::None,
            &rs,
            &PipelineOptions::default(),
            &|_| {},
        )
    })?;
    for (name, plane) in out.frame.planes() {
        write_image_atomic(&args.out.join(format!("{name}.pfm")), plane)?;
    }
    outln!("trace {:.3} ms", out.timings.total().as_secs_f64() * 1e3);
    Ok(())
}
