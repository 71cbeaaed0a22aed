//! PICK and EDIT: round trips, and refusal of edits a viewer must not be able to make.

use glam::Vec3;

use super::super::client::{decode_server, ServerMessage};
use super::super::*;
use super::picked;

#[test]
fn pick_round_trips_both_ways() {
    let answer = picked();
    assert_eq!(Pick::read(&answer.write()), Ok(answer.clone()));
    assert_eq!(
        decode_server(&answer.write()),
        Ok(ServerMessage::Pick(answer.clone()))
    );
    let request = Pick {
        request: 1,
        uv: [0.0, 1.0],
        hit: PickHit::nothing(),
    };
    assert_eq!(
        decode_client(&request.write()),
        Ok(ClientMessage::Pick(request))
    );
    // A long name is cut to the limit at a character boundary, as HELLO's.
    let mut long = picked();
    long.hit.name = "é".repeat(150);
    let Ok(back) = Pick::read(&long.write()) else {
        panic!("a long name still decodes");
    };
    assert_eq!(back.hit.name, "é".repeat(100));
}

#[test]
fn picks_outside_the_image_are_refused() {
    for uv in [
        [-0.01, 0.5],
        [0.5, 1.01],
        [f32::NAN, 0.5],
        [0.5, f32::INFINITY],
    ] {
        let p = Pick {
            request: 1,
            uv,
            hit: PickHit::nothing(),
        };
        let e = decode_client(&p.write()).expect_err("refused");
        assert_eq!(e.code, ErrorCode::InvalidValue, "{uv:?}: {}", e.message);
    }
    let mut bad_target = picked().write();
    bad_target[16] = 9;
    assert_eq!(
        decode_client(&bad_target).map_err(|e| e.code),
        Err(ErrorCode::InvalidValue)
    );
}

#[test]
fn edits_round_trip_for_every_op() {
    for &op in EditOp::ALL {
        let value = match op {
            EditOp::MoveInstance | EditOp::MoveLight => Vec3::new(-1e6, 0.5, 1e6),
            EditOp::LightIntensity | EditOp::Emission => Vec3::new(0.0, 17.0, 1e6),
            EditOp::BaseColor => Vec3::new(0.0, 0.5, 1.0),
        };
        let e = Edit {
            op,
            index: 7,
            value,
        };
        assert_eq!(Edit::read(&e.write()), Ok(e));
        assert_eq!(decode_client(&e.write()), Ok(ClientMessage::Edit(e)));
        assert_eq!(decode_server(&e.write()), Ok(ServerMessage::Edit(e)));
    }
}

#[test]
fn bad_edits_are_refused_with_a_reason() {
    let refused = |op, value: Vec3| {
        let e = Edit {
            op,
            index: 0,
            value,
        };
        let err = decode_client(&e.write()).expect_err("refused");
        assert_eq!(err.code, ErrorCode::InvalidValue, "{op:?} {value}");
        err.message
    };
    assert!(refused(EditOp::MoveInstance, Vec3::new(f32::NAN, 0.0, 0.0)).contains("not finite"));
    assert!(refused(EditOp::MoveLight, Vec3::new(0.0, f32::INFINITY, 0.0)).contains("not finite"));
    assert!(refused(EditOp::MoveInstance, Vec3::new(0.0, 0.0, -2e6)).contains("beyond"));
    assert!(refused(EditOp::LightIntensity, Vec3::new(-1.0, 0.0, 0.0)).contains("outside"));
    assert!(refused(EditOp::Emission, Vec3::new(0.0, 2e6, 0.0)).contains("outside"));
    assert!(refused(EditOp::BaseColor, Vec3::new(0.5, 1.5, 0.5)).contains("outside 0..=1"));
    assert!(refused(EditOp::BaseColor, Vec3::new(0.5, -0.1, 0.5)).contains("outside 0..=1"));
    let mut e = Edit {
        op: EditOp::BaseColor,
        index: 0,
        value: Vec3::splat(0.5),
    }
    .write();
    // An unknown op, a short message, trailing bytes.
    e[4] = 99;
    let err = decode_client(&e).expect_err("refused");
    assert_eq!(
        (err.code, err.message.as_str()),
        (ErrorCode::InvalidValue, "edit op 99")
    );
    e[4] = EditOp::MoveInstance.code();
    assert_eq!(
        decode_client(&e[..20]).map_err(|e| e.code),
        Err(ErrorCode::Malformed)
    );
    e.push(0);
    assert_eq!(
        decode_client(&e).map_err(|e| e.code),
        Err(ErrorCode::Malformed)
    );
}
