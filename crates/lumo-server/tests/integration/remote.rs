//! Remote render workers against a hub on 127.0.0.1: two in-process workers
//! (`run_remote_worker` on threads) feed one viewer and keep feeding it when one stops;
//! camera moves and edits reach them; wrong tokens, other versions, garbage, bad samples and
//! samples of an old or unknown epoch are refused or dropped, with a log line naming the
//! worker, and never reach the viewer. The hub's own render worker is throttled to 200
//! samples/s, so sample counts above that can only have come from the remote workers.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream as StdTcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use futures_util::{SinkExt, StreamExt};
use glam::Vec3;
use lumo_render::RenderScene;
use lumo_scene::builtin_scene;
use lumo_server::protocol::client::{decode_server, ServerMessage};
use lumo_server::protocol::remote::framing::{read_frame, write_frame};
use lumo_server::protocol::remote::{
    kind, EpochUpdate, SceneKind, SceneSource, Welcome, WorkerHello, WorkerState, WorkerStatus,
    LUMO_VERSION, WORKER_PROTOCOL,
};
use lumo_server::protocol::{
    CameraUpdate, Edit, EditOp, ErrorCode, ErrorReply, SampleBatch, Stream, WireCamera,
};
use lumo_server::remote::{
    run_remote_worker, serve_workers, RemoteConfig, RemoteWorkerConfig, RemoteWorkerError,
};
use lumo_server::streams::Sample;
use lumo_server::{Hub, ServerConfig};
use tokio::net::TcpStream;
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::{connect_async, MaybeTlsStream, WebSocketStream};

type Ws = WebSocketStream<MaybeTlsStream<TcpStream>>;

const TOKEN: &str = "00112233445566778899aabbccddeeff";
/// The hub's own render worker's throttle, samples per second.
const LOCAL_RATE: f64 = 200.0;

struct TestHub {
    viewers: SocketAddr,
    workers: SocketAddr,
    hub: Arc<Hub>,
}

fn builtin(name: &str) -> SceneSource {
    SceneSource {
        kind: SceneKind::Builtin,
        spec: name.into(),
        defines: Vec::new(),
    }
}

/// A 32×32 Cornell-box hub with remote workers on, its own renderer throttled.
async fn start_hub(scene: SceneSource) -> TestHub {
    let rs = RenderScene::new(builtin_scene("cornell").expect("builtin")).expect("scene");
    let mut config = ServerConfig::new(32, 32);
    config.threads = 1;
    config.max_rate = Some(LOCAL_RATE);
    let mut remote = RemoteConfig::new(TOKEN.into(), scene);
    remote.hello_timeout = Duration::from_secs(1);
    config.remote = Some(remote);
    let hub = Hub::new(rs, config).expect("hub");
    let viewers = tokio::net::TcpListener::bind("127.0.0.1:0")
        .await
        .expect("bind");
    let workers = tokio::net::TcpListener::bind("127.0.0.1:0")
        .await
        .expect("bind");
    let (va, wa) = (
        viewers.local_addr().expect("addr"),
        workers.local_addr().expect("addr"),
    );
    tokio::spawn(lumo_server::serve(viewers, hub.clone()));
    tokio::spawn(serve_workers(workers, hub.clone()));
    TestHub {
        viewers: va,
        workers: wa,
        hub,
    }
}

async fn connect(addr: SocketAddr) -> Ws {
    connect_async(format!("ws://{addr}/ws"))
        .await
        .expect("connect")
        .0
}

/// Next server message, failing the test after 20 s.
async fn next(ws: &mut Ws) -> ServerMessage {
    loop {
        let m = tokio::time::timeout(Duration::from_secs(20), ws.next())
            .await
            .expect("timed out")
            .expect("closed")
            .expect("ws error");
        if let Message::Binary(b) = m {
            return decode_server(&b).expect("decodable");
        }
    }
}

struct Worker {
    stop: Arc<AtomicBool>,
    thread: std::thread::JoinHandle<Result<(), RemoteWorkerError>>,
}

fn spawn_worker(addr: SocketAddr, token: &str, name: &str) -> Worker {
    let mut config = RemoteWorkerConfig::new(addr.to_string(), token, name);
    config.threads = 1;
    let stop = config.stop.clone();
    let thread = std::thread::spawn(move || run_remote_worker(config));
    Worker { stop, thread }
}

