//! Round trips of the worker messages and their refusals.

use glam::Vec3;
use lumo_render::{PathSettings, PpmSettings};

use super::*;
use crate::protocol::{ErrorCode, Integrator, Mode, WireCamera};

#[test]
fn worker_messages_round_trip() {
    let hello = WorkerHello {
        protocol: WORKER_PROTOCOL,
        token: "ab".repeat(16),
        version: LUMO_VERSION.into(),
        name: "node-ä".into(),
    };
    assert_eq!(WorkerHello::read(&hello.write()), Ok(hello));
    let welcome = Welcome {
        worker: 3,
        seed: 77,
        width: 32,
        height: 24,
        path: PathSettings {
            max_depth: 4,
            spectral: true,
            ..Default::default()
        },
        animate: true,
        ppm: PpmSettings {
            max_photons: 1000,
            ..Default::default()
        },
        scene: SceneSource {
            kind: SceneKind::File,
            spec: "/shared/scenes/a b.xml".into(),
            defines: vec![("spp".into(), "4".into()), ("x".into(), "a=b".into())],
        },
    };
    let back = Welcome::read(&welcome.write().expect("fits")).expect("reads");
    assert_eq!(back.scene, welcome.scene);
    assert_eq!(
        (back.worker, back.seed, back.width, back.height),
        (3, 77, 32, 24)
    );
    assert!(back.animate && back.path.spectral && back.path.max_depth == 4);
    assert_eq!(back.ppm.max_photons, 1000);
    let epoch = EpochUpdate {
        epoch: 9,
        camera: WireCamera {
            origin: Vec3::new(1.0, 2.0, 3.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov: 35.0,
        },
        integrator: Integrator::Bdpt,
        mode: Mode::Progressive,
        rendering: true,
        time: Some(0.5),
    };
    assert_eq!(EpochUpdate::read(&epoch.write()), Ok(epoch));
    let still = EpochUpdate {
        time: None,
        ..epoch
    };
    assert_eq!(EpochUpdate::read(&still.write()), Ok(still));
    let status = WorkerStatus {
        state: WorkerState::SceneFailed,
        threads: 0,
        message: "cannot read /x".into(),
    };
    assert_eq!(WorkerStatus::read(&status.write()), Ok(status));
}

#[test]
fn bad_worker_messages_are_refused() {
    let hello = WorkerHello {
        protocol: WORKER_PROTOCOL,
        token: "00".repeat(16),
        version: LUMO_VERSION.into(),
        name: String::new(),
    };
    let e = WorkerHello::read(&hello.write()).expect_err("empty name");
    assert_eq!(e.code, ErrorCode::InvalidValue);
    let mut msg = WorkerHello {
        name: "w".into(),
        ..hello
    }
    .write();
    msg.push(0);
    assert_eq!(
        WorkerHello::read(&msg).expect_err("trailing").code,
        ErrorCode::Malformed
    );
    assert!(WorkerHello::read(&msg[..50]).is_err());
    let long = Welcome {
        worker: 1,
        seed: 1,
        width: 1,
        height: 1,
        path: PathSettings::default(),
        animate: false,
        ppm: PpmSettings::default(),
        scene: SceneSource {
            kind: SceneKind::File,
            spec: "/".repeat(MAX_SCENE_TEXT + 1),
            defines: Vec::new(),
        },
    };
    assert_eq!(
        long.write().expect_err("too long").code,
        ErrorCode::TooLarge
    );
    let mut status = WorkerStatus {
        state: WorkerState::Ready,
        threads: 1,
        message: String::new(),
    }
    .write();
    status[4] = 9;
    assert_eq!(
        WorkerStatus::read(&status).expect_err("state").code,
        ErrorCode::InvalidValue
    );
}

#[test]
fn frames_carry_their_length_and_refuse_oversized_ones() {
    let mut buf = Vec::new();
    framing::write_frame(&mut buf, &[1, 1, 0, 0, 5]).expect("write");
    let mut r = &buf[..];
    assert_eq!(
        framing::read_frame(&mut r, 16).expect("read"),
        Some(vec![1, 1, 0, 0, 5])
    );
    assert!(framing::read_frame(&mut r, 16).expect("eof").is_none());
    let mut r = &buf[..];
    assert!(matches!(
        framing::read_frame(&mut r, 4),
        Err(framing::FrameError::Length { len: 5, max: 4 })
    ));
    let mut r: &[u8] = b"GET / HTTP/1.1\r\n";
    assert!(framing::read_frame(&mut r, 1 << 20).is_err());
}
