//! The hub's side of its remote workers: who is connected, what each still has to be told
//! (the edits applied since it last heard, the newest epoch state), their counters, and a
//! short log of what they did wrong.

use std::collections::VecDeque;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use crate::protocol::remote::EpochUpdate;
use crate::protocol::Edit;

use super::RemoteConfig;

/// Log lines the hub keeps for [`crate::Hub::remote_log`] (they also go to stderr).
const LOG_LINES: usize = 256;

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Adds `new` to `edits`, each replacing an older edit of the same op and index: edits hold
/// absolute values, so the newest of each is all a worker needs, and the list stays bounded by
/// the scene's objects, lights and materials however many edits are made.
pub(crate) fn merge_edits(edits: &mut Vec<Edit>, new: &[Edit]) {
    for e in new {
        edits.retain(|o| (o.op, o.index) != (e.op, e.index));
        edits.push(*e);
    }
}

/// A connected worker's counters, as [`crate::Hub::remote_workers`] reports them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RemoteWorkerStats {
    /// The worker's number at this hub.
    pub id: u64,
    /// Its name.
    pub name: String,
    /// Its address.
    pub peer: SocketAddr,
    /// True once it loaded the scene and renders.
    pub ready: bool,
    /// Camera samples merged into the viewers' stream.
    pub samples: u64,
    /// Light paths merged (the light stream's divisor).
    pub light_paths: u64,
    /// Sample batches merged.
    pub batches: u64,
    /// Bytes of merged batches.
    pub bytes: u64,
    /// Batches dropped because their epoch was over.
    pub old_batches: u64,
}

/// What the hub still has to send one worker.
#[derive(Default)]
struct Queue {
    edits: Vec<Edit>,
    state: Option<EpochUpdate>,
}

/// One connected worker: its outgoing queue and counters.
pub(crate) struct WorkerLink {
    pub(crate) id: u64,
    pub(crate) name: String,
    pub(crate) peer: SocketAddr,
    queue: Mutex<Queue>,
    /// Wakes the connection's writer when there is something to send.
    wake: tokio::sync::Notify,
    /// Set when the hub drops the worker: the connection's tasks end.
    closed: tokio::sync::watch::Sender<bool>,
    ready: std::sync::atomic::AtomicBool,
    samples: AtomicU64,
    light_paths: AtomicU64,
    batches: AtomicU64,
    bytes: AtomicU64,
    old_batches: AtomicU64,
}

impl WorkerLink {
    /// Takes what is queued: the edits (in order), then the newest state.
    pub(crate) fn take(&self) -> (Vec<Edit>, Option<EpochUpdate>) {
        let mut q = lock(&self.queue);
        (std::mem::take(&mut q.edits), q.state.take())
    }

    /// Waits until something is queued (returns at once if something was queued since the
    /// last wait).
    pub(crate) async fn queued(&self) {
        self.wake.notified().await
    }

    /// Ends the connection's tasks.
    pub(crate) fn close(&self) {
        self.closed.send_replace(true);
    }

    /// Resolves once [`WorkerLink::close`] was called.
    pub(crate) async fn closed(&self) {
        let mut rx = self.closed.subscribe();
        let _ = rx.wait_for(|c| *c).await;
    }

    /// The worker loaded the scene.
    pub(crate) fn set_ready(&self) {
        self.ready.store(true, Ordering::Relaxed);
    }

    /// Counts a merged batch.
    pub(crate) fn count(&self, samples: u64, light_paths: u64, bytes: u64) {
        self.samples.fetch_add(samples, Ordering::Relaxed);
        self.light_paths.fetch_add(light_paths, Ordering::Relaxed);
        self.batches.fetch_add(1, Ordering::Relaxed);
        self.bytes.fetch_add(bytes, Ordering::Relaxed);
    }

    /// Counts a batch of an old epoch; returns the count so far.
    pub(crate) fn count_old(&self) -> u64 {
        self.old_batches.fetch_add(1, Ordering::Relaxed) + 1
    }

    fn push(&self, edits: &[Edit], state: EpochUpdate) {
        let mut q = lock(&self.queue);
        merge_edits(&mut q.edits, edits);
        q.state = Some(state);
        drop(q);
        self.wake.notify_one();
    }

