//! The sample streams' bits, pinned: one render thread (batches in order, so the streams are a
//! function of the job alone) and a checksum of every sample of every stream, for each wire
//! integrator mode, under spectral transport and through a thin lens (the splatting modes fall
//! back to camera samples). A change to how the server reaches the integrators must leave these
//! checksums as they are; one that changes what the integrators compute changes them on purpose.

use std::sync::{mpsc, Arc};
use std::time::Duration;

use lumo_render::{PathSettings, RenderScene};
use lumo_scene::{builtin_scene, Lens};
use lumo_server::protocol::{Integrator, Mode};
use lumo_server::worker::{Job, QueryBuffer, RenderWorker};

/// FNV-1a over the bits of a stream's samples and its light-path count.
fn checksum(buf: &QueryBuffer) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |bits: u32| {
        for b in bits.to_le_bytes() {
            h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    };
    for s in buf.camera.iter().chain(&buf.light) {
        s.uv.iter().chain(&s.xyzw).for_each(|v| eat(v.to_bits()));
    }
    eat(buf.camera.len() as u32);
    eat(buf.light.len() as u32);
    eat(buf.light_paths as u32);
    h
}

/// The streams of four batches of a 24×20 Cornell box with one render thread.
fn stream(integrator: Integrator, spectral: bool, thin_lens: bool) -> QueryBuffer {
    let mut scene = builtin_scene("cornell").expect("builtin");
    if thin_lens {
        scene.camera.lens = Lens::Thin {
            aperture_radius: 0.05,
            focus_distance: 3.0,
        };
    }
    let rs = Arc::new(RenderScene::new(scene).expect("scene"));
    let (tx, rx) = mpsc::channel();
    let tx = std::sync::Mutex::new(tx);
    let w = RenderWorker::new(
        rs.clone(),
        1,
        Box::new(move |e| {
            let _ = tx.lock().map(|t| t.send(e));
        }),
    )
    .expect("worker");
    let epoch = w.render(Job {
        camera: rs.scene.camera.clone(),
        width: 24,
        height: 20,
        integrator,
        mode: Mode::Progressive,
        path: PathSettings {
            max_depth: 5,
            spectral,
            ..Default::default()
        },
        seed: 3,
        max_batches: Some(4),
        max_rate: None,
        ppm: Default::default(),
    });
    let done = rx.recv_timeout(Duration::from_secs(60)).expect("finish");
    assert!(done.epoch == epoch && !done.aborted, "{integrator:?}");
    let mut buf = QueryBuffer::default();
    w.query(&mut buf);
    assert!(
        !buf.camera.is_empty() || !buf.light.is_empty(),
        "{integrator:?}"
    );
    buf
}

/// Checksums recorded with the server as it was before the integrators' streams moved behind
/// lumo-render's table (issue 51).
#[test]
fn every_integrators_stream_keeps_its_bits() {
    let cases = [
        (Integrator::Path, false, false, 0xb5576e2f06a76205u64),
        (Integrator::Light, false, false, 0xfe12ca9384be5aa7),
        (Integrator::Both, false, false, 0x3486cf16a7fa4d10),
        (Integrator::Bdpt, false, false, 0xbdbf0d8aee00ebdf),
        (Integrator::Ppm, false, false, 0x6cbc847b54a97f71),
        (Integrator::Path, true, false, 0x7b3d0fbb24f32308),
        (Integrator::Light, true, false, 0x474d38f41f85a4a0),
        (Integrator::Both, true, false, 0x4cf58728292b75ac),
        (Integrator::Light, false, true, 0xdcc92f8d507c1fa4),
        (Integrator::Bdpt, false, true, 0xdcc92f8d507c1fa4),
    ];
    let mut wrong = Vec::new();
    for (integrator, spectral, thin_lens, want) in cases {
        let got = checksum(&stream(integrator, spectral, thin_lens));
        if got != want {
            wrong.push(format!(
                "{integrator:?} spectral {spectral} thin lens {thin_lens}: {got:#018x}, \
                 recorded {want:#018x}"
            ));
        }
    }
    assert!(wrong.is_empty(), "streams changed:\n{}", wrong.join("\n"));
}
