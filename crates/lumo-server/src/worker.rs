//! The render worker of the paper's §4.1: a wrapper thread that takes the commands `render`,
//! `abort` and `term`, runs renders on a thread pool, fires a finish event when a render ends,
//! and answers a synchronous query that copies the samples rendered so far into the caller's
//! buffer.
//!
//! Every render has an *epoch*. `render` and `abort` bump the shared epoch at once, from the
//! caller's thread, and the pool threads compare it before every single sample, so an abort
//! takes effect within one sample (a path or a light path), well inside one batch. Samples of a
//! stale epoch are never handed out: the buffer checks the epoch under its lock.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use lumo_render::integrators::photon::LockStats;
use lumo_render::stream::{streamed, SampleStream, StreamRun};
use lumo_render::{camera::PinholeCamera, PathSettings, PpmSettings, RenderScene};
use lumo_scene::{AnimatedScene, Camera};

use crate::frames::{FrameAccumulator, TemporalHistory, TEMPORAL_FRAMES};
use crate::protocol::{Edit, Integrator, Mode};
use crate::scene_edit::{edit, pose, relights};
use crate::streams::{Sample, ScreenOrder, StreamContext};

/// Camera samples per batch (about a millisecond of path tracing on one core for small scenes).
pub const CAMERA_BATCH: u64 = 256;
/// Light paths per batch.
pub const LIGHT_BATCH: u64 = 128;
/// Most samples the query buffer keeps when nobody queries; further batches are dropped, so a
/// vanished consumer costs bounded memory and never blocks the renderer.
pub const MAX_PENDING: usize = 1 << 21;

/// What to render.
#[derive(Clone, Debug)]
pub struct Job {
    /// Camera.
    pub camera: Camera,
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// Sample streams to produce.
    pub integrator: Integrator,
    /// Progressive samples or filtered frames.
    pub mode: Mode,
    /// Path settings shared by both tracers.
    pub path: PathSettings,
    /// Seed.
    pub seed: u32,
    /// Stop after this many batches (None: run until aborted).
    pub max_batches: Option<u64>,
    /// Throttle to this many samples (camera samples plus light paths) per second.
    pub max_rate: Option<f64>,
    /// Photon-mapping settings (integrator ppm): photon paths per pass, map capacity, radius.
    pub ppm: PpmSettings,
}

/// A filtered frame ready to send.
#[derive(Clone, Debug)]
pub struct FilteredFrame {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// XYZ pixels, row-major, 3 floats each.
    pub xyz: Vec<f32>,
    /// 1-spp frames averaged before filtering.
    pub frames: u32,
    /// Which filter made it.
    pub mode: Mode,
}

/// The finish event: a render ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FinishEvent {
    /// Its epoch.
    pub epoch: u64,
    /// True if stopped by abort, render or term; false if its batch budget ran out.
    pub aborted: bool,
    /// Camera samples rendered.
    pub samples: u64,
    /// Light paths traced.
    pub light_paths: u64,
    /// Wall time from start to the last pool thread stopping.
    pub elapsed: Duration,
    /// When the last pool thread stopped.
    pub finished_at: Instant,
}

/// What a query hands out.
#[derive(Debug, Default)]
pub struct QueryBuffer {
    /// Epoch the samples belong to.
    pub epoch: u64,
    /// Camera samples.
    pub camera: Vec<Sample>,
    /// Light splats.
    pub light: Vec<Sample>,
    /// Light paths the splats account for (the light image is divided by this).
    pub light_paths: u64,
    /// Latest filtered frame, if a new one was made.
    pub frame: Option<FilteredFrame>,
}

impl QueryBuffer {
    /// Empties the buffer, keeping its allocations.
    pub fn clear(&mut self) {
        self.camera.clear();
        self.light.clear();
        self.light_paths = 0;
        self.frame = None;
    }
}

/// Counters of the current render.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WorkerStats {
    /// Epoch.
    pub epoch: u64,
    /// Camera samples rendered.
    pub samples: u64,
    /// Light paths traced.
    pub light_paths: u64,
    /// Rays traced.
    pub rays: u64,
    /// Batches dropped because the query buffer was full.
    pub dropped_batches: u64,
    /// Photon paths traced into the photon map (integrator ppm).
    pub photon_paths: u64,
    /// The photon map's lock counters (integrator ppm), as of the last batch.
    pub lock: LockStats,
}

/// A read of the render scene run on the worker's thread (a pick).
pub type SceneQuery = Box<dyn FnOnce(&RenderScene) + Send>;

