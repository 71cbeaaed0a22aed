//! `lumo denoise` (to be written).

/// Arguments of `lumo denoise`.
#[derive(clap::Args)]
pub struct DenoiseArgs {}

/// Runs `lumo denoise`.
pub fn run(_args: DenoiseArgs) -> anyhow::Result<()> {
    anyhow::bail!("lumo denoise is not available yet")
}
