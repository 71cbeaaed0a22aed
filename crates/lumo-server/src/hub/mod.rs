//! The shared state of a server: the render worker, the current job, and the viewers'
//! outboxes. A pump task queries the worker at display rate and fans the samples out.
//!
//! Camera and parameter changes restart the render at most once per
//! [`crate::Limits::min_restart_interval`]: changes arriving faster are merged into the next
//! restart, which the pump applies. A viewer still gets one CAMERA per camera it sent (the
//! viewer counts its requests in flight by them); other viewers get only the newest. With no
//! viewer connected the renderer is paused ([`crate::Limits::pause_when_idle`]).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use axum::body::Bytes;
use lumo_render::RenderScene;
use lumo_scene::{Camera, FovAxis};

use crate::batches::sample_messages;
use crate::outbox::{Kind, Outbox, Outgoing, QueueReport, Slot};
use crate::protocol::{
    Animate, CameraUpdate, Edit, ErrorCode, Finish, Frame, Hello, Integrator, Mode, Params, Pick,
    ProtocolError, Stats, WireCamera,
};
use crate::remote::RemoteSet;
use crate::scene_edit::{self, EditTargets};
use crate::worker::{FinishEvent, Job, QueryBuffer, RenderWorker};
use crate::ServerConfig;

mod remote;
pub use remote::Merged;

/// Samples per batch message: 8192 × 12 bytes = 96 KiB, small enough to interleave with
/// control messages, to drop without losing much, and for a slow viewer to rasterise a few per
/// frame.
pub const SAMPLES_PER_MESSAGE: usize = 8192;
/// How often the pump queries the worker: about the display rate.
pub const PUMP_INTERVAL: Duration = Duration::from_millis(16);
/// How often stats go out.
pub const STATS_INTERVAL: Duration = Duration::from_millis(250);

struct Viewer {
    id: u64,
    outbox: Arc<Outbox>,
    /// Cameras this viewer sent that no CAMERA has answered yet.
    owed: u32,
}

/// State shared by the pump and the connections.
pub struct Hub {
    worker: RenderWorker,
    config: ServerConfig,
    name: String,
    triangles: u32,
    /// Current job and its epoch; also the lock that orders "new render + camera broadcast"
    /// against the pump's fan-out, so no viewer gets new-epoch samples before the camera.
    state: Mutex<HubState>,
    next_id: AtomicU64,
    /// Finish events recorded by the worker's handler, forwarded by the pump.
    finished: Arc<Mutex<Vec<FinishEvent>>>,
    /// What viewers' edits may change (edits keep the scene's structure, so it stays valid).
    targets: EditTargets,
    /// Remote render workers (`lumo serve --remote-workers`; empty when off).
    remote: RemoteSet,
    /// The scene has media or null boundaries: photon mapping may not render it.
    media: bool,
}

struct HubState {
    /// The job rendering now (epoch `epoch`).
    job: Job,
    epoch: u64,
    viewers: Vec<Viewer>,
    /// The job viewers asked for, applied at the next restart.
    next: Job,
    /// `next` differs from `job` (a restart is due).
    pending: bool,
    /// The integrator or mode changed since the last restart (PARAMS goes out with it).
    params_changed: bool,
    last_restart: Instant,
    /// Rendering is stopped because nobody watches.
    paused: bool,
    /// The animation's clock (`lumo serve --animate`); `None` for a static scene.
    clock: Option<Clock>,
    /// Scene edits asked for since the last restart (checked; one per op and index, the
    /// newest), applied by the worker at the next restart.
    edits: Vec<Edit>,
    /// Camera samples and light paths remote workers contributed to this epoch (STATS).
    remote_counts: (u64, u64),
}

/// The animation's clock: wall-clock time while playing, frozen while paused, looping over
/// the clips' duration.
#[derive(Clone, Copy, Debug)]
struct Clock {
    playing: bool,
    /// Animation time at `since`.
    at: f32,
    since: Instant,
    /// Length of the clips; 0 holds time at 0.
    duration: f32,
}

impl Clock {
    /// Animation time now.
    fn now(&self) -> f32 {
        let t = if self.playing {
            self.at + self.since.elapsed().as_secs_f32()
        } else {
            self.at
        };
        if self.duration > 0.0 {
            t % self.duration
        } else {
            0.0
        }
    }