/// Joins a worker's thread off the runtime's threads.
async fn finish(w: Worker) -> Result<(), RemoteWorkerError> {
    w.stop.store(true, Ordering::SeqCst);
    join(w.thread).await
}

async fn join(
    t: std::thread::JoinHandle<Result<(), RemoteWorkerError>>,
) -> Result<(), RemoteWorkerError> {
    tokio::task::spawn_blocking(move || t.join().expect("worker thread panicked"))
        .await
        .expect("join")
}

/// Reads the viewer until `pred(camera samples of epoch, their mean Y)` holds for the samples
/// of `epoch` received since the call, or fails after `limit`.
async fn samples_until(
    ws: &mut Ws,
    epoch: u32,
    limit: Duration,
    mut pred: impl FnMut(u64, f64) -> bool,
) -> (u64, f64) {
    let start = Instant::now();
    let (mut n, mut sum) = (0u64, 0.0f64);
    while start.elapsed() < limit {
        if let ServerMessage::Samples(b, s) = next(ws).await {
            if b.epoch == epoch && b.stream == Stream::Camera {
                n += s.len() as u64;
                sum += s.iter().map(|s| s.xyzw[1] as f64).sum::<f64>();
                if pred(n, sum / n.max(1) as f64) {
                    return (n, sum / n as f64);
                }
            }
        }
    }
    panic!(
        "after {limit:?}: {n} camera samples of epoch {epoch}, mean Y {}",
        sum / n.max(1) as f64
    );
}

/// Camera samples the hub's own worker can have made in `t` (its throttle, plus a batch).
fn local_bound(t: Duration) -> u64 {
    (LOCAL_RATE * t.as_secs_f64()) as u64 + 512
}