enum Command {
    /// Render a job, first applying the edits and posing the animation at the given time if
    /// there is one.
    Render(u64, Box<Job>, Option<f32>, Vec<Edit>),
    /// Run a query on the scene as it is now (between edits, beside a running render).
    Query(SceneQuery),
    Abort,
    Term,
}

/// The finish handler.
pub type FinishHandler = Box<dyn Fn(FinishEvent) + Send + Sync>;

struct Shared {
    /// Current epoch; a running render stops as soon as it differs from its own.
    epoch: AtomicU64,
    pending: Mutex<Pending>,
    /// Pool threads still running the current render.
    active: Mutex<usize>,
    idle: Condvar,
    on_finish: FinishHandler,
    /// The À-Trous frame mode's temporal filter; it outlives renders so a camera move keeps
    /// the picture (None if it could not be made).
    temporal: Mutex<Option<TemporalHistory>>,
    /// Bits of the animation time the scene was last posed at (`u64::MAX`: never posed).
    posed_at: AtomicU64,
}

#[derive(Default)]
struct Pending {
    buffer: QueryBuffer,
    stats: WorkerStats,
}

/// The render worker.
pub struct RenderWorker {
    shared: Arc<Shared>,
    commands: mpsc::Sender<Command>,
    thread: Option<JoinHandle<()>>,
    threads: usize,
}

impl RenderWorker {
    /// Starts the wrapper thread and a pool of `threads` render threads (0: all cores).
    pub fn new(
        rs: Arc<RenderScene>,
        threads: usize,
        on_finish: FinishHandler,
    ) -> anyhow::Result<Self> {
        Self::with_animation(rs, threads, on_finish, None)
    }

    /// [`RenderWorker::new`] for an animated scene: [`RenderWorker::render_posed`] poses
    /// `rig` before a render. `rs` must not be shared elsewhere (the worker updates it in
    /// place between renders, when no render thread holds it).
    pub fn with_animation(
        rs: Arc<RenderScene>,
        threads: usize,
        on_finish: FinishHandler,
        rig: Option<AnimatedScene>,
    ) -> anyhow::Result<Self> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("lumo-render-{i}"))
            .build()?;
        let threads = pool.current_num_threads();
        let shared = Arc::new(Shared {
            epoch: AtomicU64::new(0),
            pending: Mutex::new(Pending::default()),
            active: Mutex::new(0),
            idle: Condvar::new(),
            on_finish,
            temporal: Mutex::new(TemporalHistory::new().map(|h| {
                h.deforming(
                    rig.iter()
                        .flat_map(|r| &r.deformers)
                        .map(|d| d.mesh)
                        .collect(),
                )
            })),
            posed_at: AtomicU64::new(u64::MAX),
        });
        let (tx, rx) = mpsc::channel();
        let sh = shared.clone();
        let thread = std::thread::Builder::new()
            .name("lumo-worker".into())
            .spawn(move || command_loop(rx, sh, pool, rs, rig))?;
        Ok(Self {
            shared,
            commands: tx,
            thread: Some(thread),
            threads,
        })
    }

    /// Render threads in the pool.
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// Aborts whatever runs and starts `job`; returns its epoch.
    pub fn render(&self, job: Job) -> u64 {
        self.start_render(job, None, Vec::new())
    }

    /// Aborts whatever runs, applies `edits` (checked against the scene by
    /// [`crate::scene_edit::EditTargets::check`]) once the previous render's threads let go
    /// of the scene, poses the animation at `time` if given, and starts `job`; returns its
    /// epoch. An edit that relights the scene clears the temporal history.
    pub fn render_edited(&self, job: Job, time: Option<f32>, edits: Vec<Edit>) -> u64 {
        self.start_render(job, time, edits)
    }

    /// Runs `query` with the scene on the worker's thread, after the edits of the renders
    /// started before it; a render that is running keeps running (the query only reads).
    pub fn query_scene(&self, query: SceneQuery) {
        let _ = self.commands.send(Command::Query(query));
    }

    /// Aborts whatever runs, poses the animation at `time` seconds (after the previous
    /// render's threads let go of the scene) and starts `job`; returns its epoch. Without an
    /// animation this is [`RenderWorker::render`].
    pub fn render_posed(&self, job: Job, time: f32) -> u64 {
        self.start_render(job, Some(time), Vec::new())
    }

    fn start_render(&self, job: Job, time: Option<f32>, edits: Vec<Edit>) -> u64 {
        let epoch = self.shared.epoch.fetch_add(1, Ordering::SeqCst) + 1;
        self.reset_pending(epoch);
        // A closed channel means term ran; the epoch bump already stopped everything.
        let _ = self
            .commands
            .send(Command::Render(epoch, Box::new(job), time, edits));
        epoch
    }

    /// Stops the current render; its finish event follows within one sample's time.
    pub fn abort(&self) -> u64 {
        let epoch = self.shared.epoch.fetch_add(1, Ordering::SeqCst) + 1;
        self.reset_pending(epoch);
        let _ = self.commands.send(Command::Abort);
        epoch
    }

    /// Stops rendering and ends the wrapper thread (also done on drop).
    pub fn term(&mut self) {
        self.shared.epoch.fetch_add(1, Ordering::SeqCst);
        let _ = self.commands.send(Command::Term);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }

    /// The synchronous query: moves the samples rendered since the last query into `out`
    /// (cleared first). Holds the lock only for the copy.
    pub fn query(&self, out: &mut QueryBuffer) -> WorkerStats {
        out.clear();
        let mut p = lock(&self.shared.pending);
        let b = &mut p.buffer;
        out.epoch = b.epoch;
        std::mem::swap(&mut out.camera, &mut b.camera);
        std::mem::swap(&mut out.light, &mut b.light);
        out.light_paths = std::mem::take(&mut b.light_paths);
        out.frame = b.frame.take();
        p.stats
    }

    /// The animation time, in seconds, the scene was last posed at by
    /// [`RenderWorker::render_posed`] (`None` before the first pose or without animation).
    pub fn posed_at(&self) -> Option<f32> {
        let bits = self.shared.posed_at.load(Ordering::SeqCst);
        (bits != u64::MAX).then(|| f32::from_bits(bits as u32))
    }

    /// Counters of the current render.
    pub fn stats(&self) -> WorkerStats {
        lock(&self.shared.pending).stats
    }

    fn reset_pending(&self, epoch: u64) {
        let mut p = lock(&self.shared.pending);
        p.buffer.clear();
        p.buffer.epoch = epoch;
        p.stats = WorkerStats {
            epoch,
            ..Default::default()
        };
    }
}