    fn stats(&self) -> RemoteWorkerStats {
        RemoteWorkerStats {
            id: self.id,
            name: self.name.clone(),
            peer: self.peer,
            ready: self.ready.load(Ordering::Relaxed),
            samples: self.samples.load(Ordering::Relaxed),
            light_paths: self.light_paths.load(Ordering::Relaxed),
            batches: self.batches.load(Ordering::Relaxed),
            bytes: self.bytes.load(Ordering::Relaxed),
            old_batches: self.old_batches.load(Ordering::Relaxed),
        }
    }
}

struct Inner {
    links: Vec<Arc<WorkerLink>>,
    /// Every edit applied since the hub started (the newest per op and index): a worker that
    /// joins gets them before its first epoch.
    applied: Vec<Edit>,
    /// The current epoch's state.
    state: Option<EpochUpdate>,
}

/// The hub's remote workers.
pub(crate) struct RemoteSet {
    config: Option<RemoteConfig>,
    inner: Mutex<Inner>,
    next_id: AtomicU64,
    /// Connections still in their handshake (bounded apart from the workers).
    handshakes: AtomicUsize,
    log: Mutex<VecDeque<String>>,
}

impl RemoteSet {
    /// The set of a hub configured with `config` (`None`: remote workers are off).
    pub(crate) fn new(config: Option<RemoteConfig>) -> Self {
        Self {
            config,
            inner: Mutex::new(Inner {
                links: Vec::new(),
                applied: Vec::new(),
                state: None,
            }),
            next_id: AtomicU64::new(1),
            handshakes: AtomicUsize::new(0),
            log: Mutex::new(VecDeque::new()),
        }
    }

    /// The configuration, if remote workers are on.
    pub(crate) fn config(&self) -> Option<&RemoteConfig> {
        self.config.as_ref()
    }

    /// A new epoch: `edits` were applied before it; every worker is told.
    pub(crate) fn announce(&self, state: EpochUpdate, edits: &[Edit]) {
        if self.config.is_none() {
            return;
        }
        let mut inner = lock(&self.inner);
        merge_edits(&mut inner.applied, edits);
        inner.state = Some(state);
        for l in &inner.links {
            l.push(edits, state);
        }
    }

    /// Registers a worker that passed the handshake's checks; `None` when
    /// [`RemoteConfig::max_workers`] are connected. Its queue starts with every edit applied
    /// so far and the current state.
    pub(crate) fn register(&self, name: String, peer: SocketAddr) -> Option<Arc<WorkerLink>> {
        let max = self.config.as_ref()?.max_workers;
        let mut inner = lock(&self.inner);
        if inner.links.len() >= max {
            return None;
        }
        let link = Arc::new(WorkerLink {
            id: self.next_id.fetch_add(1, Ordering::Relaxed),
            name,
            peer,
            queue: Mutex::new(Queue::default()),
            wake: tokio::sync::Notify::new(),
            closed: tokio::sync::watch::channel(false).0,
            ready: Default::default(),
            samples: AtomicU64::new(0),
            light_paths: AtomicU64::new(0),
            batches: AtomicU64::new(0),
            bytes: AtomicU64::new(0),
            old_batches: AtomicU64::new(0),
        });
        if let Some(state) = inner.state {
            link.push(&inner.applied, state);
        }
        inner.links.push(link.clone());
        Some(link)
    }

    /// Unregisters worker `id`.
    pub(crate) fn remove(&self, id: u64) {
        lock(&self.inner).links.retain(|l| l.id != id);
    }

    /// Counters of every connected worker.
    pub(crate) fn stats(&self) -> Vec<RemoteWorkerStats> {
        lock(&self.inner).links.iter().map(|l| l.stats()).collect()
    }

    /// Starts a handshake unless `max` are under way.
    pub(crate) fn begin_handshake(&self, max: usize) -> bool {
        self.handshakes
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| {
                (n < max).then_some(n + 1)
            })
            .is_ok()
    }

    /// Ends a handshake begun by [`RemoteSet::begin_handshake`].
    pub(crate) fn end_handshake(&self) {
        self.handshakes.fetch_sub(1, Ordering::SeqCst);
    }

    /// Logs `line` (stderr and the last [`LOG_LINES`] kept for tools and tests).
    pub(crate) fn log(&self, line: String) {
        eprintln!("{line}");
        let mut log = lock(&self.log);
        if log.len() == LOG_LINES {
            log.pop_front();
        }
        log.push_back(line);
    }

    /// The log lines kept.
    pub(crate) fn log_lines(&self) -> Vec<String> {
        lock(&self.log).iter().cloned().collect()
    }
}