async fn wait_for(what: &str, mut cond: impl FnMut() -> bool) {
    let start = Instant::now();
    while !cond() {
        assert!(start.elapsed() < Duration::from_secs(30), "{what}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

fn logged(hub: &Hub, parts: &[&str]) -> bool {
    hub.remote_log()
        .iter()
        .any(|l| parts.iter().all(|p| l.contains(p)))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn remote_workers_feed_the_viewer_follow_its_camera_and_edits_and_one_may_stop() {
    let t = start_hub(builtin("cornell")).await;
    let mut ws = connect(t.viewers).await;
    let ServerMessage::Hello(hello) = next(&mut ws).await else {
        panic!("hello first")
    };
    let a = spawn_worker(t.workers, TOKEN, "alpha");
    let b = spawn_worker(t.workers, TOKEN, "beta");
    let hub = t.hub.clone();
    wait_for("both workers merge samples", || {
        let w = hub.remote_workers();
        w.len() == 2 && w.iter().all(|w| w.samples > 0)
    })
    .await;
    // The viewer gets far more samples than the throttled local worker makes.
    let since = Instant::now();
    let (n, _) = samples_until(&mut ws, hello.epoch, Duration::from_secs(30), |n, _| {
        n > local_bound(since.elapsed()) + 20_000
    })
    .await;
    let names: Vec<String> = hub
        .remote_workers()
        .iter()
        .map(|w| w.name.clone())
        .collect();
    assert!(
        names.contains(&"alpha".into()) && names.contains(&"beta".into()),
        "{names:?}"
    );
    eprintln!("{n} samples from two workers: {:?}", hub.remote_workers());

    // A camera move reaches the workers: the new epoch's samples come from them too.
    let camera = WireCamera {
        origin: Vec3::new(0.0, 1.0, 3.5),
        target: Vec3::new(0.0, 1.0, 0.0),
        up: Vec3::Y,
        fov: 40.0,
    };
    ws.send(Message::Binary(
        CameraUpdate { epoch: 0, camera }.write().into(),
    ))
    .await
    .expect("send");
    let epoch = loop {
        if let ServerMessage::Camera(c) = next(&mut ws).await {
            break c.epoch;
        }
    };
    let since = Instant::now();
    let (_, lit) = samples_until(&mut ws, epoch, Duration::from_secs(30), |n, _| {
        n > local_bound(since.elapsed()) + 20_000
    })
    .await;

    // An edit reaches them: the ceiling light off, their samples turn black.
    let scene = builtin_scene("cornell").expect("builtin");
    let light = scene
        .materials
        .iter()
        .position(|m| m.emission.max_element() > 0.0)
        .expect("a light");
    let off = Edit {
        op: EditOp::Emission,
        index: light as u32,
        value: Vec3::ZERO,
    };
    ws.send(Message::Binary(off.write().into()))
        .await
        .expect("send");
    let epoch = loop {
        if let ServerMessage::Camera(c) = next(&mut ws).await {
            break c.epoch;
        }
    };
    let since = Instant::now();
    let (_, dark) = samples_until(&mut ws, epoch, Duration::from_secs(30), |n, _| {
        n > local_bound(since.elapsed()) + 20_000
    })
    .await;
    assert!(
        lit > 0.01 && dark < 1e-4,
        "mean Y lit {lit}, light off {dark}"
    );

    // One worker stops: samples keep arriving from the other.
    let alpha_id = hub
        .remote_workers()
        .iter()
        .find(|w| w.name == "alpha")
        .expect("alpha")
        .id;
    finish(a).await.expect("alpha stops cleanly");
    wait_for("alpha leaves", || {
        hub.remote_workers().iter().all(|w| w.id != alpha_id)
    })
    .await;
    let before = hub.remote_workers()[0].samples;
    let since = Instant::now();
    samples_until(&mut ws, epoch, Duration::from_secs(30), |n, _| {
        n > local_bound(since.elapsed()) + 10_000
    })
    .await;
    // (Those may have been queued before alpha left; beta's count must still grow.)
    wait_for("beta keeps merging", || {
        let w = hub.remote_workers();
        w.len() == 1 && w[0].name == "beta" && w[0].samples > before
    })
    .await;
    assert!(
        logged(&hub, &["\"alpha\"", "left"]),
        "{:?}",
        hub.remote_log()
    );
    finish(b).await.expect("beta stops cleanly");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_wrong_token_is_refused_naming_the_worker() {
    let t = start_hub(builtin("cornell")).await;
    let w = spawn_worker(t.workers, "ffeeddccbbaa99887766554433221100", "intruder");
    match join(w.thread).await {
        Err(RemoteWorkerError::Refused { name, reason }) => {
            assert!(
                name == "intruder" && reason.contains("wrong token"),
                "{reason}"
            );
        }
        other => panic!("{other:?}"),
    }
    assert!(
        logged(&t.hub, &["\"intruder\"", "wrong token"]),
        "{:?}",
        t.hub.remote_log()
    );
    assert!(t.hub.remote_workers().is_empty());
}

/// A blocking connection speaking the worker protocol by hand.
fn raw(addr: SocketAddr) -> StdTcpStream {
    let s = StdTcpStream::connect(addr).expect("connect");
    s.set_read_timeout(Some(Duration::from_secs(20)))
        .expect("timeout");
    s
}

fn hello(version: &str, protocol: u16, name: &str) -> Vec<u8> {
    WorkerHello {
        protocol,
        token: TOKEN.into(),
        version: version.into(),
        name: name.into(),
    }
    .write()
}

/// The hub's answer as an ERROR, or None when it closed without one.
fn refusal(s: &mut StdTcpStream) -> Option<ErrorReply> {
    match read_frame(s, 1 << 16) {
        Ok(Some(m)) => Some(ErrorReply::read(&m).expect("an ERROR")),
        _ => None,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn another_version_or_protocol_is_refused_naming_the_worker() {
    let t = start_hub(builtin("cornell")).await;
    let addr = t.workers;
    let replies = tokio::task::spawn_blocking(move || {
        [
            ("0.0.0-old", WORKER_PROTOCOL, "old-build"),
            (LUMO_VERSION, 99, "new-protocol"),
        ]
        .map(|(v, p, name)| {
            let mut s = raw(addr);
            write_frame(&mut s, &hello(v, p, name)).expect("send");
            refusal(&mut s)
        })
    })
    .await
    .expect("join");
    for r in &replies {
        let r = r.as_ref().expect("an ERROR before closing");
        assert_eq!(r.code, ErrorCode::Version as u16, "{r:?}");
        assert!(r.message.contains(LUMO_VERSION), "{r:?}");
    }
    let hub = &t.hub;
    assert!(
        logged(hub, &["\"old-build\"", "0.0.0-old"]),
        "{:?}",
        hub.remote_log()
    );
    assert!(
        logged(hub, &["\"new-protocol\"", "protocol 99"]),
        "{:?}",
        hub.remote_log()
    );
    assert!(hub.remote_workers().is_empty());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn garbage_is_refused_and_closes_the_connection() {
    let t = start_hub(builtin("cornell")).await;
    let addr = t.workers;
    let ports = tokio::task::spawn_blocking(move || {
        let mut ports = Vec::new();
        // An HTTP request: its first bytes read as a length of half a gigabyte.
        let mut s = raw(addr);
        ports.push(s.local_addr().expect("addr").port());
        s.write_all(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n")
            .expect("send");
        assert!(refusal(&mut s).is_some());
        // A frame of the right length holding a truncated hello.
        let mut s = raw(addr);
        ports.push(s.local_addr().expect("addr").port());
        write_frame(&mut s, &[kind::WORKER_HELLO, 1, 0, 0, 7, 7]).expect("send");
        assert!(refusal(&mut s).is_some());
        // Silence: the hello deadline (1 s here) closes it.
        let mut s = raw(addr);
        ports.push(s.local_addr().expect("addr").port());
        let mut buf = [0u8; 64];
        let n = loop {
            match s.read(&mut buf) {
                Ok(0) => break 0,
                Ok(n) => break n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => panic!("{e}"),
            }
        };
        assert!(n > 0, "an ERROR before the close");
        ports
    })
    .await
    .expect("join");
    let hub = &t.hub;
    for (port, why) in ports
        .iter()
        .zip(["message length", "too short", "no hello"])
    {
        assert!(
            logged(hub, &[&format!("127.0.0.1:{port}"), "refused", why]),
            "{port} {why}: {:?}",
            hub.remote_log()
        );
    }
    assert!(hub.remote_workers().is_empty());
}

/// A worker by hand through the handshake: returns its socket and the first EPOCH.
fn handshake(addr: SocketAddr, name: &str) -> (StdTcpStream, Welcome, EpochUpdate) {
    let mut s = raw(addr);
    write_frame(&mut s, &hello(LUMO_VERSION, WORKER_PROTOCOL, name)).expect("send");
    let welcome = Welcome::read(&read_frame(&mut s, 1 << 16).expect("read").expect("welcome"))
        .expect("a WELCOME");
    let ready = WorkerStatus {
        state: WorkerState::Ready,
        threads: 1,
        message: String::new(),
    };
    write_frame(&mut s, &ready.write()).expect("send");
    let epoch = next_epoch(&mut s);
    (s, welcome, epoch)
}

/// The next EPOCH the hub sends (edits skipped).
fn next_epoch(s: &mut StdTcpStream) -> EpochUpdate {
    loop {
        let m = read_frame(s, 1 << 16).expect("read").expect("open");
        if m[0] == kind::EPOCH {
            return EpochUpdate::read(&m).expect("an EPOCH");
        }
    }
}

/// `n` camera samples of colour `y` in the middle of the image, as SAMPLES of `epoch`.
fn marked(epoch: u32, y: f32, n: usize) -> Vec<u8> {
    let s = Sample {
        uv: [0.5, 0.5],
        xyzw: [y, y, y, 1.0],
    };
    SampleBatch {
        epoch,
        stream: Stream::Camera,
        light_paths: 0,
    }
    .write(&vec![s; n])
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn samples_of_an_old_epoch_are_dropped_and_of_an_unknown_one_refused() {
    let t = start_hub(builtin("cornell")).await;
    let mut ws = connect(t.viewers).await;
    let ServerMessage::Hello(_) = next(&mut ws).await else {
        panic!("hello first")
    };
    let addr = t.workers;
    let (mut s, welcome, first) = tokio::task::spawn_blocking(move || handshake(addr, "by-hand"))
        .await
        .expect("join");
    assert!(first.rendering, "{first:?}");
    assert_eq!(welcome.width, 32);
    // A camera move: the worker's first epoch is over.
    let camera = first.camera;
    ws.send(Message::Binary(
        CameraUpdate { epoch: 0, camera }.write().into(),
    ))
    .await
    .expect("send");
    let (s2, second) = tokio::task::spawn_blocking(move || {
        let e = next_epoch(&mut s);
        (s, e)
    })
    .await
    .expect("join");
    s = s2;
    assert!(second.epoch > first.epoch);
    // Marked samples: 1000 of the old epoch, then 2000 of the current one.
    write_frame(&mut s, &marked(first.epoch, 1000.0, 64)).expect("send");
    write_frame(&mut s, &marked(second.epoch, 2000.0, 64)).expect("send");
    loop {
        if let ServerMessage::Samples(_, samples) = next(&mut ws).await {
            let y: Vec<f32> = samples.iter().map(|s| s.xyzw[1]).collect();
            assert!(
                !y.contains(&1000.0),
                "a sample of the old epoch reached the viewer"
            );
            if y.contains(&2000.0) {
                break;
            }
        }
    }
    let hub = t.hub.clone();
    let w = hub.remote_workers();
    assert!(
        w.len() == 1 && w[0].old_batches == 1 && w[0].samples == 64,
        "{w:?}"
    );
    assert!(
        logged(&hub, &["\"by-hand\"", "old epoch"]),
        "{:?}",
        hub.remote_log()
    );
    // An epoch the hub has not begun: refused, the worker dropped.
    write_frame(&mut s, &marked(second.epoch + 5, 3000.0, 64)).expect("send");
    wait_for("the worker is dropped", || hub.remote_workers().is_empty()).await;
    assert!(
        logged(&hub, &["\"by-hand\"", "has not begun"]),
        "{:?}",
        hub.remote_log()
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_samples_are_refused_and_nothing_of_them_reaches_the_viewer() {
    let t = start_hub(builtin("cornell")).await;
    let mut ws = connect(t.viewers).await;
    let ServerMessage::Hello(_) = next(&mut ws).await else {
        panic!("hello first")
    };
    let addr = t.workers;
    let hub = t.hub.clone();
    for (name, why) in [
        ("nan-sender", "not finite"),
        ("weight-sender", "weight"),
        ("light-sender", "light"),
    ] {
        let (mut s, _, e) = tokio::task::spawn_blocking(move || handshake(addr, name))
            .await
            .expect("join");
        let mut msg = marked(e.epoch, 4000.0, 64);
        match why {
            // The last sample's Y as a half-float NaN.
            "not finite" => {
                let at = msg.len() - 12 + 6;
                msg[at..at + 2].copy_from_slice(&0x7e00u16.to_le_bytes());
            }
            // Its weight 2.
            "weight" => {
                let at = msg.len() - 2;
                msg[at..at + 2].copy_from_slice(&0x4000u16.to_le_bytes());
            }
            // Light samples under the path tracer.
            _ => msg[8] = Stream::Light.code(),
        }
        write_frame(&mut s, &msg).expect("send");
        wait_for("the worker is dropped", || hub.remote_workers().is_empty()).await;
        assert!(
            logged(&hub, &[&format!("{name:?}"), "refused", why]),
            "{name}: {:?}",
            hub.remote_log()
        );
    }
    // Local samples keep coming and none is marked.
    let start = Instant::now();
    while start.elapsed() < Duration::from_millis(500) {
        if let ServerMessage::Samples(_, samples) = next(&mut ws).await {
            assert!(samples.iter().all(|s| s.xyzw[1] != 4000.0));
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_scene_the_worker_cannot_read_is_reported_to_the_hub() {
    let scene = SceneSource {
        kind: SceneKind::File,
        spec: "/nonexistent/lumo-remote-test/scene.xml".into(),
        defines: vec![("spp".into(), "4".into())],
    };
    let t = start_hub(scene).await;
    let w = spawn_worker(t.workers, TOKEN, "no-share");
    match join(w.thread).await {
        Err(RemoteWorkerError::Scene { name, reason }) => {
            assert!(
                name == "no-share" && reason.contains("cannot read scene file"),
                "{reason}"
            );
        }
        other => panic!("{other:?}"),
    }
    let hub = t.hub.clone();
    wait_for("the hub logs it", || {
        logged(
            &hub,
            &[
                "\"no-share\"",
                "cannot load the scene",
                "/nonexistent/lumo-remote-test",
            ],
        )
    })
    .await;
}
