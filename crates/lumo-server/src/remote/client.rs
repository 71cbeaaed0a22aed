//! The worker's side: [`run_remote_worker`] connects to a hub, introduces itself, loads the
//! scene the hub names, and renders the hub's epochs with a [`RenderWorker`] until the hub
//! closes the connection or the caller raises the stop flag. It blocks its thread; a reader
//! thread turns the hub's messages into commands, and this thread queries the render worker
//! at display rate and sends the samples, tagged with the hub's epoch.

use std::io;
use std::net::{Shutdown, SocketAddr, TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::Arc;
use std::time::Duration;

use lumo_render::RenderScene;
use lumo_scene::{Camera, FovAxis};

use super::{merge_edits, MAX_HUB_MESSAGE};
use crate::batches::sample_messages;
use crate::hub::{shorter_side_fov, PUMP_INTERVAL};
use crate::protocol::remote::framing::{read_frame, write_frame, FrameError};
use crate::protocol::remote::{
    kind, EpochUpdate, Welcome, WorkerHello, WorkerState, WorkerStatus, LUMO_VERSION,
    WORKER_PROTOCOL,
};
use crate::protocol::{self, Edit, ErrorReply, Mode, ProtocolError};
use crate::scene_edit::EditTargets;
use crate::worker::{Job, QueryBuffer, RenderWorker};

/// How long the handshake may wait for the hub.
const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(30);
/// A hub whose socket accepts nothing for this long is given up.
const WRITE_TIMEOUT: Duration = Duration::from_secs(20);
/// Hub messages the reader thread may have queued before it waits for this thread.
const INBOX: usize = 256;

/// What [`run_remote_worker`] needs.
#[derive(Clone, Debug)]
pub struct RemoteWorkerConfig {
    /// The hub's worker address, `HOST:PORT` (as `lumo serve --remote-workers` prints it; a
    /// `tcp://` prefix is accepted).
    pub hub: String,
    /// The token the hub printed.
    pub token: String,
    /// The worker's name in the hub's log (1 to 64 bytes).
    pub name: String,
    /// Render threads (0: all cores).
    pub threads: usize,
    /// Raised by the caller to stop: the worker closes the connection and returns `Ok(())`
    /// within about one pump interval (16 ms) plus one batch.
    pub stop: Arc<AtomicBool>,
    /// How long to try connecting.
    pub connect_timeout: Duration,
}

impl RemoteWorkerConfig {
    /// A worker of `name` for the hub at `hub` with `token`: all cores, its own stop flag,
    /// 10 s to connect.
    pub fn new(hub: impl Into<String>, token: impl Into<String>, name: impl Into<String>) -> Self {
        Self {
            hub: hub.into(),
            token: token.into(),
            name: name.into(),
            threads: 0,
            stop: Arc::default(),
            connect_timeout: Duration::from_secs(10),
        }
    }
}

/// Why a remote worker stopped.
#[derive(Debug, thiserror::Error)]
pub enum RemoteWorkerError {
    /// The settings cannot work (no address, empty name).
    #[error("{0}")]
    Config(String),
    /// The hub could not be reached.
    #[error("cannot connect to the hub at {hub}: {reason}")]
    Connect {
        /// The address tried.
        hub: String,
        /// Why (not a `source`: the message already says it, and would say it twice in a
        /// chain).
        reason: io::Error,
    },
    /// The hub refused the worker (token, version, too many workers) or dropped it.
    #[error("the hub refused worker {name:?}: {reason}")]
    Refused {
        /// The worker's name.
        name: String,
        /// The hub's reason.
        reason: String,
    },
    /// The scene could not be loaded here (the hub was told and logs it).
    #[error("worker {name:?} cannot load the hub's scene: {reason}")]
    Scene {
        /// The worker's name.
        name: String,
        /// Why.
        reason: String,
    },
    /// The render threads could not start.
    #[error("cannot start the render threads: {0}")]
    Threads(String),
    /// The hub sent something this worker cannot read.
    #[error("the hub sent an invalid message: {0}")]
    Protocol(ProtocolError),
    /// The connection failed.
    #[error("connection to the hub failed: {0}")]
    Io(io::Error),
}

// By hand rather than `#[from]`, which would also make them the error's source: the messages
// above already include them, and a chain would print them twice.
impl From<ProtocolError> for RemoteWorkerError {
    fn from(e: ProtocolError) -> Self {
        Self::Protocol(e)
    }
}

impl From<io::Error> for RemoteWorkerError {
    fn from(e: io::Error) -> Self {
        Self::Io(e)
    }
}

impl From<FrameError> for RemoteWorkerError {
    fn from(e: FrameError) -> Self {
        match e {
            FrameError::Io(e) => Self::Io(e),
            e => Self::Protocol(ProtocolError::new(
                protocol::ErrorCode::TooLarge,
                e.to_string(),
            )),
        }
    }
}

/// What the reader thread hands over.
enum Inbound {
    Message(Vec<u8>),
    /// The hub closed the connection.
    Closed,
    Failed(FrameError),
}

fn resolve(hub: &str) -> Result<SocketAddr, RemoteWorkerError> {
    let addr = hub.strip_prefix("tcp://").unwrap_or(hub);
    let bad = |reason: String| RemoteWorkerError::Config(format!("--hub {hub:?}: {reason}"));
    addr.to_socket_addrs()
        .map_err(|e| bad(format!("expected HOST:PORT ({e})")))?
        .next()
        .ok_or_else(|| bad("the name has no address".into()))
}

/// The reason in a hub's ERROR message (or a description of what else it sent).
fn refusal(msg: &[u8]) -> String {
    match ErrorReply::read(msg) {
        Ok(e) => e.message,
        Err(e) => format!("unreadable refusal ({e})"),
    }
}

/// Connects to the hub, renders its epochs and streams the samples until the hub closes the
/// connection (`Ok`) or `config.stop` is raised (`Ok`); blocks the calling thread. A scene
/// this machine cannot load is reported to the hub, then returned as
/// [`RemoteWorkerError::Scene`].
pub fn run_remote_worker(config: RemoteWorkerConfig) -> Result<(), RemoteWorkerError> {
    let name = config.name.clone();
    if name.is_empty() || name.len() > crate::protocol::remote::MAX_WORKER_NAME {
        return Err(RemoteWorkerError::Config(format!(
            "worker name {name:?}: 1 to {} bytes",
            crate::protocol::remote::MAX_WORKER_NAME
        )));
    }
    let addr = resolve(&config.hub)?;
    let connect = |reason| RemoteWorkerError::Connect {
        hub: config.hub.clone(),
        reason,
    };
    let mut stream = TcpStream::connect_timeout(&addr, config.connect_timeout).map_err(connect)?;
    stream.set_nodelay(true)?;
    stream.set_write_timeout(Some(WRITE_TIMEOUT))?;
    stream.set_read_timeout(Some(HANDSHAKE_TIMEOUT))?;
    let hello = WorkerHello {
        protocol: WORKER_PROTOCOL,
        token: config.token.clone(),
        version: LUMO_VERSION.into(),
        name: name.clone(),
    };
    write_frame(&mut stream, &hello.write())?;
    let refused = |reason: String| RemoteWorkerError::Refused {
        name: name.clone(),
        reason,
    };
    let reply = read_frame(&mut stream, MAX_HUB_MESSAGE)?
        .ok_or_else(|| refused("it closed the connection".into()))?;
    let welcome = match reply.first().copied() {
        Some(kind::WELCOME) => Welcome::read(&reply)?,
        Some(protocol::kind::ERROR) => return Err(refused(refusal(&reply))),
        _ => {
            return Err(refused(
                "it answered with something other than WELCOME".into(),
            ))
        }
    };
    let status = |state, threads, message: String| WorkerStatus {
        state,
        threads,
        message,
    };
    let (scene, rig) = match super::load_scene_source(&welcome.scene, welcome.animate) {
        Ok(s) => s,
        Err(reason) => {
            // Best effort: the hub logs it naming this worker; the error is returned anyway.
            let _ = write_frame(
                &mut stream,
                &status(WorkerState::SceneFailed, 0, reason.clone()).write(),
            );
            return Err(RemoteWorkerError::Scene { name, reason });
        }
    };
    let built = RenderScene::new(scene).map_err(|e| e.to_string());
    let rs = match built {
        Ok(rs) => rs,
        Err(reason) => {
            let _ = write_frame(
                &mut stream,
                &status(WorkerState::SceneFailed, 0, reason.clone()).write(),
            );
            return Err(RemoteWorkerError::Scene { name, reason });
        }
    };
    let session = Session::new(&rs, &welcome);
    let worker = RenderWorker::with_animation(Arc::new(rs), config.threads, Box::new(|_| {}), rig);
    let worker = match worker {
        Ok(w) => w,
        Err(e) => {
            let reason = e.to_string();
            let _ = write_frame(
                &mut stream,
                &status(WorkerState::Failed, 0, reason.clone()).write(),
            );
            return Err(RemoteWorkerError::Threads(reason));
        }
    };
    let threads = worker.threads().min(u16::MAX as usize) as u16;
    write_frame(
        &mut stream,
        &status(WorkerState::Ready, threads, String::new()).write(),
    )?;
    stream.set_read_timeout(None)?;
    let (tx, rx) = mpsc::sync_channel(INBOX);
    let mut reading = stream.try_clone()?;
    let reader = std::thread::Builder::new()
        .name("lumo-worker-reader".into())
        .spawn(move || loop {
            let (item, last) = match read_frame(&mut reading, MAX_HUB_MESSAGE) {
                Ok(Some(m)) => (Inbound::Message(m), false),
                Ok(None) => (Inbound::Closed, true),
                Err(e) => (Inbound::Failed(e), true),
            };
            if tx.send(item).is_err() || last {
                break;
            }
        })?;
    let result = render_loop(&mut stream, &rx, worker, session, &config.stop, &name);
    // Unblocks the reader thread's read.
    let _ = stream.shutdown(Shutdown::Both);
    drop(rx);
    let _ = reader.join();
    result
}

/// What the worker keeps between the hub's messages.
struct Session {
    /// The scene's camera with the wire's field-of-view convention (shorter side).
    base_camera: Camera,
    targets: EditTargets,
    welcome: Welcome,
    /// Edits received since the last EPOCH, applied with the next render.
    edits: Vec<Edit>,
    /// The render worker's epoch and the hub's epoch it renders.
    current: Option<(u64, u32)>,
}

impl Session {
    fn new(rs: &RenderScene, welcome: &Welcome) -> Self {
        let (w, h) = (welcome.width as usize, welcome.height as usize);
        let mut base_camera = rs.scene.camera.clone();
        base_camera.fov = shorter_side_fov(&base_camera, w, h);
        base_camera.fov_axis = FovAxis::Smaller;
        Self {
            base_camera,
            targets: EditTargets::of(rs),
            welcome: welcome.clone(),
            edits: Vec::new(),
            current: None,
        }
    }

    /// Acts on one hub message.
    fn handle(&mut self, worker: &RenderWorker, msg: &[u8]) -> Result<(), RemoteWorkerError> {
        match msg.first().copied() {
            Some(protocol::kind::EDIT) => {
                let e = Edit::read(msg)?;
                e.validate()?;
                self.targets.check(&e)?;
                merge_edits(&mut self.edits, &[e]);
            }
            Some(kind::EPOCH) => {
                let u = EpochUpdate::read(msg)?;
                if u.rendering && u.mode == Mode::Progressive {
                    let job = self.job(&u);
                    let edits = std::mem::take(&mut self.edits);
                    let local = worker.render_edited(job, u.time, edits);
                    self.current = Some((local, u.epoch));
                } else {
                    worker.abort();
                    self.current = None;
                }
            }
            Some(k) => {
                return Err(ProtocolError::new(
                    protocol::ErrorCode::UnknownType,
                    format!("message type {k:#04x} on a worker connection"),
                )
                .into())
            }
            None => {}
        }
        Ok(())
    }

    fn job(&self, u: &EpochUpdate) -> Job {
        let w = &self.welcome;
        let mut camera = self.base_camera.clone();
        camera.origin = u.camera.origin;
        camera.target = u.camera.target;
        camera.up = u.camera.up;
        camera.fov = u.camera.fov;
        Job {
            camera,
            width: w.width as usize,
            height: w.height as usize,
            integrator: u.integrator,
            mode: Mode::Progressive,
            path: w.path,
            seed: w.seed,
            max_batches: None,
            max_rate: None,
            ppm: w.ppm,
        }
    }
}

/// Handles the hub's messages and sends samples until the hub closes or `stop` is raised.
fn render_loop(
    stream: &mut TcpStream,
    rx: &mpsc::Receiver<Inbound>,
    worker: RenderWorker,
    mut session: Session,
    stop: &AtomicBool,
    name: &str,
) -> Result<(), RemoteWorkerError> {
    let mut buf = QueryBuffer::default();
    loop {
        if stop.load(Ordering::SeqCst) {
            return Ok(());
        }
        let mut next = rx.recv_timeout(PUMP_INTERVAL);
        loop {
            match next {
                Ok(Inbound::Message(m)) if m.first() == Some(&protocol::kind::ERROR) => {
                    return Err(RemoteWorkerError::Refused {
                        name: name.into(),
                        reason: refusal(&m),
                    });
                }
                Ok(Inbound::Message(m)) => session.handle(&worker, &m)?,
                Ok(Inbound::Closed) | Err(RecvTimeoutError::Disconnected) => return Ok(()),
                Ok(Inbound::Failed(e)) => return Err(e.into()),
                Err(RecvTimeoutError::Timeout) => break,
            }
            // Everything already queued, before sampling again.
            next = rx.try_recv().map_err(|e| match e {
                mpsc::TryRecvError::Empty => RecvTimeoutError::Timeout,
                mpsc::TryRecvError::Disconnected => RecvTimeoutError::Disconnected,
            });
        }
        let _ = worker.query(&mut buf);
        let Some((local, epoch)) = session.current else {
            continue;
        };
        if buf.epoch != local {
            continue;
        }
        for msg in sample_messages(epoch, &buf) {
            if let Err(e) = write_frame(stream, &msg) {
                return after_write_error(rx, e, name);
            }
        }
    }
}

/// A write failed: if the hub closed the connection (or said why first), that is the answer;
/// otherwise the write's error is.
fn after_write_error(
    rx: &mpsc::Receiver<Inbound>,
    e: io::Error,
    name: &str,
) -> Result<(), RemoteWorkerError> {
    let deadline = std::time::Instant::now() + Duration::from_millis(500);
    while let Some(left) = deadline.checked_duration_since(std::time::Instant::now()) {
        match rx.recv_timeout(left) {
            Ok(Inbound::Message(m)) if m.first() == Some(&protocol::kind::ERROR) => {
                return Err(RemoteWorkerError::Refused {
                    name: name.into(),
                    reason: refusal(&m),
                });
            }
            Ok(Inbound::Message(_)) => {}
            Ok(Inbound::Closed) => return Ok(()),
            Ok(Inbound::Failed(_)) | Err(_) => break,
        }
    }
    Err(e.into())
}
