//! The server end to end over real sockets: hello, sample batches, camera restarts seen by
//! every viewer, error replies that keep the connection open, host checks, and viewers that
//! stop reading or vanish without slowing the renderer or the other viewers.

use std::sync::Arc;
use std::time::{Duration, Instant};

use futures_util::{SinkExt, StreamExt};
use lumo_render::RenderScene;
use lumo_scene::builtin_scene;
use lumo_server::protocol::client::{decode_server, ServerMessage};
use lumo_server::protocol::{self, Integrator, Mode, Stream, WireCamera};
use lumo_server::{Hub, ServerConfig};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::{connect_async, MaybeTlsStream, WebSocketStream};

type Ws = WebSocketStream<MaybeTlsStream<TcpStream>>;

async fn start(size: usize, queue: usize) -> (std::net::SocketAddr, Arc<Hub>) {
    start_with_rate(size, queue, None).await
}

async fn start_with_rate(
    size: usize,
    queue: usize,
    max_rate: Option<f64>,
) -> (std::net::SocketAddr, Arc<Hub>) {
    let rs = RenderScene::new(builtin_scene("cornell").expect("builtin")).expect("scene");
    let mut config = ServerConfig::new(size, size);
    config.threads = 2;
    config.viewer_queue_bytes = queue;
    config.max_rate = max_rate;
    let hub = Hub::new(rs, config).expect("hub");
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
        .await
        .expect("bind");
    let addr = listener.local_addr().expect("addr");
    tokio::spawn(lumo_server::serve(listener, hub.clone()));
    (addr, hub)
}

async fn connect(addr: std::net::SocketAddr) -> Ws {
    connect_async(format!("ws://{addr}/ws"))
        .await
        .expect("connect")
        .0
}

/// Next server message, failing the test after 10 s.
async fn next(ws: &mut Ws) -> ServerMessage {
    loop {
        let m = tokio::time::timeout(Duration::from_secs(10), ws.next())
            .await
            .expect("timed out")
            .expect("closed")
            .expect("ws error");
        if let Message::Binary(b) = m {
            return decode_server(&b).expect("decodable");
        }
    }
}

/// Reads until `pred` matches.
async fn until(ws: &mut Ws, mut pred: impl FnMut(&ServerMessage) -> bool) -> ServerMessage {
    loop {
        let m = next(ws).await;
        if pred(&m) {
            return m;
        }
    }
}

