//! The `lumo` command.
#![forbid(unsafe_code)]

mod bench;
mod cli_common;
mod compare_cmd;
mod denoise;
mod pipeline_args;
mod render_cmd;
mod reshade;
mod sequence;
mod serve_cmd;
mod temporal;
mod temporal_eval;

use crate::cli_common::errln;
use clap::{Parser, Subcommand};

/// lumo: physically based global illumination with fast screen-space denoising.
#[derive(Parser)]
#[command(name = "lumo", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Path-trace a scene and write the image (EXR, PFM or PNG) and optionally its AOVs.
    Render(render_cmd::RenderArgs),
    /// Denoise an image from any renderer with a screen-space filter.
    Denoise(denoise::DenoiseArgs),
    /// Benchmarks with stated inputs and machine.
    Bench(bench::BenchArgs),
    /// Error metrics (MSE, relMSE, SMAPE, PSNR, SSIM, FLIP) of images against a reference.
    Compare(compare_cmd::CompareArgs),
    /// Start a progressive render server and its web viewer (prints the URL to open).
    Serve(serve_cmd::ServeArgs),
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render_cmd::run(args),
        Command::Denoise(args) => denoise::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Compare(args) => compare_cmd::run(args),
        Command::Serve(args) => serve_cmd::run(args),
    };
    if let Err(e) = result {
        errln!("error: {e:#}");
        std::process::exit(2);
    }
}
