//! The `lumo` command.
#![forbid(unsafe_code)]

use lumo_cli::{bench, compare_cmd, denoise, export_cmd, render, serve_cmd, worker_cmd};

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
    Render(render::RenderArgs),
    /// Denoise an image from any renderer with a screen-space filter.
    Denoise(denoise::DenoiseArgs),
    /// Benchmarks with stated inputs and machine.
    Bench(bench::BenchArgs),
    /// Error metrics (MSE, relMSE, SMAPE, PSNR, SSIM, FLIP) of images against a reference.
    Compare(compare_cmd::CompareArgs),
    /// Write a scene (built-in or any file lumo reads) as Mitsuba 3 XML + PLY meshes.
    Export(export_cmd::ExportArgs),
    /// Start a progressive render server and its web viewer (prints the URL to open).
    Serve(serve_cmd::ServeArgs),
    /// Render for a `lumo serve --remote-workers` hub: load its scene, stream samples of its
    /// current view until it closes the connection.
    Worker(worker_cmd::WorkerArgs),
}

fn main() {
    let cli = Cli::parse();
    lumo_cli::cli_common::remove_temps_on_signal();
    let result = match cli.command {
        Command::Render(args) => render::run(args),
        Command::Denoise(args) => denoise::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Compare(args) => compare_cmd::run(args),
        Command::Export(args) => export_cmd::run(args),
        Command::Serve(args) => serve_cmd::run(args),
        Command::Worker(args) => worker_cmd::run(args),
    };
    if let Err(e) = result {
        // Survives a closed stderr, like every message of the subcommands (cli_common).
        lumo_cli::cli_common::write_stderr(format_args!("error: {e:#}\n"));
        std::process::exit(2);
    }
}
