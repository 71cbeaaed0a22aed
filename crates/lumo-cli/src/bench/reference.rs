//! The converged reference of a scene: from the cache, or rendered with `--pipeline none` and
//! then cached. `lumo bench reference` exposes it so that other tools (tools/peers) score
//! against exactly the image `lumo bench quality` uses.

use crate::cli_common::{errln, outln};
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Result};
use indicatif::{ProgressBar, ProgressStyle};
use lumo_image::Image;
use lumo_pipeline::{run_pipeline, Pipeline, PipelineOptions};

use super::cache::{self, ReferenceKey};
use super::scenes::{load_all, settings, BenchScene};
use crate::arguments::parse_size;

/// Arguments of `lumo bench reference`.
#[derive(clap::Args, Debug)]
pub struct ReferenceArgs {
    /// Built-in scene name or scene file.
    pub scene: String,
    /// Image size.
    #[arg(long, value_parser = parse_size, default_value = "256x256")]
    pub size: (usize, usize),
    /// Samples per pixel of the reference.
    #[arg(long, default_value_t = 1024, value_parser = crate::cli_common::parse_spp)]
    pub reference_spp: u32,
    /// Seed of the *test* images, as given to `lumo bench quality`; the reference uses SEED + 1.
    #[arg(long, default_value_t = 0, value_parser = crate::cli_common::parse_seed)]
    pub seed: u32,
    /// Longest path depth [default: the scene's].
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Directory of cached references.
    #[arg(long, default_value = "target/lumo-bench-cache")]
    pub cache: PathBuf,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = crate::cli_common::parse_threads)]
    pub threads: Option<usize>,
}

/// Runs `lumo bench reference`: prints the cached reference's path on stdout.
pub fn run(args: ReferenceArgs) -> Result<()> {
    if args.reference_spp == 0 {
        bail!("--reference-spp must be at least 1");
    }
    crate::cli_common::check_max_depth(args.max_depth)?;
    let pool = crate::cli_common::worker_pool(args.threads)?;
    let scenes = load_all(std::slice::from_ref(&args.scene), &pool)?;
    let s = &scenes[0];
    let key = reference_key(
        s,
        args.size,
        args.reference_spp,
        args.seed.wrapping_add(1),
        args.max_depth.unwrap_or(s.max_depth),
    );
    let (_, path) = ensure_reference(&args.cache, &key, s, &pool)?;
    outln!("{}", path.display());
    Ok(())
}

/// The cache key of `s`'s reference.
pub fn reference_key(
    s: &BenchScene,
    size: (usize, usize),
    spp: u32,
    seed: u32,
    max_depth: u32,
) -> ReferenceKey {
    ReferenceKey {
        scene_id: s.id.clone(),
        slug: cache::slug(&s.name),
        width: size.0,
        height: size.1,
        spp,
        max_depth,
        rr_depth: s.rr_depth,
        seed,
    }
}

/// The reference for `key`, from `dir` or rendered (with a progress bar) and stored there.
/// Prints which on stderr, so a user (and the tests) can see the cache at work.
pub fn ensure_reference(
    dir: &Path,
    key: &ReferenceKey,
    s: &BenchScene,
    pool: &rayon::ThreadPool,
) -> Result<(Image, PathBuf)> {
    let path = cache::entry_path(dir, key);
    if let Some(img) = cache::load(dir, key) {
        errln!("reference {}: cached ({})", s.name, path.display());
        return Ok((img, path));
    }
    let rs = settings(
        (key.width, key.height),
        key.spp,
        key.seed,
        key.max_depth,
        key.rr_depth,
    );
    let bar = ProgressBar::new(1000).with_style(
        ProgressStyle::with_template(&format!(
            "reference {} {} spp {{bar:30}} {{percent:>3}}%  {{elapsed}} (eta {{eta}})",
            s.name, key.spp
        ))
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let t = Instant::now();
    let out = pool.install(|| {
        run_pipeline(
            &s.rs,
            Pipeline::None,
            &rs,
            &PipelineOptions::default(),
            &|f| bar.set_position((f * 1000.0) as u64),
        )
    })?;
    bar.finish_and_clear();
    let stored = cache::store(dir, key, &out.image)?;
    errln!(
        "reference {}: rendered in {:.1} s ({})",
        s.name,
        t.elapsed().as_secs_f64(),
        stored.display()
    );
    Ok((out.image, stored))
}
