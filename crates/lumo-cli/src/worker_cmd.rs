//! `lumo worker`: a remote render worker for a `lumo serve --remote-workers` hub
//! (docs/remote-workers.md); the work is `lumo_server::remote::run_remote_worker`.

use anyhow::{Context, Result};
use lumo_server::remote::{run_remote_worker, RemoteWorkerConfig};

/// Arguments of `lumo worker`.
#[derive(clap::Args, Debug)]
pub struct WorkerArgs {
    /// The hub's worker address, HOST:PORT (the `workers:` line `lumo serve --remote-workers`
    /// prints).
    #[arg(long, value_name = "HOST:PORT")]
    pub hub: String,
    /// The hub's token [default: the environment variable LUMO_WORKER_TOKEN, which keeps it
    /// out of the process list].
    #[arg(long, value_name = "HEX")]
    pub token: Option<String>,
    /// This worker's name in the hub's log (1 to 64 bytes) [default: host name and process
    /// id].
    #[arg(long)]
    pub name: Option<String>,
    /// Render threads [default: all cores].
    #[arg(long, value_parser = crate::cli_common::parse_threads)]
    pub threads: Option<usize>,
}

/// The machine's name, for the default worker name.
fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .or_else(|| std::env::var("HOSTNAME").ok())
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "worker".into())
}

/// Runs `lumo worker` until the hub closes the connection.
pub fn run(args: WorkerArgs) -> Result<()> {
    let token = args
        .token
        .or_else(|| std::env::var("LUMO_WORKER_TOKEN").ok())
        .context("--token: give the token lumo serve printed (or set LUMO_WORKER_TOKEN)")?;
    let name = args
        .name
        .unwrap_or_else(|| format!("{}-{}", host_name(), std::process::id()));
    let mut config = RemoteWorkerConfig::new(args.hub.clone(), token, name.clone());
    config.threads = crate::cli_common::thread_count(args.threads).unwrap_or(0);
    crate::cli_common::errln!("worker {name}: connecting to {}", args.hub);
    run_remote_worker(config)?;
    crate::cli_common::errln!("worker {name}: the hub closed the connection");
    Ok(())
}
