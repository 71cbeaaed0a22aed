//! Write → read → equal for every message, edge values included, and the field tables'
//! consistency with the writers.

use super::super::client::{decode_server, ServerMessage};
use super::super::layout::{Count, FieldType, Layout, HEADER};
use super::super::*;
use super::{camera, hello, one_of_each};
use crate::streams::Sample;

#[test]
fn field_tables_tile_their_messages() {
    let mut kinds = Vec::new();
    for l in MESSAGES.iter().chain(RECORDS) {
        let start = if l.kind == 0 { 0 } else { HEADER_BYTES };
        let mut at = start;
        for (i, f) in l.fields.iter().enumerate() {
            assert_eq!(f.offset, at, "{}.{}: gap or overlap", l.name, f.name);
            assert!(
                l.fields[..i].iter().all(|g| g.name != f.name),
                "{}.{} twice",
                l.name,
                f.name
            );
            match f.count {
                Count::Fixed(n) => assert!(n > 0, "{}.{}", l.name, f.name),
                Count::Product(_, names) => {
                    assert_eq!(i, l.fields.len() - 1, "{}.{} not last", l.name, f.name);
                    for n in names {
                        assert!(
                            l.fields[..i].iter().any(|g| g.name == *n),
                            "{}.{} counts by unknown {n}",
                            l.name,
                            f.name
                        );
                    }
                }
            }
            at += f.bytes();
        }
        assert_eq!(at, l.bytes, "{}", l.name);
        if l.kind != 0 {
            assert!(
                !kinds.contains(&l.kind),
                "{} reuses type {}",
                l.name,
                l.kind
            );
            kinds.push(l.kind);
        }
    }
    let expected = [
        kind::HELLO,
        kind::CAMERA,
        kind::PARAMS,
        kind::ANIMATE,
        kind::PICK,
        kind::EDIT,
        kind::SAMPLES,
        kind::FRAME,
        kind::STATS,
        kind::FINISH,
        kind::ERROR,
    ];
    assert_eq!(kinds, expected);
    assert_eq!(HEADER.bytes, HEADER_BYTES);
    for e in ENUMS {
        for (i, v) in e.variants.iter().enumerate() {
            assert!(e.variants[..i]
                .iter()
                .all(|w| w.code != v.code && w.name != v.name));
        }
    }
    // The sizes the rest of the crate and the viewer rely on.
    assert_eq!(
        (SAMPLE_BYTES, BATCH_HEADER_BYTES, FRAME_HEADER_BYTES),
        (12, 20, 20)
    );
}

/// Every field of the table is written: in a message whose values are all non-zero, each
/// field holds a non-zero byte and reserved bytes are zero; the header is the table's.
#[test]
fn writers_fill_every_field_of_their_table() {
    for (msg, l) in one_of_each().iter().zip(MESSAGES) {
        assert_eq!((msg[0], msg[1], msg[2], msg[3]), (l.kind, VERSION, 0, 0));
        assert!(msg.len() >= l.bytes, "{}", l.name);
        for f in l.fields {
            let bytes = match f.count {
                Count::Fixed(_) => &msg[f.offset..f.end()],
                Count::Product(..) => &msg[f.offset..],
            };
            if let FieldType::Reserved = f.ty {
                assert!(bytes.iter().all(|&b| b == 0), "{}.{}", l.name, f.name);
            } else {
                assert!(
                    bytes.iter().any(|&b| b != 0),
                    "{}.{} unwritten",
                    l.name,
                    f.name
                );
            }
        }
    }
}

fn round_trip_hello(h: &Hello) -> Hello {
    let Ok(ServerMessage::Hello(back)) = decode_server(&h.write()) else {
        panic!("hello did not decode");
    };
    back
}

