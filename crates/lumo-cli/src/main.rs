//! The `lumo` command.

mod bench_cmd;
mod denoise;
mod render_cmd;

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
    Bench(bench_cmd::BenchArgs),
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render_cmd::run(args),
        Command::Denoise(args) => denoise::run(args),
        Command::Bench(args) => bench_cmd::run(args),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(2);
    }
}
