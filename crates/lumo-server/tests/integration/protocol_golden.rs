//! Golden byte files of every wire message (tests/data/protocol/), shared with the viewer's
//! decoder: this test checks that the Rust encoder still writes exactly those bytes and that the
//! Rust decoders read them back; `web/tests/protocol_golden.test.mjs` (plain node, run by
//! `.ci/run`) decodes the same files with `web/protocol.js` and compares every field with the
//! `.json` file beside each one, and encodes the client messages byte for byte. A change to
//! the format on one side only fails one of the two.
//!
//! After an intended format change: `LUMO_BLESS=1 cargo test -p lumo-server --test
//! protocol_golden` rewrites the files (the field tables in crates/lumo-server/src/protocol/ drive web/protocol.js and the docs'
//! tables through `protocol_layout`).

use std::path::PathBuf;

use glam::Vec3;
use lumo_server::protocol::client::{decode_server, ServerMessage};
use lumo_server::protocol::{
    decode_client, Animate, CameraUpdate, ClientMessage, Edit, EditOp, ErrorCode, ErrorReply,
    Finish, Frame, Hello, Integrator, Mode, Params, Pick, PickHit, PickTarget, ProtocolError,
    SampleBatch, Stats, Stream, WireCamera,
};
use lumo_server::streams::Sample;

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/protocol")
}

fn camera() -> WireCamera {
    WireCamera {
        origin: Vec3::new(0.0, 1.0, 3.5),
        target: Vec3::new(0.0, 0.75, -0.5),
        up: Vec3::Y,
        fov: 39.25,
    }
}

/// The camera as the viewer's decoder returns it.
fn camera_json(c: &WireCamera) -> String {
    let v = |v: Vec3| format!("[{}, {}, {}]", v.x, v.y, v.z);
    format!(
        r#"{{"origin": {}, "target": {}, "up": {}, "fov": {}}}"#,
        v(c.origin),
        v(c.target),
        v(c.up),
        c.fov
    )
}

/// Compares `bytes` with the golden file `name.bin` (and `json` with `name.json`), or writes
/// both when blessing.
fn golden(name: &str, bytes: &[u8], json: &str) {
    let (bin_path, json_path) = (
        dir().join(format!("{name}.bin")),
        dir().join(format!("{name}.json")),
    );
    let json = format!("{json}\n");
    if std::env::var_os("LUMO_BLESS").is_some() {
        std::fs::create_dir_all(dir()).unwrap();
        std::fs::write(&bin_path, bytes).unwrap();
        std::fs::write(&json_path, &json).unwrap();
        return;
    }
    let stored = std::fs::read(&bin_path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (LUMO_BLESS=1 writes the golden files)",
            bin_path.display()
        )
    });
    assert_eq!(
        stored,
        bytes,
        "{name}: the encoder no longer writes {}",
        bin_path.display()
    );
    let stored_json = std::fs::read_to_string(&json_path).unwrap();
    assert_eq!(stored_json, json, "{}", json_path.display());
}