#[test]
fn animate_round_trips_and_refuses_bad_values() {
    for playing in [false, true] {
        let a = Animate {
            playing,
            time: 1.75,
            duration: 2.0,
        };
        assert_eq!(Animate::read(&a.write()), Ok(a));
        assert_eq!(decode_client(&a.write()), Ok(ClientMessage::Animate(a)));
    }
    let mut bad = Animate {
        playing: true,
        time: f32::NAN,
        duration: 2.0,
    }
    .write();
    assert_eq!(
        decode_client(&bad).map_err(|e| e.code),
        Err(ErrorCode::InvalidValue)
    );
    bad[4] = 2;
    assert_eq!(
        decode_client(&bad).map_err(|e| e.code),
        Err(ErrorCode::InvalidValue)
    );
    assert_eq!(
        decode_client(&bad[..12]).map_err(|e| e.code),
        Err(ErrorCode::Malformed)
    );
}

#[test]
fn hello_round_trips_with_edge_values() {
    for integrator in Integrator::ALL {
        for mode in Mode::ALL {
            let h = Hello {
                integrator: *integrator,
                mode: *mode,
                ..hello("cornell")
            };
            assert_eq!(Hello::read(&h.write()), Ok(h.clone()));
        }
    }
    // Empty name; largest numbers.
    let h = Hello {
        width: u32::MAX,
        height: u32::MAX,
        triangles: u32::MAX,
        threads: u16::MAX,
        epoch: u32::MAX,
        ..hello("")
    };
    assert_eq!(h.write().len(), Hello::LAYOUT.bytes);
    assert_eq!(round_trip_hello(&h), h);
    // A name of exactly the limit goes whole; a longer one is cut at a character boundary.
    let h = hello(&"n".repeat(MAX_NAME));
    assert_eq!(round_trip_hello(&h), h);
    let long = format!("{}é", "n".repeat(MAX_NAME - 1));
    assert_eq!(
        round_trip_hello(&hello(&long)).name,
        "n".repeat(MAX_NAME - 1)
    );
}

#[test]
fn camera_and_params_round_trip_both_ways() {
    let c = CameraUpdate {
        epoch: u32::MAX,
        camera: camera(),
    };
    assert_eq!(CameraUpdate::read(&c.write()), Ok(c));
    assert_eq!(
        decode_client(&c.write()),
        Ok(ClientMessage::Camera(c.camera))
    );
    // NaN travels bit for bit; the server refuses it from a viewer.
    let nan = CameraUpdate {
        epoch: 1,
        camera: WireCamera {
            fov: f32::NAN,
            ..camera()
        },
    };
    let back = CameraUpdate::read(&nan.write()).unwrap();
    assert_eq!(back.camera.fov.to_bits(), f32::NAN.to_bits());
    assert_eq!(
        decode_client(&nan.write()).map_err(|e| e.code),
        Err(ErrorCode::InvalidValue)
    );
    for integrator in Integrator::ALL {
        for mode in Mode::ALL {
            let p = Params {
                integrator: *integrator,
                mode: *mode,
            };
            assert_eq!(Params::read(&p.write()), Ok(p));
            assert_eq!(decode_client(&p.write()), Ok(ClientMessage::Params(p)));
            assert_eq!(decode_server(&p.write()), Ok(ServerMessage::Params(p)));
        }
    }
}

#[test]
fn counters_round_trip_with_edge_values() {
    for s in [
        Stats {
            epoch: 0,
            viewers: 0,
            samples: 0,
            light_paths: 0,
            rate: 0.0,
            dropped: 0,
        },
        Stats {
            epoch: u32::MAX,
            viewers: u32::MAX,
            samples: u64::MAX,
            light_paths: u64::MAX,
            rate: f32::INFINITY,
            dropped: u32::MAX,
        },
    ] {
        assert_eq!(Stats::read(&s.write()), Ok(s));
        assert_eq!(decode_server(&s.write()), Ok(ServerMessage::Stats(s)));
    }
    let s = Stats {
        epoch: 1,
        viewers: 1,
        samples: 1,
        light_paths: 1,
        rate: f32::NAN,
        dropped: 1,
    };
    assert!(Stats::read(&s.write()).unwrap().rate.is_nan());
    for aborted in [false, true] {
        let f = Finish {
            epoch: u32::MAX,
            aborted,
            samples: u64::MAX,
            light_paths: 0,
            seconds: 0.0,
        };
        assert_eq!(Finish::read(&f.write()), Ok(f));
        assert_eq!(decode_server(&f.write()), Ok(ServerMessage::Finish(f)));
    }
}

