//! The remote render workers' protocol (docs/protocol.md, "Remote render workers"): a hub
//! (`lumo serve --remote-workers`) and the workers that render for it (`lumo worker`) talk over
//! one TCP connection per worker, every message framed by a 4-byte little-endian length
//! ([`framing`]).
//!
//! The messages use the viewer protocol's header and field tables ([`super::layout`]): the
//! handshake ([`WorkerHello`], [`Welcome`], [`WorkerStatus`]) and the epoch state
//! ([`EpochUpdate`]) are defined here; edits travel as the viewer's EDIT, samples as its
//! SAMPLES (so the hub forwards a worker's checked batch to viewers byte for byte), refusals
//! as its ERROR.

mod epoch;
pub mod framing;
mod join;
mod status;
#[cfg(test)]
mod tests;
mod welcome;

pub use epoch::EpochUpdate;
pub use join::{WorkerHello, MAX_TOKEN, MAX_WORKER_NAME};
pub use status::{WorkerState, WorkerStatus};
pub use welcome::{SceneKind, SceneSource, Welcome, MAX_SCENE_TEXT};

use super::layout::Layout;

/// The worker protocol's number: a worker and a hub must agree on it (and on the lumo
/// version, [`LUMO_VERSION`]).
pub const WORKER_PROTOCOL: u16 = 1;
/// This build's lumo version, which a worker presents and the hub must share.
pub const LUMO_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Type bytes of the worker-only messages (beside the viewer protocol's, which they do not
/// reuse).
pub mod kind {
    /// Worker → hub, first message: token, version, name.
    pub const WORKER_HELLO: u8 = 0x20;
    /// Hub → worker, the answer to a hello: the scene and the render settings.
    pub const WELCOME: u8 = 0x21;
    /// Hub → worker: the current epoch's camera, integrator, mode and pose.
    pub const EPOCH: u8 = 0x22;
    /// Worker → hub: ready (scene loaded) or why it cannot render.
    pub const STATUS: u8 = 0x23;
}

/// The worker-only messages' field tables, in type order (docs/protocol.md's tables).
pub const WORKER_MESSAGES: &[&Layout] = &[
    &WorkerHello::LAYOUT,
    &Welcome::LAYOUT,
    &EpochUpdate::LAYOUT,
    &WorkerStatus::LAYOUT,
];

/// A fixed-size text field's bytes without the zero padding, as UTF-8.
fn padded_text(bytes: &[u8], what: &str) -> Result<String, super::ProtocolError> {
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    std::str::from_utf8(&bytes[..end])
        .map(str::to_string)
        .map_err(|_| {
            super::ProtocolError::new(super::ErrorCode::Malformed, format!("{what} is not UTF-8"))
        })
}
