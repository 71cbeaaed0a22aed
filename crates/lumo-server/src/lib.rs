//! `lumo serve`: a progressive render server after Radziszewski et al., "Progressive client for
//! a ray-tracing server" (WSCG 2010; papers/README §4).
//!
//! A [`worker::RenderWorker`] runs the path tracer and/or the light tracer on a thread pool and
//! collects samples `([u,v], [X,Y,Z,W])`; a [`hub::Hub`] queries it at display rate and sends
//! the samples over WebSocket (the binary protocol of [`protocol`], docs/protocol.md) to any
//! number of browser viewers, each behind a bounded [`outbox::Outbox`]. The viewer (web/,
//! embedded by [`assets`]) reconstructs, blurs and tone-maps the image on the GPU.
//!
//! Every resource a client can make the server spend is bounded by [`Limits`]: connections,
//! request time and size ([`conn`]), queued messages per viewer ([`outbox`]), message rate
//! and render restarts ([`http`], [`hub`]); with no viewer connected the renderer pauses.
#![forbid(unsafe_code)]

pub mod assets;
pub mod batches;
mod bucket;
pub mod conn;
pub mod frames;
pub mod http;
pub mod hub;
pub mod outbox;
mod oversize;
pub mod protocol;
pub mod remote;
pub mod scene_edit;
pub mod streams;
pub mod worker;

use std::time::Duration;

use lumo_render::{PathSettings, PpmSettings};

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
    /// Photon-mapping settings (integrator ppm).
    pub ppm: PpmSettings,
    /// Bytes of sample data a viewer may have queued before the oldest is dropped.
    pub viewer_queue_bytes: usize,
    /// What one client may cost the server.
    pub limits: Limits,
    /// The scene's node animation (`lumo serve --animate`): the server poses the scene by
    /// wall-clock time and restarts rendering at every pump tick while it plays; `None`
    /// renders the scene as loaded.
    pub animation: Option<lumo_scene::AnimatedScene>,
    /// Remote render workers (`lumo serve --remote-workers`): `None` accepts none; with a
    /// config, [`remote::serve_workers`] accepts them on a listener of its own.
    pub remote: Option<remote::RemoteConfig>,
}

/// Bounds on what a client may make the server spend (docs/protocol.md, "Limits and safety").
/// The defaults are far above what the viewer needs and far below what hurts the server.
#[derive(Clone, Debug)]
pub struct Limits {
    /// Open TCP connections at most. When full, the oldest connection that is not a viewer
    /// (an idle or slow HTTP client) is closed to make room; when all are viewers, the new
    /// connection is closed at once.
    pub max_connections: usize,
    /// Viewers (WebSocket connections) at most; more are refused with 503.
    pub max_viewers: usize,
    /// Time an HTTP connection has to send a complete request, counted from accept and again
    /// from each write of the server: bounds slow header senders and idle keep-alive alike.
    pub request_timeout: Duration,
    /// Bytes a connection may send before the server answers (request line and headers);
    /// a larger request gets 414, 431 or 413 by how far it got, and its connection is closed.
    pub max_request_bytes: usize,
    /// A viewer whose socket accepts nothing for this long is closed.
    pub write_stall_timeout: Duration,
    /// Bytes of messages that must arrive (hello, cameras this viewer asked for, errors) a
    /// viewer may have queued; beyond it the viewer is closed, as it asks without reading.
    pub control_queue_bytes: usize,
    /// Messages per second a viewer may send on average; a faster sender is read more slowly
    /// (its own socket fills up), the server does no extra work for it.
    pub messages_per_second: f64,
    /// Messages a viewer may send in a burst above that rate.
    pub message_burst: f64,
    /// Invalid messages a viewer may send in a burst; one more closes it (close code 1008).
    pub violation_burst: f64,
    /// Rate at which that allowance refills, per second.
    pub violations_per_second: f64,
    /// Shortest time between two render restarts; camera and parameter changes arriving
    /// faster are merged into the next restart.
    pub min_restart_interval: Duration,
    /// How long a close frame may take to go out before the connection is dropped.
    pub close_grace: Duration,
    /// Stop rendering while no viewer is connected; the next viewer restarts it.
    pub pause_when_idle: bool,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            max_connections: 256,
            max_viewers: 64,
            request_timeout: Duration::from_secs(10),
            max_request_bytes: 64 << 10,
            write_stall_timeout: Duration::from_secs(20),
            control_queue_bytes: outbox::DEFAULT_CONTROL_BYTES,
            // The viewer sends at most one camera per 30 ms.
            messages_per_second: 100.0,
            message_burst: 50.0,
            violation_burst: 32.0,
            violations_per_second: 1.0,
            // About one pump interval: a restart per displayed frame at most.
            min_restart_interval: Duration::from_millis(15),
            close_grace: Duration::from_secs(1),
            pause_when_idle: true,
        }
    }
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
            ppm: PpmSettings::default(),
            viewer_queue_bytes: 8 << 20,
            limits: Limits::default(),
            animation: None,
            remote: None,
        }
    }
}