#[test]
fn errors_round_trip_and_are_cut_to_the_limit() {
    for code in ErrorCode::ALL {
        let e = ProtocolError::new(*code, "why");
        assert_eq!(
            decode_server(&e.write()),
            Ok(ServerMessage::Error(ErrorReply {
                code: *code as u16,
                message: "why".into()
            }))
        );
    }
    let empty = ErrorReply {
        code: 9,
        message: String::new(),
    };
    assert_eq!(empty.write().len(), ErrorReply::LAYOUT.bytes);
    assert_eq!(ErrorReply::read(&empty.write()), Ok(empty));
    let long = ProtocolError::new(ErrorCode::Malformed, format!("{}€", "x".repeat(399)));
    let back = ErrorReply::read(&long.write()).unwrap();
    assert_eq!(back.message, "x".repeat(399));
    let exact = ProtocolError::new(ErrorCode::Malformed, "y".repeat(MAX_ERROR_TEXT));
    assert_eq!(
        ErrorReply::read(&exact.write()).unwrap().message.len(),
        MAX_ERROR_TEXT
    );
}

#[test]
fn samples_pack_into_twelve_bytes() {
    let batch = SampleBatch {
        epoch: 9,
        stream: Stream::Light,
        light_paths: 5,
    };
    let b = batch.write(&[
        Sample {
            uv: [0.25, 1.0],
            xyzw: [1.5, 0.5, 0.25, 1.0],
        },
        Sample {
            uv: [-1.0, f32::NAN],
            xyzw: [f32::NAN, 1e9, f32::NEG_INFINITY, -2.0],
        },
    ]);
    assert_eq!(b.len(), BATCH_HEADER_BYTES + 2 * SAMPLE_BYTES);
    let Ok(ServerMessage::Samples(back, samples)) = decode_server(&b) else {
        panic!("not a batch");
    };
    assert_eq!(back, batch);
    let s = samples[0];
    assert!((s.uv[0] - 0.25).abs() < 1e-4 && s.uv[1] == 1.0);
    assert_eq!(s.xyzw, [1.5, 0.5, 0.25, 1.0]);
    // Out-of-range positions clamp (NaN to 0); non-finite colours become 0; huge values
    // saturate at the half max.
    assert_eq!(samples[1].uv, [0.0, 0.0]);
    assert_eq!(samples[1].xyzw, [0.0, 65504.0, 0.0, -2.0]);
}

#[test]
fn sample_batches_round_trip_empty_and_large() {
    for stream in Stream::ALL {
        let empty = SampleBatch {
            epoch: 1,
            stream: *stream,
            light_paths: u32::MAX,
        };
        let msg = empty.write(&[]);
        assert_eq!(msg.len(), BATCH_HEADER_BYTES);
        assert_eq!(SampleBatch::read(&msg), Ok((empty, vec![])));
    }
    // Values on the quantisation grids come back exactly.
    let many: Vec<Sample> = (0..20_000u32)
        .map(|i| Sample {
            uv: [(i % 65536) as f32 / 65535.0, 1.0 - (i % 7) as f32 / 65535.0],
            xyzw: [i as f32 / 8.0, 0.5, -65504.0, 1.0],
        })
        .collect();
    let batch = SampleBatch {
        epoch: 2,
        stream: Stream::Camera,
        light_paths: 0,
    };
    let (back, samples) = SampleBatch::read(&batch.write(&many)).unwrap();
    assert_eq!(back, batch);
    assert_eq!(samples.len(), many.len());
    for (a, b) in samples.iter().zip(&many) {
        assert_eq!(a.xyzw[1..], b.xyzw[1..]);
        assert_eq!(a.xyzw[0], half::f16::from_f32(b.xyzw[0]).to_f32());
        for k in 0..2 {
            assert!((a.uv[k] - b.uv[k]).abs() < 1e-6, "{a:?} {b:?}");
        }
    }
}