async fn send(ws: &mut Ws, bytes: Vec<u8>) {
    ws.send(Message::Binary(bytes.into())).await.expect("send");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hello_samples_and_camera_restart_reach_every_viewer() {
    let (addr, hub) = start(32, 8 << 20).await;
    let mut a = connect(addr).await;
    let mut b = connect(addr).await;
    let ServerMessage::Hello(hello) = next(&mut a).await else {
        panic!("hello first");
    };
    assert_eq!(
        (hello.width, hello.height, hello.name.as_str()),
        (32, 32, "cornell")
    );
    assert_eq!(hello.integrator, Integrator::Path);
    let ServerMessage::Samples(protocol::SampleBatch { epoch, stream, .. }, samples) =
        until(&mut a, |m| matches!(m, ServerMessage::Samples(..))).await
    else {
        unreachable!()
    };
    assert_eq!((epoch, stream), (hello.epoch, Stream::Camera));
    assert!(!samples.is_empty());
    assert!(matches!(next(&mut b).await, ServerMessage::Hello(_)));
    // B moves the camera: both viewers get the new epoch, then only its samples.
    let moved = WireCamera {
        origin: hello.camera.origin + glam::Vec3::new(0.3, 0.2, 0.0),
        ..hello.camera
    };
    send(
        &mut b,
        protocol::CameraUpdate {
            epoch: 0,
            camera: moved,
        }
        .write(),
    )
    .await;
    for ws in [&mut a, &mut b] {
        let ServerMessage::Camera(protocol::CameraUpdate {
            epoch: e,
            camera: c,
        }) = until(ws, |m| matches!(m, ServerMessage::Camera(..))).await
        else {
            unreachable!()
        };
        assert!(e > hello.epoch);
        assert_eq!(c, moved);
        let ServerMessage::Samples(protocol::SampleBatch { epoch, .. }, _) =
            until(ws, |m| matches!(m, ServerMessage::Samples(..))).await
        else {
            unreachable!()
        };
        assert_eq!(epoch, e);
    }
    // Parameters: the light tracer's stream carries the light-path count.
    send(
        &mut a,
        protocol::Params {
            integrator: Integrator::Light,
            mode: Mode::Progressive,
        }
        .write(),
    )
    .await;
    assert_eq!(
        until(&mut a, |m| matches!(m, ServerMessage::Params(..))).await,
        ServerMessage::Params(protocol::Params {
            integrator: Integrator::Light,
            mode: Mode::Progressive,
        })
    );
    let ServerMessage::Samples(
        protocol::SampleBatch {
            stream,
            light_paths,
            ..
        },
        _,
    ) = until(&mut a, |m| {
        matches!(
            m,
            ServerMessage::Samples(
                protocol::SampleBatch {
                    stream: Stream::Light,
                    ..
                },
                _
            )
        )
    })
    .await
    else {
        unreachable!()
    };
    assert_eq!(stream, Stream::Light);
    assert!(light_paths > 0);
    let stats = until(&mut a, |m| matches!(m, ServerMessage::Stats(_))).await;
    let ServerMessage::Stats(s) = stats else {
        unreachable!()
    };
    assert_eq!(s.viewers, 2);
    assert_eq!(hub.viewer_count(), 2);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn malformed_messages_get_errors_and_the_connection_stays_up() {
    let (addr, _hub) = start(16, 8 << 20).await;
    let mut ws = connect(addr).await;
    let is_error = |m: &ServerMessage| matches!(m, ServerMessage::Error(..));
    for (bad, code) in [
        (vec![1u8, 2, 3], 1u16),
        (vec![0x42, protocol::VERSION, 0, 0], 2),
        (vec![protocol::kind::CAMERA, 9, 0, 0], 3),
        (
            vec![protocol::kind::PARAMS, protocol::VERSION, 0, 0, 7, 0, 0, 0],
            4,
        ),
        (vec![0; 2000], 5),
        (vec![protocol::kind::STATS, protocol::VERSION, 0, 0], 7),
    ] {
        send(&mut ws, bad).await;
        let ServerMessage::Error(protocol::ErrorReply {
            code: c,
            message: text,
        }) = until(&mut ws, is_error).await
        else {
            unreachable!()
        };
        assert_eq!(c, code, "{text}");
    }
    ws.send(Message::Text("hello?".into())).await.expect("send");
    let ServerMessage::Error(protocol::ErrorReply { code: c, .. }) = until(&mut ws, is_error).await
    else {
        unreachable!()
    };
    assert_eq!(c, 6);
    // Still connected and served.
    send(
        &mut ws,
        protocol::Params {
            integrator: Integrator::Both,
            mode: Mode::Progressive,
        }
        .write(),
    )
    .await;
    assert_eq!(
        until(&mut ws, |m| matches!(m, ServerMessage::Params(..))).await,
        ServerMessage::Params(protocol::Params {
            integrator: Integrator::Both,
            mode: Mode::Progressive,
        })
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stalled_and_vanished_viewers_do_not_stall_the_renderer_or_others() {
    // A small queue so the stalled viewer overflows quickly, and a rate cap that a reading
    // viewer can always follow, even on a loaded CI machine: the test is about the stalled
    // viewer not hurting the others, not about how fast this test can decode.
    let (addr, hub) = start_with_rate(64, 256 << 10, Some(200_000.0)).await;
    let _stalled = connect(addr).await; // never read
    let vanished = connect(addr).await;
    let mut reader = connect(addr).await;
    drop(vanished);
    let t0 = Instant::now();
    let mut received = 0usize;
    let mut last_samples_at = t0;
    let mut dropped_for_reader = 0;
    while t0.elapsed() < Duration::from_secs(3) {
        match next(&mut reader).await {
            ServerMessage::Samples(_, samples) => {
                received += samples.len();
                last_samples_at = Instant::now();
            }
            ServerMessage::Stats(s) => dropped_for_reader = s.dropped,
            _ => {}
        }
    }
    let rendered = hub.worker().stats().samples;
    eprintln!(
        "3 s with a stalled viewer: rendered {rendered} samples, the reading viewer got {received}"
    );
    assert!(rendered > 10_000, "renderer stalled: {rendered} samples");
    assert!(
        received as u64 * 2 > rendered,
        "reader starved: {received} of {rendered}"
    );
    assert!(last_samples_at.elapsed() < Duration::from_millis(500));
    assert_eq!(dropped_for_reader, 0);
    // The vanished viewer was removed; the stalled one is still counted.
    assert_eq!(hub.viewer_count(), 2);
}

async fn http_get(addr: std::net::SocketAddr, path: &str, host: &str) -> String {
    let mut s = TcpStream::connect(addr).await.expect("connect");
    let req = format!("GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n");
    s.write_all(req.as_bytes()).await.expect("write");
    let mut out = Vec::new();
    s.read_to_end(&mut out).await.expect("read");
    String::from_utf8_lossy(&out).into_owned()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn serves_the_viewer_to_local_hosts_only() {
    let (addr, _hub) = start(16, 8 << 20).await;
    let page = http_get(addr, "/", &addr.to_string()).await;
    assert!(page.starts_with("HTTP/1.1 200"), "{page}");
    assert!(page.contains("main.js"));
    let shader = http_get(addr, "/shaders/display.frag", "localhost").await;
    assert!(shader.contains("1.0 - exp(-pow(u_B * y, u_C))"));
    assert!(http_get(addr, "/nope", "localhost")
        .await
        .starts_with("HTTP/1.1 404"));
    assert!(http_get(addr, "/", "evil.example:8080")
        .await
        .starts_with("HTTP/1.1 403"));
    // A cross-origin page may not open the WebSocket.
    let req = tokio_tungstenite::tungstenite::handshake::client::Request::builder()
        .uri(format!("ws://{addr}/ws"))
        .header("Host", addr.to_string())
        .header("Origin", "http://evil.example")
        .header("Connection", "Upgrade")
        .header("Upgrade", "websocket")
        .header("Sec-WebSocket-Version", "13")
        .header("Sec-WebSocket-Key", "dGhlIHNhbXBsZSBub25jZQ==")
        .body(())
        .expect("request");
    assert!(connect_async(req).await.is_err());
}

/// `lumo serve --animate`: the scene plays as one epoch per pump tick, posed in place by the
/// worker; ANIMATE pauses (the pose freezes, epochs stop) and resumes it for every viewer.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_animated_scene_plays_as_new_epochs_and_pauses() {
    use lumo_server::protocol::Animate;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/animated.gltf");
    let loaded = lumo_scene::load::load_scene(&path, &Default::default()).expect("load");
    let rs = RenderScene::new(loaded.scene).expect("scene");
    let mut config = ServerConfig::new(16, 16);
    config.threads = 2;
    config.animation = loaded.animation;
    let hub = Hub::new(rs, config).expect("hub");
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
        .await
        .expect("bind");
    let addr = listener.local_addr().expect("addr");
    tokio::spawn(lumo_server::serve(listener, hub.clone()));
    let mut ws = connect(addr).await;
    let mut other = connect(addr).await;
    let playing = |want: bool| move |m: &ServerMessage| matches!(m, ServerMessage::Animate(a) if a.playing == want);
    match until(&mut ws, playing(true)).await {
        ServerMessage::Animate(a) => assert_eq!(a.duration, 2.0),
        m => panic!("{m:?}"),
    }
    let sleep = |ms| tokio::time::sleep(Duration::from_millis(ms));
    let (e0, t0) = (hub.epoch(), hub.worker().posed_at());
    sleep(300).await;
    assert!(
        hub.epoch() >= e0 + 5,
        "{e0} → {}: a new epoch per frame",
        hub.epoch()
    );
    assert_ne!(hub.worker().posed_at(), t0, "the worker poses the scene");
    let pause = Animate {
        playing: false,
        time: 0.0,
        duration: 0.0,
    };
    send(&mut ws, pause.write()).await;
    until(&mut ws, playing(false)).await;
    until(&mut other, playing(false)).await;
    sleep(100).await;
    let (e1, t1) = (hub.epoch(), hub.worker().posed_at());
    sleep(300).await;
    assert_eq!(hub.epoch(), e1, "paused: the frame converges, no restarts");
    assert_eq!(hub.worker().posed_at(), t1);
    assert_eq!(
        t1,
        hub.animation().map(|a| a.time),
        "the worker shows the frozen time"
    );
    send(
        &mut other,
        Animate {
            playing: true,
            ..pause
        }
        .write(),
    )
    .await;
    until(&mut ws, playing(true)).await;
    sleep(300).await;
    assert!(hub.epoch() >= e1 + 5, "playing again");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn animate_on_a_static_scene_is_refused() {
    let (addr, _hub) = start(16, 1 << 20).await;
    let mut ws = connect(addr).await;
    let msg = lumo_server::protocol::Animate {
        playing: true,
        time: 0.0,
        duration: 0.0,
    };
    send(&mut ws, msg.write()).await;
    match until(&mut ws, |m| matches!(m, ServerMessage::Error(_))).await {
        ServerMessage::Error(e) => assert!(e.message.contains("not animated"), "{e:?}"),
        m => panic!("{m:?}"),
    }
    // An invalid playing value is refused too.
    let mut bytes = msg.write();
    bytes[4] = 7;
    send(&mut ws, bytes).await;
    match until(&mut ws, |m| matches!(m, ServerMessage::Error(_))).await {
        ServerMessage::Error(e) => assert!(e.message.contains("playing 7"), "{e:?}"),
        m => panic!("{m:?}"),
    }
}

/// A scene with participating media: the light tracer, BDPT and `both` serve it (at start and
/// on a viewer's switch), photon mapping is refused with a message naming what renders it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn media_scenes_take_light_bdpt_and_both_and_refuse_ppm() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data/mitsuba/scenes/media_fog_box.xml");
    let scene = || {
        let loaded = lumo_scene::load::load_scene(&path, &Default::default()).expect("load");
        assert!(loaded.scene.media.is_active());
        RenderScene::new(loaded.scene).expect("scene")
    };
    let config = |integrator| {
        let mut c = ServerConfig::new(16, 16);
        c.threads = 2;
        c.max_rate = Some(50_000.0);
        c.integrator = integrator;
        c
    };
    let why = Hub::new(scene(), config(Integrator::Ppm))
        .err()
        .expect("refused")
        .to_string();
    assert!(why.contains("--integrator bdpt"), "{why}");
    let hub = Hub::new(scene(), config(Integrator::Light)).expect("the light tracer");
    hub.set_params(Integrator::Both, Mode::Progressive)
        .expect("both");
    hub.set_params(Integrator::Bdpt, Mode::Progressive)
        .expect("bdpt");
    let e = hub
        .set_params(Integrator::Ppm, Mode::Progressive)
        .expect_err("refused");
    assert!(
        format!("{e:?}").contains("choose Path, Light, Both or Bdpt"),
        "{e:?}"
    );
}
