//! `lumo serve`: a progressive render server after Radziszewski et al., "Progressive client for
//! a ray-tracing server" (WSCG 2010; papers/README §4).
//!
//! A [`worker::RenderWorker`] runs the path tracer and/or the light tracer on a thread pool and
//! collects samples `([u,v], [X,Y,Z,W])`; a [`hub::Hub`] queries it at display rate and sends
//! the samples over WebSocket (the binary protocol of [`protocol`], docs/protocol.md) to any
//! number of browser viewers, each behind a bounded [`outbox::Outbox`]. The viewer (web/,
//! embedded by [`assets`]) reconstructs, blurs and tone-maps the image on the GPU.

pub mod assets;
pub mod frames;
pub mod http;
pub mod hub;
pub mod outbox;
pub mod protocol;
pub mod streams;
pub mod worker;

use lumo_render::PathSettings;

pub use http::{router, serve};
pub use hub::Hub;
pub use protocol::{Integrator, Mode};

/// Server settings, from the command line.
#[derive(Clone, Debug)]
pub struct ServerConfig {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// Render threads (0: all cores).
    pub threads: usize,
    /// Integrator at start.
    pub integrator: Integrator,
    /// Path settings for both tracers.
    pub path: PathSettings,
    /// Seed.
    pub seed: u32,
    /// Throttle, samples (camera samples plus light paths) per second.
    pub max_rate: Option<f64>,
    /// Bytes of sample data a viewer may have queued before the oldest is dropped.
    pub viewer_queue_bytes: usize,
}

impl ServerConfig {
    /// Defaults for a `width`×`height` image.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            threads: 0,
            integrator: Integrator::Path,
            path: PathSettings::default(),
            seed: 0,
            max_rate: None,
            viewer_queue_bytes: 8 << 20,
        }
    }
}
