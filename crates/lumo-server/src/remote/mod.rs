//! Remote render workers (docs/remote-workers.md): `lumo serve --remote-workers` accepts
//! worker connections on a TCP port of its own ([`serve_workers`]); each worker
//! ([`run_remote_worker`], `lumo worker`) presents the hub's token, its lumo version and a
//! name, loads the scene from the path the hub names, renders sample batches of the hub's
//! current epoch with the crate's own [`crate::worker::RenderWorker`] and streams them back;
//! the hub checks each batch and merges it into the one sample stream its viewers receive
//! ([`crate::Hub::merge_remote`]).

mod client;
mod conn;
mod framing_async;
mod registry;
mod scene;
mod token;

use std::time::Duration;

pub use client::{run_remote_worker, RemoteWorkerConfig, RemoteWorkerError};
pub use conn::serve_workers;
pub use registry::RemoteWorkerStats;
pub(crate) use registry::{merge_edits, RemoteSet};
pub use scene::load_scene_source;
pub use token::{check_token, new_token, TokenError};

use crate::protocol::remote::SceneSource;

/// Largest message a worker may send: one batch of [`crate::hub::SAMPLES_PER_MESSAGE`]
/// samples (the status and hello are far smaller).
pub const MAX_WORKER_MESSAGE: usize = crate::protocol::BATCH_HEADER_BYTES
    + crate::hub::SAMPLES_PER_MESSAGE * crate::protocol::SAMPLE_BYTES;
/// Largest message a hub sends a worker (WELCOME with the longest scene text).
pub const MAX_HUB_MESSAGE: usize = 32 << 10;

/// A hub's settings for remote workers (`lumo serve --remote-workers`).
#[derive(Clone, Debug)]
pub struct RemoteConfig {
    /// The token workers must present ([`new_token`] draws one).
    pub token: String,
    /// The scene as workers load it: a built-in name, or the file's absolute path (every
    /// worker's machine must be able to read it: a shared path) and its defines.
    pub scene: SceneSource,
    /// Workers connected at most; more are refused.
    pub max_workers: usize,
    /// Connections still in their handshake at most; more are closed at once.
    pub max_handshakes: usize,
    /// Samples (camera samples plus light paths) per second the hub reads from one worker
    /// at most; a faster worker waits at its own socket.
    pub samples_per_second: f64,
    /// Time a new connection has to send its WORKER_HELLO.
    pub hello_timeout: Duration,
    /// Time a welcomed worker has to load the scene and say it is ready.
    pub load_timeout: Duration,
    /// A worker whose socket accepts nothing for this long is dropped.
    pub write_stall_timeout: Duration,
}

impl RemoteConfig {
    /// Defaults with `token` and `scene`.
    pub fn new(token: String, scene: SceneSource) -> Self {
        Self {
            token,
            scene,
            max_workers: 32,
            max_handshakes: 16,
            // 8 M samples/s = 96 MB/s of batches: above what a 64-core node renders of a
            // simple scene, a bound on what one worker can make the hub forward.
            samples_per_second: 8e6,
            hello_timeout: Duration::from_secs(5),
            load_timeout: Duration::from_secs(600),
            write_stall_timeout: Duration::from_secs(20),
        }
    }
}

/// The seed of worker `id`'s samples: the hub's seed and the worker's number mixed, so no two
/// workers (and not the hub's own render worker, which uses `seed`) draw the same samples.
pub(crate) fn worker_seed(seed: u32, id: u64) -> u32 {
    let mixed = lumo_render::sampler::mix64(((seed as u64) << 32) ^ id);
    let s = (mixed ^ (mixed >> 32)) as u32;
    if s == seed {
        s.wrapping_add(1)
    } else {
        s
    }
}
