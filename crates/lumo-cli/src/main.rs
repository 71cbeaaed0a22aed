//! The `lumo` command.

mod denoise;

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
    /// Denoise an image from any renderer with a screen-space filter.
    Denoise(denoise::DenoiseArgs),
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Denoise(args) => denoise::run(args),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(2);
    }
}
