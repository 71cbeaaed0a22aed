//! The protocol's unit tests: round trips of every message with edge values and the field
//! tables' consistency (`round_trip`), refusal of truncated, garbage and invalid input
//! (`refusals`). Shared fixtures here.

use glam::Vec3;

use super::*;
use crate::streams::Sample;

mod edits;
mod integrators;
mod refusals;
mod round_trip;

pub(super) fn camera() -> WireCamera {
    WireCamera {
        origin: Vec3::new(0.0, 0.5, 3.9),
        target: Vec3::ZERO,
        up: Vec3::Y,
        fov: 39.3,
    }
}

pub(super) fn hello(name: &str) -> Hello {
    Hello {
        width: 640,
        height: 480,
        triangles: 36,
        threads: 2,
        integrator: Integrator::Light,
        mode: Mode::Progressive,
        epoch: 3,
        camera: camera(),
        name: name.into(),
    }
}

/// A pick answer with every field non-zero.
pub(super) fn picked() -> Pick {
    Pick {
        request: 5,
        uv: [0.25, 0.75],
        hit: PickHit {
            target: PickTarget::Object,
            has_color: true,
            index: 3,
            mesh: 4,
            material: 2,
            position: Vec3::new(0.5, 1.0, -1.5),
            point: Vec3::new(0.25, 0.5, -1.0),
            color: Vec3::new(0.75, 0.5, 0.25),
            emission: Vec3::new(1.0, 2.0, 4.0),
            name: "sphere · red".into(),
        },
    }
}

/// One message of every type with every field non-zero, for the table checks.
pub(super) fn one_of_each() -> Vec<Vec<u8>> {
    let far = WireCamera {
        target: Vec3::new(0.0, 0.75, -0.5),
        ..camera()
    };
    let s = Sample {
        uv: [0.5, 0.25],
        xyzw: [1.0, 2.0, 3.0, 1.0],
    };
    vec![
        Hello {
            mode: Mode::Guided,
            camera: far,
            ..hello("cornell")
        }
        .write(),
        CameraUpdate {
            epoch: 7,
            camera: far,
        }
        .write(),
        Params {
            integrator: Integrator::Both,
            mode: Mode::Atrous,
        }
        .write(),
        Animate {
            playing: true,
            time: 0.5,
            duration: 2.0,
        }
        .write(),
        picked().write(),
        Edit {
            op: EditOp::BaseColor,
            index: 2,
            value: Vec3::new(0.25, 0.5, 0.75),
        }
        .write(),
        SampleBatch {
            epoch: 9,
            stream: Stream::Light,
            light_paths: 4,
        }
        .write(&[s, s]),
        Frame {
            epoch: 6,
            width: 2,
            height: 1,
            mode: Mode::Atrous,
            frames: 8,
        }
        .write(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
        Stats {
            epoch: 4,
            viewers: 2,
            samples: 1 << 40,
            light_paths: 12,
            rate: 1.5e6,
            dropped: 9,
        }
        .write(),
        Finish {
            epoch: 5,
            aborted: true,
            samples: 100,
            light_paths: 3,
            seconds: 0.25,
        }
        .write(),
        ProtocolError::new(ErrorCode::InvalidValue, "nope").write(),
    ]
}