#[test]
fn frames_round_trip_empty_and_clamped() {
    let f = Frame {
        epoch: 6,
        width: 2,
        height: 1,
        mode: Mode::Atrous,
        frames: 8,
    };
    let msg = f.write(&[1.0, f32::NAN, -3.0, 1e9, f32::INFINITY, 0.5]);
    assert_eq!(msg.len(), FRAME_HEADER_BYTES + 2 * 8);
    assert_eq!(
        Frame::read(&msg),
        Ok((f, vec![[1.0, 0.0, 0.0, 1.0], [65504.0, 0.0, 0.5, 1.0]]))
    );
    for mode in Mode::ALL {
        let empty = Frame {
            epoch: u32::MAX,
            width: 0,
            height: u16::MAX,
            mode: *mode,
            frames: u32::MAX,
        };
        let msg = empty.write(&[]);
        assert_eq!(msg.len(), FRAME_HEADER_BYTES);
        assert_eq!(decode_server(&msg), Ok(ServerMessage::Frame(empty, vec![])));
    }
}

#[test]
fn client_messages_round_trip() {
    let c = camera();
    let msg = CameraUpdate {
        epoch: 7,
        camera: c,
    }
    .write();
    assert_eq!(decode_client(&msg), Ok(ClientMessage::Camera(c)));
}

/// The generated files start from these tables; a layout the generator cannot describe
/// (a record inside a record, say) would show here first.
#[test]
fn generators_describe_every_table() {
    let js = generate::javascript();
    for l in MESSAGES.iter().chain(RECORDS) {
        assert!(js.contains(&format!("  {}: {{", l.name)), "{}", l.name);
        let md = generate::markdown(l);
        let rows = md.lines().filter(|r| r.starts_with("| ")).count();
        assert_eq!(rows, l.fields.len() + 2, "{md}");
    }
    // The worker messages are documented, not sent to the viewer.
    for l in crate::protocol::remote::WORKER_MESSAGES {
        assert!(!js.contains(&format!("  {}: {{", l.name)), "{}", l.name);
        let md = generate::markdown(l);
        let rows = md.lines().filter(|r| r.starts_with("| ")).count();
        assert_eq!(rows, l.fields.len() + 2, "{md}");
    }
    let _: &Layout = &Hello::LAYOUT;
}

/// The docs check replaces stale blocks and names a missing or unknown one, so a message
/// added without its docs block fails the `protocol_layout` test.
#[test]
fn docs_blocks_are_regenerated_and_missing_ones_named() {
    let names: Vec<&str> = RECORDS
        .iter()
        .chain(MESSAGES)
        .chain(crate::protocol::remote::WORKER_MESSAGES)
        .map(|l| l.name)
        .chain(["TYPES", "WORKER_TYPES"])
        .collect();
    let block = |n: &str| format!("<!-- layout {n} -->\nstale\n<!-- /layout -->\n");
    let doc: String = names.iter().map(|n| block(n)).collect();
    let fresh = generate::update_markdown(&doc).unwrap();
    assert!(!fresh.contains("stale"));
    assert!(fresh.contains(&generate::markdown(&Hello::LAYOUT)));
    assert!(fresh.contains(&generate::markdown_types()));
    assert!(fresh.contains(&generate::markdown_worker_types()));
    assert_eq!(generate::update_markdown(&fresh), Ok(fresh.clone()));
    let without_frame = doc.replace(&block("FRAME"), "");
    assert!(generate::update_markdown(&without_frame).is_err_and(|e| e.contains("FRAME")));
    let unknown = format!("{doc}{}", block("NOPE"));
    assert!(generate::update_markdown(&unknown).is_err_and(|e| e.contains("NOPE")));
}