    /// The ANIMATE message of this state.
    fn message(&self) -> Animate {
        Animate {
            playing: self.playing,
            time: self.now(),
            duration: self.duration,
        }
    }
}

/// Starts `job` on `worker` after applying `edits`, posed at the clock's time when the scene
/// is animated; returns the epoch and that time.
fn start(
    worker: &RenderWorker,
    job: Job,
    clock: Option<&Clock>,
    edits: Vec<Edit>,
) -> (u64, Option<f32>) {
    let time = clock.map(Clock::now);
    (worker.render_edited(job, time, edits), time)
}

fn to_wire(c: &Camera) -> WireCamera {
    WireCamera {
        origin: c.origin,
        target: c.target,
        up: c.up,
        fov: c.fov,
    }
}

/// `integrator` as `lumo serve --integrator` names it (what [`lumo_render::media`] reads).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Hub {
    /// Starts the worker and the first render.
    pub fn new(rs: RenderScene, config: ServerConfig) -> anyhow::Result<Arc<Self>> {
        let name = rs.scene.name.clone();
        let media = rs.scene.media.is_active();
        let chosen = config.integrator;
        if let Some(why) =
            lumo_render::media::refusal(&rs.scene, chosen.name(), chosen.renders_media())
        {
            anyhow::bail!(why);
        }
        let triangles = rs.scene.triangle_count().min(u32::MAX as usize) as u32;
        let mut camera = rs.scene.camera.clone();
        // The wire camera's field of view is along the shorter side; convert once.
        camera.fov = shorter_side_fov(&camera, config.width, config.height);
        camera.fov_axis = FovAxis::Smaller;
        let job = Job {
            camera,
            width: config.width,
            height: config.height,
            integrator: config.integrator,
            mode: Mode::Progressive,
            path: config.path,
            seed: config.seed,
            max_batches: None,
            max_rate: config.max_rate,
            ppm: config.ppm,
        };
        // The finish handler runs on a render thread: it only records the event.
        let finished: Arc<Mutex<Vec<FinishEvent>>> = Arc::default();
        let f2 = finished.clone();
        // An animation plays from t = 0 at start.
        let clock = config.animation.as_ref().map(|rig| Clock {
            playing: true,
            at: 0.0,
            since: Instant::now(),
            duration: rig.duration(),
        });
        let targets = EditTargets::of(&rs);
        let worker = RenderWorker::with_animation(
            Arc::new(rs),
            config.threads,
            Box::new(move |e| lock(&f2).push(e)),
            config.animation.clone(),
        )?;
        // Nobody watches yet: render only once a viewer connects, unless told to keep going.
        let paused = config.limits.pause_when_idle;
        let (epoch, time) = if paused {
            (worker.abort(), None)
        } else {
            start(&worker, job.clone(), clock.as_ref(), Vec::new())
        };
        let remote = RemoteSet::new(config.remote.clone());
        let hub = Arc::new(Self {
            worker,
            config,
            name,
            triangles,
            state: Mutex::new(HubState {
                next: job.clone(),
                job,
                epoch,
                viewers: Vec::new(),
                pending: false,
                params_changed: false,
                last_restart: Instant::now(),
                paused,
                clock,
                edits: Vec::new(),
                remote_counts: (0, 0),
            }),
            next_id: AtomicU64::new(1),
            finished,
            targets,
            remote,
            media,
        });
        hub.announce(&lock(&hub.state), time, &[]);
        Ok(hub)
    }

    /// Render threads.
    pub fn threads(&self) -> usize {
        self.worker.threads()
    }

    /// The limits this server enforces.
    pub fn limits(&self) -> &crate::Limits {
        &self.config.limits
    }

    /// Registers a viewer and queues its hello; returns its id and outbox, or None when
    /// [`crate::Limits::max_viewers`] are connected. Resumes a paused render.
    pub fn join(&self) -> Option<(u64, Arc<Outbox>)> {
        let mut st = lock(&self.state);
        if st.viewers.len() >= self.config.limits.max_viewers {
            return None;
        }
        let id = self.next_id.fetch_add(1, Ordering::Relaxed);
        let outbox = Arc::new(Outbox::with_budgets(
            self.config.viewer_queue_bytes,
            self.config.limits.control_queue_bytes,
        ));
        if st.paused {
            st.paused = false;
            // Changes asked for before the pause apply now; nobody is owed a CAMERA.
            st.job = st.next.clone();
            st.pending = false;
            st.params_changed = false;
            let edits = std::mem::take(&mut st.edits);
            let (epoch, time) = start(
                &self.worker,
                st.job.clone(),
                st.clock.as_ref(),
                edits.clone(),
            );
            st.epoch = epoch;
            st.last_restart = Instant::now();
            st.remote_counts = (0, 0);
            self.announce(&st, time, &edits);
        }
        let hello = Hello {
            width: self.config.width as u32,
            height: self.config.height as u32,
            triangles: self.triangles,
            threads: self.worker.threads().min(u16::MAX as usize) as u16,
            integrator: st.job.integrator,
            mode: st.job.mode,
            epoch: st.epoch as u32,
            camera: to_wire(&st.job.camera),
            name: self.name.clone(),
        };
        outbox.push(control(hello.write()));
        if let Some(c) = &st.clock {
            outbox.push(control(c.message().write()));
        }
        st.viewers.push(Viewer {
            id,
            outbox: outbox.clone(),
            owed: 0,
        });
        Some((id, outbox))
    }

    /// Unregisters a viewer and closes its outbox; pauses rendering when it was the last.
    pub fn leave(&self, id: u64) {
        let mut st = lock(&self.state);
        st.viewers.retain(|v| {
            if v.id == id {
                v.outbox.close();
            }
            v.id != id
        });
        if st.viewers.is_empty() && self.config.limits.pause_when_idle && !st.paused {
            st.paused = true;
            // A pending change stays in `next` and applies on resume.
            st.epoch = self.worker.abort();
            st.remote_counts = (0, 0);
            self.announce(&st, None, &[]);
        }
    }

    /// True while rendering is paused because no viewer is connected.
    pub fn is_paused(&self) -> bool {
        lock(&self.state).paused
    }

    /// Epoch of the current render (it grows by one per restart).
    pub fn epoch(&self) -> u64 {
        lock(&self.state).epoch
    }

    /// Each viewer's id and queue sizes, for tests and tools.
    pub fn queue_reports(&self) -> Vec<(u64, QueueReport)> {
        lock(&self.state)
            .viewers
            .iter()
            .map(|v| (v.id, v.outbox.report()))
            .collect()
    }

    /// Viewers connected.
    pub fn viewer_count(&self) -> usize {
        lock(&self.state).viewers.len()
    }

    /// Viewer `id` moved the camera: restart rendering (now, or merged into the next restart
    /// if the last one was too recent) and tell every viewer.
    pub fn set_camera(&self, id: u64, c: WireCamera) {
        let mut st = lock(&self.state);
        st.next.camera.origin = c.origin;
        st.next.camera.target = c.target;
        st.next.camera.up = c.up;
        st.next.camera.fov = c.fov;
        if let Some(v) = st.viewers.iter_mut().find(|v| v.id == id) {
            v.owed = v.owed.saturating_add(1);
        }
        st.pending = true;
        self.maybe_restart(&mut st);
    }

    /// A viewer changed integrator or mode: restart rendering (now or merged as above) and
    /// tell every viewer.
    /// Refused for photon mapping in a scene with participating media.
    pub fn set_params(&self, integrator: Integrator, mode: Mode) -> Result<(), ProtocolError> {
        if self.media && !integrator.renders_media() {
            let takers: Vec<String> = Integrator::ALL
                .iter()
                .filter(|m| m.renders_media())
                .map(|m| format!("{m:?}"))
                .collect();
            return Err(ProtocolError::new(
                ErrorCode::InvalidValue,
                format!(
                    "PARAMS: the scene has participating media, which {integrator:?} does not \
                     render (choose {})",
                    lumo_render::sentence(&takers, "or")
                ),
            ));
        }
        let mut st = lock(&self.state);
        st.next.integrator = integrator;
        st.next.mode = mode;
        st.pending = true;
        st.params_changed = true;
        self.maybe_restart(&mut st);
        Ok(())
    }

    /// A viewer plays or pauses the animation: the clock runs or freezes, every viewer is
    /// told, and the render restarts at the clock's time. Refused for a static scene.
    pub fn set_playing(&self, playing: bool) -> Result<(), ProtocolError> {
        let mut st = lock(&self.state);
        let Some(c) = &mut st.clock else {
            return Err(ProtocolError::new(
                ErrorCode::InvalidValue,
                "ANIMATE: the scene is not animated (start lumo serve with --animate and an animated glTF scene)",
            ));
        };
        if c.playing != playing {
            c.at = c.now();
            c.since = Instant::now();
            c.playing = playing;
        }
        let msg = c.message().write();
        broadcast(&st, &control(msg));
        st.pending = true;
        self.maybe_restart(&mut st);
        Ok(())
    }

    /// A viewer edits the scene: the edit is checked against the scene, queued (replacing an
    /// older edit of the same op and index) and applied at the next restart (now, or merged
    /// as cameras are), which tells every viewer with EDIT and the new epoch's CAMERA.
    pub fn set_edit(&self, edit: Edit) -> Result<(), ProtocolError> {
        self.targets.check(&edit)?;
        let mut st = lock(&self.state);
        st.edits
            .retain(|e| (e.op, e.index) != (edit.op, edit.index));
        st.edits.push(edit);
        st.pending = true;
        self.maybe_restart(&mut st);
        Ok(())
    }

    /// Viewer `id` asks what is under an image position: the worker casts the ray through it
    /// with the newest camera asked for (after the edits already queued) and the answer goes
    /// to that viewer only.
    pub fn pick(&self, id: u64, request: Pick) {
        let st = lock(&self.state);
        let Some(v) = st.viewers.iter().find(|v| v.id == id) else {
            return;
        };
        let outbox = v.outbox.clone();
        let (camera, w, h) = (st.next.camera.clone(), st.next.width, st.next.height);
        drop(st);
        self.worker.query_scene(Box::new(move |rs| {
            let hit = scene_edit::pick(rs, &camera, w, h, request.uv);
            let answer = Pick { hit, ..request };
            outbox.push(control(answer.write()));
        }));
    }

    /// The animation's state, if the scene is animated.
    pub fn animation(&self) -> Option<Animate> {
        lock(&self.state).clock.map(|c| c.message())
    }

    fn maybe_restart(&self, st: &mut HubState) {
        if st.pending
            && !st.paused
            && st.last_restart.elapsed() >= self.config.limits.min_restart_interval
        {
            self.restart(st);
        }
    }

    /// Starts `next`, purges old data and announces the new epoch: PARAMS if they changed,
    /// then CAMERA, once per camera a viewer asked for and once (replacing an older queued
    /// one) for the others.
    fn restart(&self, st: &mut HubState) {
        st.job = st.next.clone();
        let edits = std::mem::take(&mut st.edits);
        let (epoch, time) = start(
            &self.worker,
            st.job.clone(),
            st.clock.as_ref(),
            edits.clone(),
        );
        st.epoch = epoch;
        st.last_restart = Instant::now();
        st.pending = false;
        st.remote_counts = (0, 0);
        self.announce(st, time, &edits);
        let epoch = st.epoch as u32;
        for v in &st.viewers {
            v.outbox.purge_except(epoch);
        }
        if std::mem::take(&mut st.params_changed) {
            let params = Params {
                integrator: st.job.integrator,
                mode: st.job.mode,
            }
            .write();
            broadcast(st, &latest(Slot::Params, params));
        }
        // The edits applied, so every viewer's panel shows them (data of the new epoch: a
        // newer restart's edits, absolute values, replace them).
        for e in &edits {
            broadcast(st, &data(epoch, e.write()));
        }
        let camera = Bytes::from(
            CameraUpdate {
                epoch,
                camera: to_wire(&st.job.camera),
            }
            .write(),
        );
        for v in &mut st.viewers {
            if v.owed == 0 {
                v.outbox.push(Outgoing {
                    kind: Kind::Latest(Slot::Camera),
                    bytes: camera.clone(),
                });
            }
            // Owed copies must all arrive; a viewer that keeps asking without reading runs
            // into its control budget and is closed.
            for _ in 0..std::mem::take(&mut v.owed) {
                v.outbox.push(Outgoing {
                    kind: Kind::Control,
                    bytes: camera.clone(),
                });
            }
        }
    }

    /// Runs forever: queries the worker every [`PUMP_INTERVAL`] and fans out samples,
    /// frames, finish events and stats.
    pub async fn pump(self: Arc<Self>) {
        let mut interval = tokio::time::interval(PUMP_INTERVAL);
        interval.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        let mut buf = QueryBuffer::default();
        let mut last_stats = Instant::now();
        let mut last_count = (0u64, 0u64);
        loop {
            interval.tick().await;
            self.pump_once(&mut buf, &mut last_stats, &mut last_count);
        }
    }

    fn pump_once(&self, buf: &mut QueryBuffer, last_stats: &mut Instant, last: &mut (u64, u64)) {
        let mut st = lock(&self.state);
        // A playing animation shows a new pose every tick: a restart (new epoch) per frame.
        if st.clock.is_some_and(|c| c.playing) {
            st.pending = true;
        }
        // Changes merged because they came too fast start here, at most one pump tick late.
        self.maybe_restart(&mut st);
        let st = st;
        let stats = self.worker.query(buf);
        if buf.epoch == st.epoch {
            let epoch = buf.epoch as u32;
            for msg in sample_messages(epoch, buf) {
                broadcast(&st, &data(epoch, msg));
            }
            if let Some(f) = &buf.frame {
                let msg = Frame {
                    epoch,
                    width: f.width as u16,
                    height: f.height as u16,
                    mode: f.mode,
                    frames: f.frames,
                }
                .write(&f.xyz);
                broadcast(&st, &data(epoch, msg));
            }
        }
        for e in std::mem::take(&mut *lock(&self.finished)) {
            let msg = Finish {
                epoch: e.epoch as u32,
                aborted: e.aborted,
                samples: e.samples,
                light_paths: e.light_paths,
                seconds: e.elapsed.as_secs_f32(),
            }
            .write();
            broadcast(&st, &latest(Slot::Finish, msg));
        }
        let dt = last_stats.elapsed();
        if dt >= STATS_INTERVAL {
            // Remote workers' samples of this epoch count as the hub's own.
            let remote = if stats.epoch == st.epoch {
                st.remote_counts
            } else {
                (0, 0)
            };
            let count = (stats.samples + remote.0, stats.light_paths + remote.1);
            let done = if stats.epoch == st.epoch && count >= *last {
                (count.0 - last.0) + (count.1 - last.1)
            } else {
                count.0 + count.1
            };
            let rate = done as f64 / dt.as_secs_f64();
            *last = count;
            *last_stats = Instant::now();
            for v in &st.viewers {
                let s = Stats {
                    epoch: st.epoch as u32,
                    viewers: st.viewers.len() as u32,
                    samples: count.0,
                    light_paths: count.1,
                    rate: rate as f32,
                    dropped: v.outbox.dropped().min(u32::MAX as u64) as u32,
                };
                v.outbox.push(Outgoing {
                    kind: Kind::Stats,
                    bytes: Bytes::from(s.write()),
                });
            }
        }
    }

    /// The worker, for tests and tools.
    pub fn worker(&self) -> &RenderWorker {
        &self.worker
    }
}

fn control(v: Vec<u8>) -> Outgoing {
    Outgoing {
        kind: Kind::Control,
        bytes: Bytes::from(v),
    }
}

fn latest(slot: Slot, v: Vec<u8>) -> Outgoing {
    Outgoing {
        kind: Kind::Latest(slot),
        bytes: Bytes::from(v),
    }
}

fn data(epoch: u32, v: Vec<u8>) -> Outgoing {
    Outgoing {
        kind: Kind::Data(epoch),
        bytes: Bytes::from(v),
    }
}

fn broadcast(st: &HubState, msg: &Outgoing) {
    for v in &st.viewers {
        v.outbox.push(msg.clone());
    }
}

/// The scene camera's field of view measured along the image's shorter side.
pub(crate) fn shorter_side_fov(c: &Camera, width: usize, height: usize) -> f32 {
    let (hw, hh) = c.half_extent(width, height);
    (2.0 * hw.min(hh).atan()).to_degrees()
}
