//! Measures what remote render workers cost a hub (docs/remote-workers.md, "Cost"): the merge
//! per sample (checking a batch and queueing it for one viewer) and the samples and bytes per
//! second one worker streams over loopback, with one and with two workers. Not a test: it
//! prints numbers.
//!
//! `cargo run --release -p lumo-server --example remote_bench [SECONDS]`

use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use axum::body::Bytes;
use lumo_render::RenderScene;
use lumo_scene::builtin_scene;
use lumo_server::hub::SAMPLES_PER_MESSAGE;
use lumo_server::protocol::remote::{SceneKind, SceneSource};
use lumo_server::protocol::{SampleBatch, Stream};
use lumo_server::remote::{run_remote_worker, serve_workers, RemoteConfig, RemoteWorkerConfig};
use lumo_server::streams::Sample;
use lumo_server::{Hub, ServerConfig};

const TOKEN: &str = "0123456789abcdef0123456789abcdef";

/// A hub of the Cornell box at `size`², its own renderer throttled to a trickle, one viewer
/// queue (no socket: the hub's side of the merge is all that is timed).
fn hub(size: usize) -> std::sync::Arc<Hub> {
    let rs = RenderScene::new(builtin_scene("cornell").expect("builtin")).expect("scene");
    let mut config = ServerConfig::new(size, size);
    config.threads = 1;
    config.max_rate = Some(1.0);
    let scene = SceneSource {
        kind: SceneKind::Builtin,
        spec: "cornell".into(),
        defines: Vec::new(),
    };
    config.remote = Some(RemoteConfig::new(TOKEN.into(), scene));
    let hub = Hub::new(rs, config).expect("hub");
    hub.join().expect("a viewer");
    hub
}

fn merge_cost() {
    let hub = hub(128);
    let samples: Vec<Sample> = (0..SAMPLES_PER_MESSAGE)
        .map(|i| Sample {
            uv: [(i % 128) as f32 / 128.0, (i / 128 % 128) as f32 / 128.0],
            xyzw: [0.2, 0.3, 0.4, 1.0],
        })
        .collect();
    let msg = Bytes::from(
        SampleBatch {
            epoch: hub.epoch() as u32,
            stream: Stream::Camera,
            light_paths: 0,
        }
        .write(&samples),
    );
    // The fastest of five runs of each: the machine is shared, and interference only adds.
    let per_sample = |f: &dyn Fn()| {
        let rounds = 1000;
        (0..5)
            .map(|_| {
                let t = Instant::now();
                for _ in 0..rounds {
                    f();
                }
                t.elapsed().as_secs_f64() * 1e9 / (rounds * SAMPLES_PER_MESSAGE) as f64
            })
            .fold(f64::INFINITY, f64::min)
    };
    let check = per_sample(&|| {
        SampleBatch::check_packed(&msg, SAMPLES_PER_MESSAGE).expect("valid");
    });
    let merge = per_sample(&|| {
        hub.merge_remote(msg.clone()).expect("merged");
    });
    println!(
        "merge: {merge:.2} ns per sample (of which the check {check:.2} ns), batches of \
         {SAMPLES_PER_MESSAGE}, one viewer queue"
    );
}

fn stream_rate(workers: usize, seconds: f64) {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .expect("runtime");
    let hub = hub(128);
    let addr = runtime.block_on(async {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
            .await
            .expect("bind");
        let addr = listener.local_addr().expect("addr");
        tokio::spawn(serve_workers(listener, hub.clone()));
        addr
    });
    let handles: Vec<_> = (0..workers)
        .map(|i| {
            let mut c = RemoteWorkerConfig::new(addr.to_string(), TOKEN, format!("bench-{i}"));
            c.threads = 1;
            let stop = c.stop.clone();
            (stop, std::thread::spawn(move || run_remote_worker(c)))
        })
        .collect();
    // Counted from when every worker is ready.
    while hub.remote_workers().iter().filter(|w| w.ready).count() < workers {
        std::thread::sleep(Duration::from_millis(10));
    }
    let start = hub.remote_workers();
    let t = Instant::now();
    std::thread::sleep(Duration::from_secs_f64(seconds));
    let end = hub.remote_workers();
    let dt = t.elapsed().as_secs_f64();
    for (a, b) in start.iter().zip(&end) {
        println!(
            "{workers} worker(s), {}: {:.0} samples/s, {:.2} MB/s, {:.0} batches/s",
            b.name,
            (b.samples - a.samples) as f64 / dt,
            (b.bytes - a.bytes) as f64 / dt / 1e6,
            (b.batches - a.batches) as f64 / dt
        );
    }
    for (stop, h) in handles {
        stop.store(true, Ordering::SeqCst);
        h.join().expect("thread").expect("worker");
    }
    runtime.shutdown_timeout(Duration::from_secs(1));
}

fn main() {
    let seconds: f64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(10.0);
    merge_cost();
    stream_rate(1, seconds);
    stream_rate(2, seconds);
}
