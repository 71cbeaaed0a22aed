//! Truncated, garbage and invalid input: a typed error with the code and text the viewer
//! sees, never a panic.

use glam::Vec3;

use super::super::client::decode_server;
use super::super::*;
use super::{camera, one_of_each};

/// Every prefix of every message, and every message with a byte changed or appended,
/// decodes to a value or a typed error, never a panic; prefixes are always refused.
#[test]
fn truncated_and_garbage_input_is_an_error_not_a_panic() {
    for msg in one_of_each() {
        for n in 0..msg.len() {
            let short = &msg[..n];
            let e = decode_server(short).expect_err("a prefix decoded");
            assert!(
                matches!(e.code, ErrorCode::Malformed | ErrorCode::UnknownType),
                "{e}"
            );
            let _ = decode_client(short);
        }
        let mut long = msg.clone();
        long.push(1);
        let _ = decode_server(&long);
        let _ = decode_client(&long);
        for i in 0..msg.len().min(80) {
            for b in [0u8, 1, 0x7f, 0xff] {
                let mut m = msg.clone();
                m[i] = b;
                let _ = decode_server(&m);
                let _ = decode_client(&m);
            }
        }
    }
    // Random bytes behind every header, with a small xorshift (no dependency).
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    for l in MESSAGES.iter().map(|l| l.kind).chain([0, 0x55, 0xff]) {
        for _ in 0..500 {
            let len = (next() % 120) as usize;
            let mut m: Vec<u8> = (0..len).map(|_| next() as u8).collect();
            if len >= 2 {
                m[0] = l;
                m[1] = VERSION;
            }
            let _ = decode_server(&m);
            let _ = decode_client(&m);
        }
    }
    // A count that would overflow the expected length is refused.
    let mut m = SampleBatch {
        epoch: 0,
        stream: Stream::Camera,
        light_paths: 0,
    }
    .write(&[]);
    m[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(decode_server(&m).is_err());
}

/// The refusals a viewer sees, with their codes and texts (both travel on the wire).
#[test]
fn malformed_messages_are_refused_with_a_code() {
    let code = |m: &[u8]| decode_client(m).map_err(|e| e.code);
    let text = |m: &[u8]| decode_client(m).map_err(|e| e.message);
    assert_eq!(code(&[]), Err(ErrorCode::Malformed));
    assert_eq!(
        text(&[]),
        Err("0 bytes is shorter than the 4-byte header".into())
    );
    assert_eq!(
        text(&[kind::CAMERA, VERSION, 0, 0, 1]),
        Err("message too short".into())
    );
    assert_eq!(code(&[0x55, VERSION, 0, 0]), Err(ErrorCode::UnknownType));
    assert_eq!(
        text(&[0x55, VERSION, 0, 0]),
        Err("unknown message type 0x55".into())
    );
    for k in [
        kind::HELLO,
        kind::SAMPLES,
        kind::FRAME,
        kind::STATS,
        kind::FINISH,
        kind::ERROR,
    ] {
        assert_eq!(
            text(&[k, VERSION, 0, 0]),
            Err(format!("message type {k:#04x} is sent by the server only"))
        );
    }
    let p = Params {
        integrator: Integrator::Path,
        mode: Mode::Progressive,
    };
    let mut c = CameraUpdate {
        epoch: 0,
        camera: camera(),
    }
    .write();
    c[1] = VERSION + 1;
    assert_eq!(code(&c), Err(ErrorCode::Version));
    assert_eq!(text(&c), Err("protocol version 2 (server speaks 1)".into()));
    let mut long = p.write();
    long.push(0);
    assert_eq!(text(&long), Err("1 unexpected trailing bytes".into()));
    assert_eq!(code(&vec![0; 300]), Err(ErrorCode::TooLarge));
    assert_eq!(text(&vec![0; 300]), Err("300 bytes exceeds 256".into()));
    assert_eq!(
        text(&[kind::PARAMS, VERSION, 0, 0, 9, 0, 0, 0]),
        Err("integrator 9".into())
    );
    assert_eq!(
        text(&[kind::PARAMS, VERSION, 0, 0, 0, 3, 0, 0]),
        Err("mode 3".into())
    );
    // Short beats invalid; invalid beats trailing (the order of the checks is on the wire).
    assert_eq!(
        code(&[kind::PARAMS, VERSION, 0, 0, 9, 0, 0]),
        Err(ErrorCode::Malformed)
    );
    assert_eq!(
        code(&[kind::PARAMS, VERSION, 0, 0, 9, 0, 0, 0, 0]),
        Err(ErrorCode::InvalidValue)
    );
    let mut bad_long = CameraUpdate {
        epoch: 0,
        camera: WireCamera {
            fov: 0.0,
            ..camera()
        },
    }
    .write();
    bad_long.push(0);
    assert_eq!(code(&bad_long), Err(ErrorCode::InvalidValue));
    for bad in [
        WireCamera {
            fov: f32::NAN,
            ..camera()
        },
        WireCamera {
            fov: 0.0,
            ..camera()
        },
        WireCamera {
            target: camera().origin,
            ..camera()
        },
        WireCamera {
            up: Vec3::new(0.0, 0.5, 3.9),
            target: Vec3::ZERO,
            ..camera()
        },
    ] {
        let msg = CameraUpdate {
            epoch: 0,
            camera: bad,
        }
        .write();
        assert_eq!(code(&msg), Err(ErrorCode::InvalidValue));
    }
}

#[test]
fn cameras_are_checked_in_terms_of_what_the_renderer_computes() {
    let why = |c: WireCamera| c.validate().map_err(|e| e.message);
    // The overflow probe: every number finite, their difference not.
    let e = why(WireCamera {
        origin: Vec3::splat(3e38),
        target: Vec3::splat(-3e38),
        ..camera()
    });
    assert!(e.as_ref().is_err_and(|m| m.contains("beyond")), "{e:?}");
    // A far eye beyond the bound is refused for its distance, not as "parallel".
    let e = why(WireCamera {
        origin: Vec3::new(0.0, 0.0, 1e30),
        ..camera()
    });
    assert!(
        e.as_ref()
            .is_err_and(|m| m.contains("origin") && m.contains("beyond")),
        "{e:?}"
    );
    // Far but within it: accepted, and the renderer's basis is finite and orthonormal.
    for far in [1e6f32, 1e15, 9e17] {
        let c = WireCamera {
            origin: Vec3::new(far, 0.5, far),
            ..camera()
        };
        assert_eq!(why(c), Ok(()), "{far}");
        let cam = lumo_scene::Camera {
            origin: c.origin,
            target: c.target,
            up: c.up,
            fov: c.fov,
            fov_axis: lumo_scene::FovAxis::Smaller,
            lens: Default::default(),
            filter: Default::default(),
        };
        let (r, u, f) = cam.basis();
        for v in [r, u, f] {
            assert!(
                v.is_finite() && (v.length() - 1.0).abs() < 1e-3,
                "{far}: {v}"
            );
        }
    }
    // A huge or tiny up hint, or one along the view, cannot make a basis.
    for up in [Vec3::new(0.0, 1e30, 0.0), Vec3::splat(1e-30), Vec3::ZERO] {
        assert!(why(WireCamera { up, ..camera() }).is_err(), "{up}");
    }
    let e = why(WireCamera {
        up: camera().target - camera().origin,
        ..camera()
    });
    assert!(e.is_err_and(|m| m.contains("parallel")));
    // Within the bound, an up of any length works.
    assert_eq!(
        why(WireCamera {
            up: Vec3::new(0.0, 1e-3, 0.0),
            ..camera()
        }),
        Ok(())
    );
}
