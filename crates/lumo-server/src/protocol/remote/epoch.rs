//! EPOCH (0x22, hub → worker): the state of the hub's current render — its epoch, camera,
//! integrator, mode and animation time — sent at every restart (and after WELCOME). Only the
//! newest matters: a worker that reads slowly gets the latest one, after the EDITs applied
//! before it.

use super::super::camera::{CameraFields, WireCamera};
use super::super::enums::{Integrator, Mode};
use super::super::error::{ErrorCode, ProtocolError};
use super::super::layout::{Direction, Field, FieldType, Layout, Reader, Writer};
use super::super::read_message;
use super::kind;

const CAMERA: CameraFields = CameraFields::at(4, "the epoch; samples of this state carry it");
const INTEGRATOR: Field = Field::one(
    "integrator",
    48,
    FieldType::Enum(&Integrator::WIRE),
    "integrator",
);
const MODE: Field = Field::one("mode", 49, FieldType::Enum(&Mode::WIRE), "mode");
const RENDERING: Field = Field::one(
    "rendering",
    50,
    FieldType::Bool,
    "1: render samples of this epoch; 0: stop (no viewer watches, or a filtered-frame mode)",
);
const ANIMATED: Field = Field::one("animated", 51, FieldType::Bool, "`time` is a pose");
const TIME: Field = Field::one(
    "time",
    52,
    FieldType::F32,
    "animation time in seconds to pose the scene at",
);

/// The hub's current render, as workers reproduce it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EpochUpdate {
    /// The hub's epoch; a worker tags its samples with it.
    pub epoch: u32,
    /// The camera.
    pub camera: WireCamera,
    /// Integrator.
    pub integrator: Integrator,
    /// Mode (workers render only in the progressive mode).
    pub mode: Mode,
    /// False while the hub does not want samples (no viewer, or a filtered-frame mode).
    pub rendering: bool,
    /// The animation time to pose the scene at, if the scene is animated.
    pub time: Option<f32>,
}

impl EpochUpdate {
    /// Field table of EPOCH.
    pub const LAYOUT: Layout = Layout::message(
        "EPOCH",
        kind::EPOCH,
        Direction::ToWorker,
        &[
            CAMERA.epoch,
            CAMERA.origin,
            CAMERA.target,
            CAMERA.up,
            CAMERA.fov,
            INTEGRATOR,
            MODE,
            RENDERING,
            ANIMATED,
            TIME,
        ],
    );

    /// Encodes it.
    pub fn write(&self) -> Vec<u8> {
        let mut w = Writer::new(&Self::LAYOUT, 0);
        CAMERA.write(&mut w, self.epoch, &self.camera);
        w.put(&INTEGRATOR, self.integrator.code());
        w.put(&MODE, self.mode.code());
        w.put(&RENDERING, self.rendering as u8);
        w.put(&ANIMATED, self.time.is_some() as u8);
        w.put(&TIME, self.time.unwrap_or(0.0));
        w.finish()
    }

    /// Decodes a whole message. The camera is the hub's as it renders it (the scene's own at
    /// first, which a viewer's checks need not pass), so it is not checked here.
    pub fn read(msg: &[u8]) -> Result<Self, ProtocolError> {
        read_message(msg, &Self::LAYOUT, Self::decode)
    }

    fn decode(r: &Reader) -> Result<Self, ProtocolError> {
        let bad = |m: String| ProtocolError::new(ErrorCode::InvalidValue, m);
        let (epoch, camera) = CAMERA.read(r)?;
        let i = r.get::<u8>(&INTEGRATOR)?;
        let m = r.get::<u8>(&MODE)?;
        let time: f32 = r.get(&TIME)?;
        let animated = r.get::<u8>(&ANIMATED)? != 0;
        if animated && !time.is_finite() {
            return Err(bad(format!("animation time {time}")));
        }
        Ok(Self {
            epoch,
            camera,
            integrator: Integrator::from_code(i).ok_or_else(|| bad(format!("integrator {i}")))?,
            mode: Mode::from_code(m).ok_or_else(|| bad(format!("mode {m}")))?,
            rendering: r.get::<u8>(&RENDERING)? != 0,
            time: animated.then_some(time),
        })
    }
}