impl Drop for RenderWorker {
    fn drop(&mut self) {
        self.term();
    }
}

/// Locks, recovering from a poisoned mutex: the data (counters, sample vectors) stays valid
/// even if a render thread panicked while holding it.
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

fn wait_idle(shared: &Shared) {
    let mut active = lock(&shared.active);
    while *active > 0 {
        active = shared.idle.wait(active).unwrap_or_else(|e| e.into_inner());
    }
}

fn command_loop(
    rx: mpsc::Receiver<Command>,
    shared: Arc<Shared>,
    pool: rayon::ThreadPool,
    mut rs: Arc<RenderScene>,
    rig: Option<AnimatedScene>,
) {
    // The pose `rs` is at, so an unchanged time costs nothing.
    let mut posed: Option<f32> = None;
    while let Ok(cmd) = rx.recv() {
        match cmd {
            Command::Term => {
                wait_idle(&shared);
                break;
            }
            Command::Abort => wait_idle(&shared),
            Command::Query(query) => query(&rs),
            Command::Render(epoch, job, time, edits) => {
                // One render at a time: the previous one saw the epoch bump and is stopping.
                wait_idle(&shared);
                if !edits.is_empty() && edit(&mut rs, &edits) && edits.iter().any(relights) {
                    // The history's illumination is stale everywhere.
                    if let Some(h) = lock(&shared.temporal).as_mut() {
                        h.reset();
                    }
                }
                if let (Some(rig), Some(t)) = (&rig, time) {
                    if posed != Some(t) {
                        // In the pool: a rebuild (rare) builds in parallel on its threads.
                        if pool.install(|| pose(&mut rs, rig, t)) {
                            shared.posed_at.store(t.to_bits() as u64, Ordering::SeqCst);
                        }
                        posed = Some(t);
                    }
                }
                if shared.epoch.load(Ordering::SeqCst) != epoch {
                    (shared.on_finish)(FinishEvent {
                        epoch,
                        aborted: true,
                        samples: 0,
                        light_paths: 0,
                        elapsed: Duration::ZERO,
                        finished_at: Instant::now(),
                    });
                    continue;
                }
                start(&shared, &pool, rs.clone(), epoch, *job);
            }
        }
    }
}