#[test]
fn server_messages_match_their_golden_files_and_decode() {
    let hello = Hello {
        width: 512,
        height: 384,
        triangles: 36,
        threads: 2,
        integrator: Integrator::Light,
        mode: Mode::Guided,
        epoch: 7,
        camera: camera(),
        name: "cornell".into(),
    };
    let bytes = hello.write();
    assert_eq!(
        decode_server(&bytes),
        Ok(ServerMessage::Hello(hello.clone()))
    );
    golden(
        "hello",
        &bytes,
        &format!(
            r#"{{"kind": 1, "width": 512, "height": 384, "triangles": 36, "threads": 2, "integrator": "light", "mode": "guided", "epoch": 7, "camera": {}, "name": "cornell"}}"#,
            camera_json(&hello.camera)
        ),
    );

    let update = CameraUpdate {
        epoch: 9,
        camera: camera(),
    };
    let bytes = update.write();
    assert_eq!(decode_server(&bytes), Ok(ServerMessage::Camera(update)));
    golden(
        "camera",
        &bytes,
        &format!(
            r#"{{"kind": 2, "epoch": 9, "camera": {}}}"#,
            camera_json(&camera())
        ),
    );

    let params = Params {
        integrator: Integrator::Both,
        mode: Mode::Atrous,
    };
    let bytes = params.write();
    assert_eq!(decode_server(&bytes), Ok(ServerMessage::Params(params)));
    golden(
        "params",
        &bytes,
        r#"{"kind": 3, "integrator": "both", "mode": "atrous"}"#,
    );

    let animate = Animate {
        playing: true,
        time: 1.25,
        duration: 2.0,
    };
    let bytes = animate.write();
    assert_eq!(decode_server(&bytes), Ok(ServerMessage::Animate(animate)));
    golden(
        "animate",
        &bytes,
        r#"{"kind": 4, "playing": true, "time": 1.25, "duration": 2}"#,
    );

    let pick = Pick {
        request: 3,
        uv: [0.25, 0.75],
        hit: PickHit {
            target: PickTarget::Object,
            has_color: true,
            index: 4,
            mesh: 5,
            material: 2,
            position: Vec3::new(0.5, 0.0, -1.0),
            point: Vec3::new(0.25, 0.5, -0.75),
            color: Vec3::new(0.75, 0.5, 0.25),
            emission: Vec3::new(0.0, 1.5, 3.0),
            name: "sphere · red".into(),
        },
    };
    let bytes = pick.write();
    assert_eq!(decode_server(&bytes), Ok(ServerMessage::Pick(pick)));
    golden(
        "pick",
        &bytes,
        r#"{"kind": 5, "request": 3, "uv": [0.25, 0.75], "target": "object", "hasColor": true, "index": 4, "mesh": 5, "material": 2, "position": [0.5, 0, -1], "point": [0.25, 0.5, -0.75], "color": [0.75, 0.5, 0.25], "emission": [0, 1.5, 3], "name": "sphere · red"}"#,
    );

    let edit = Edit {
        op: EditOp::MoveInstance,
        index: 6,
        value: Vec3::new(1.5, -2.0, 0.25),
    };
    let bytes = edit.write();
    assert_eq!(decode_server(&bytes), Ok(ServerMessage::Edit(edit)));
    golden(
        "edit",
        &bytes,
        r#"{"kind": 6, "op": "moveInstance", "index": 6, "value": [1.5, -2, 0.25]}"#,
    );

    let batch = SampleBatch {
        epoch: 11,
        stream: Stream::Light,
        light_paths: 5,
    };
    let samples = [
        Sample {
            uv: [0.25, 0.75],
            xyzw: [1.0, 0.5, 0.25, 1.0],
        },
        Sample {
            uv: [1.0, 0.0],
            xyzw: [2.0, 3.0, 4.0, 0.5],
        },
    ];
    let bytes = batch.write(&samples);
    match decode_server(&bytes) {
        Ok(ServerMessage::Samples(b, s)) => {
            assert_eq!(b, batch);
            assert_eq!(s[1], samples[1]);
            assert!((s[0].uv[0] - 0.25).abs() < 1e-4 && s[0].xyzw == samples[0].xyzw);
        }
        other => panic!("samples decoded as {other:?}"),
    }
    golden(
        "samples",
        &bytes,
        r#"{"kind": 16, "epoch": 11, "stream": 1, "count": 2, "lightPaths": 5}"#,
    );

    let frame = Frame {
        epoch: 12,
        width: 2,
        height: 1,
        mode: Mode::Guided,
        frames: 30,
    };
    let bytes = frame.write(&[0.5, 1.0, 2.0, 4.0, 8.0, 16.0]);
    assert_eq!(
        decode_server(&bytes),
        Ok(ServerMessage::Frame(
            frame,
            vec![[0.5, 1.0, 2.0, 1.0], [4.0, 8.0, 16.0, 1.0]]
        ))
    );
    golden(
        "frame",
        &bytes,
        r#"{"kind": 17, "epoch": 12, "width": 2, "height": 1, "mode": "guided", "frames": 30}"#,
    );

    let stats = Stats {
        epoch: 13,
        viewers: 3,
        samples: 5_000_000_000,
        light_paths: 12345,
        rate: 1.5e6,
        dropped: 4,
    };
    let bytes = stats.write();
    assert_eq!(decode_server(&bytes), Ok(ServerMessage::Stats(stats)));
    golden(
        "stats",
        &bytes,
        r#"{"kind": 18, "epoch": 13, "viewers": 3, "samples": 5000000000, "lightPaths": 12345, "rate": 1500000, "dropped": 4}"#,
    );

    let finish = Finish {
        epoch: 14,
        aborted: true,
        samples: 262144,
        light_paths: 0,
        seconds: 2.5,
    };
    let bytes = finish.write();
    assert_eq!(decode_server(&bytes), Ok(ServerMessage::Finish(finish)));
    golden(
        "finish",
        &bytes,
        r#"{"kind": 19, "epoch": 14, "aborted": true, "samples": 262144, "seconds": 2.5}"#,
    );

    let err = ProtocolError {
        code: ErrorCode::InvalidValue,
        message: "camera fov 0 is outside (0, 180)".into(),
    };
    let bytes = err.write();
    assert_eq!(
        decode_server(&bytes),
        Ok(ServerMessage::Error(ErrorReply {
            code: 4,
            message: "camera fov 0 is outside (0, 180)".into()
        }))
    );
    golden(
        "error",
        &bytes,
        r#"{"kind": 127, "code": 4, "message": "camera fov 0 is outside (0, 180)"}"#,
    );
}