/// Progress of one render, shared by its pool threads.
struct Run {
    epoch: u64,
    job: Job,
    next_batch: AtomicU64,
    samples: AtomicU64,
    light_paths: AtomicU64,
    start: Instant,
    /// The table's integrators that feed the streams (progressive mode; a splatting one
    /// replaced by the path tracer where the camera takes no splats).
    integrators: Vec<lumo_render::Integrator>,
    /// What their samples share across pool threads (a photon map that camera samples of
    /// every thread gather from while each batch adds its photons).
    stream: StreamRun,
}

impl Run {
    fn aborted(&self, shared: &Shared) -> bool {
        shared.epoch.load(Ordering::Relaxed) != self.epoch
    }

    /// Sleeps until the sample budget of `--max-rate` allows `done` samples, in short steps
    /// so an abort is still seen quickly. Returns false if aborted meanwhile.
    fn pace(&self, shared: &Shared, done: u64) -> bool {
        let Some(rate) = self.job.max_rate else {
            return true;
        };
        loop {
            if self.aborted(shared) {
                return false;
            }
            let allowed = self.start.elapsed().as_secs_f64() * rate;
            if done as f64 <= allowed {
                return true;
            }
            let wait = ((done as f64 - allowed) / rate).min(0.005);
            std::thread::sleep(Duration::from_secs_f64(wait));
        }
    }
}

fn start(
    shared: &Arc<Shared>,
    pool: &rayon::ThreadPool,
    rs: Arc<RenderScene>,
    epoch: u64,
    job: Job,
) {
    let integrators = if job.mode == Mode::Progressive {
        let camera = PinholeCamera::new(&job.camera, job.width, job.height);
        streamed(job.integrator.parts(), &camera)
    } else {
        Vec::new()
    };
    let run = Arc::new(Run {
        epoch,
        next_batch: AtomicU64::new(0),
        samples: AtomicU64::new(0),
        light_paths: AtomicU64::new(0),
        start: Instant::now(),
        stream: StreamRun::new(&integrators, &rs, job.ppm),
        integrators,
        job,
    });
    let threads = pool.current_num_threads();
    *lock(&shared.active) = threads;
    if run.job.mode == Mode::Progressive {
        for _ in 0..threads {
            let (shared, run, rs) = (shared.clone(), run.clone(), rs.clone());
            pool.spawn(move || {
                let finished = sample_loop(&shared, &run, &rs);
                // Let go of the scene before saying so: the worker may then update it.
                drop(rs);
                thread_done(&shared, &run, finished);
            });
        }
    } else {
        // A frame pipeline uses the whole pool through rayon inside one task; the other
        // threads count as finished right away.
        *lock(&shared.active) = 1;
        let (shared, run) = (shared.clone(), run.clone());
        pool.spawn(move || {
            let finished = frame_loop(&shared, &run, &rs);
            drop(rs);
            thread_done(&shared, &run, finished);
        });
    }
}

/// Marks one pool thread done; the last one fires the finish event.
fn thread_done(shared: &Shared, run: &Run, finished_budget: bool) {
    let mut active = lock(&shared.active);
    *active -= 1;
    if *active == 0 {
        let event = FinishEvent {
            epoch: run.epoch,
            aborted: !finished_budget || run.aborted(shared),
            samples: run.samples.load(Ordering::SeqCst),
            light_paths: run.light_paths.load(Ordering::SeqCst),
            elapsed: run.start.elapsed(),
            finished_at: Instant::now(),
        };
        // Fire before waking the wrapper thread, so events arrive in epoch order.
        (shared.on_finish)(event);
        shared.idle.notify_all();
    }
}

/// Renders batches until aborted or out of budget; true when the budget ran out.
fn sample_loop(shared: &Shared, run: &Run, rs: &RenderScene) -> bool {
    let job = &run.job;
    let order = ScreenOrder::new(job.width as u32, job.height as u32);
    let camera = PinholeCamera::new(&job.camera, job.width, job.height);
    let pixels = (job.width * job.height) as u64;
    let parts = &run.integrators;
    let ctx = StreamContext {
        stream: SampleStream::new(
            rs,
            camera,
            job.path,
            job.seed,
            &run.stream,
            pixels,
            order.period(),
            CAMERA_BATCH,
        ),
        order,
        size: glam::Vec2::new(job.width as f32, job.height as f32),
        // Integrators that estimate the same image side by side share it.
        scale: 1.0 / parts.len().max(1) as f32,
    };
    let camera_parts: Vec<_> = parts
        .iter()
        .copied()
        .filter(|i| i.caps().camera_stream)
        .collect();
    // Lights that emit no particles leave nothing for light paths to start from.
    let light_parts: Vec<_> = parts
        .iter()
        .copied()
        .filter(|i| i.streams_light_paths() && !rs.lights.emits_no_particles())
        .collect();
    let per_batch =
        camera_parts.len() as u64 * CAMERA_BATCH + light_parts.len() as u64 * LIGHT_BATCH;
    let mut camera = Vec::with_capacity(CAMERA_BATCH as usize);
    let mut light = Vec::new();
    loop {
        if run.aborted(shared) {
            return false;
        }
        let b = run.next_batch.fetch_add(1, Ordering::SeqCst);
        if job.max_batches.is_some_and(|m| b >= m) || per_batch == 0 {
            return true;
        }
        if !run.pace(shared, (b + 1) * per_batch) {
            return false;
        }
        camera.clear();
        light.clear();
        let mut paths = 0u64;
        // Photon mapping grows its map before the batch's camera samples gather from it.
        let Some(photons) = ctx.stream.grow_photons(b, || run.aborted(shared)) else {
            return false;
        };
        let mut rays = photons.rays;
        for &integrator in &camera_parts {
            // Each sample of an integrator that feeds both streams is one light path of the
            // light stream's normalisation.
            let light_path = integrator.caps().light_stream as u64;
            for n in b * CAMERA_BATCH..(b + 1) * CAMERA_BATCH {
                if run.aborted(shared) {
                    return false;
                }
                if let Some((s, r)) = ctx.camera_sample(integrator, n, &mut light) {
                    camera.push(s);
                    rays += r as u64;
                    paths += light_path;
                }
            }
        }
        for &integrator in &light_parts {
            for m in b * LIGHT_BATCH..(b + 1) * LIGHT_BATCH {
                if run.aborted(shared) {
                    return false;
                }
                rays += ctx.light_path(integrator, m, &mut light).unwrap_or(0) as u64;
                paths += 1;
            }
        }
        let mut p = lock(&shared.pending);
        if p.buffer.epoch != run.epoch {
            return false;
        }
        p.stats.rays += rays;
        p.stats.photon_paths += photons.paths;
        if let Some(lock) = run.stream.lock_stats() {
            p.stats.lock = lock;
        }
        if p.buffer.camera.len() + p.buffer.light.len() + camera.len() + light.len() > MAX_PENDING {
            p.stats.dropped_batches += 1;
            continue;
        }
        p.buffer.camera.extend_from_slice(&camera);
        p.buffer.light.extend_from_slice(&light);
        p.buffer.light_paths += paths;
        p.stats.samples += camera.len() as u64;
        p.stats.light_paths += paths;
        run.samples.fetch_add(camera.len() as u64, Ordering::SeqCst);
        run.light_paths.fetch_add(paths, Ordering::SeqCst);
    }
}

/// Renders 1-spp frames, keeps their running mean and publishes it filtered after each.
fn frame_loop(shared: &Shared, run: &Run, rs: &RenderScene) -> bool {
    let job = &run.job;
    let mut acc = FrameAccumulator::new(job);
    let mut frame = 0u64;
    loop {
        if run.aborted(shared) {
            return false;
        }
        if job.max_batches.is_some_and(|m| frame >= m) {
            return true;
        }
        let abort = || run.aborted(shared);
        let Some(rays) = acc.add_frame(rs, frame as u32, &abort) else {
            return false;
        };
        // A restart that came while the last rows were traced: its frame would be thrown
        // away, and filtering it would hold the new view's first frame back.
        if run.aborted(shared) {
            return false;
        }
        let temporal = job.mode == Mode::Atrous && acc.frames() <= TEMPORAL_FRAMES;
        let filtered = match lock(&shared.temporal).as_mut() {
            Some(history) if temporal => acc.filtered_temporal(history, rs),
            _ => acc.filtered(job.mode),
        };
        let Some(filtered) = filtered else {
            return false;
        };
        frame += 1;
        let n = (job.width * job.height) as u64;
        let mut p = lock(&shared.pending);
        if p.buffer.epoch != run.epoch {
            return false;
        }
        p.buffer.frame = Some(filtered);
        p.stats.samples += n;
        p.stats.rays += rays;
        run.samples.fetch_add(n, Ordering::SeqCst);
    }
}