#[test]
fn client_messages_match_their_golden_files_and_decode() {
    // A viewer's CAMERA: the header, 4 reserved bytes, then origin, target, up and fov as
    // little-endian f32 (docs/protocol.md); the viewer's encodeCamera must write these bytes.
    let c = camera();
    let mut bytes = vec![0x02, 1, 0, 0, 0, 0, 0, 0];
    for v in c
        .origin
        .to_array()
        .into_iter()
        .chain(c.target.to_array())
        .chain(c.up.to_array())
        .chain([c.fov])
    {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    assert_eq!(decode_client(&bytes), Ok(ClientMessage::Camera(c)));
    golden("client_camera", &bytes, &camera_json(&c));

    // PARAMS: the header, integrator, mode and 2 reserved bytes.
    let bytes = vec![0x03, 1, 0, 0, 2, 1, 0, 0];
    assert_eq!(
        decode_client(&bytes),
        Ok(ClientMessage::Params(Params {
            integrator: Integrator::Both,
            mode: Mode::Atrous
        }))
    );
    golden(
        "client_params",
        &bytes,
        r#"{"integrator": "both", "mode": "atrous"}"#,
    );

    // ANIMATE from a viewer: the header, playing, 3 reserved bytes, time and duration (0).
    let mut bytes = vec![0x04, 1, 0, 0, 0, 0, 0, 0];
    bytes.extend_from_slice(&[0; 8]);
    assert_eq!(
        decode_client(&bytes),
        Ok(ClientMessage::Animate(Animate {
            playing: false,
            time: 0.0,
            duration: 0.0
        }))
    );
    golden("client_animate", &bytes, r#"{"playing": false}"#);

    // PICK from a viewer: the header, its request number and the image position; the answer
    // fields and the name length stay 0.
    let mut bytes = vec![0x05, 1, 0, 0, 9, 0, 0, 0];
    bytes.extend_from_slice(&0.5f32.to_le_bytes());
    bytes.extend_from_slice(&0.25f32.to_le_bytes());
    bytes.resize(82, 0);
    assert_eq!(
        decode_client(&bytes),
        Ok(ClientMessage::Pick(Pick {
            request: 9,
            uv: [0.5, 0.25],
            hit: PickHit::nothing()
        }))
    );
    golden(
        "client_pick",
        &bytes,
        r#"{"request": 9, "uv": [0.5, 0.25]}"#,
    );

    // EDIT from a viewer: the header, op, 3 reserved bytes, index and the value.
    let mut bytes = vec![0x06, 1, 0, 0, 4, 0, 0, 0, 2, 0, 0, 0];
    for v in [0.25f32, 0.5, 1.0] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    assert_eq!(
        decode_client(&bytes),
        Ok(ClientMessage::Edit(Edit {
            op: EditOp::BaseColor,
            index: 2,
            value: Vec3::new(0.25, 0.5, 1.0)
        }))
    );
    golden(
        "client_edit",
        &bytes,
        r#"{"op": "baseColor", "index": 2, "value": [0.25, 0.5, 1]}"#,
    );
}
