//! FINISH (0x13, server → viewer): a render ended (budget reached or aborted).

use super::error::ProtocolError;
use super::kind;
use super::layout::{Direction, Field, FieldType, Layout, Reader, Writer};

const EPOCH: Field = Field::one("epoch", 4, FieldType::U32, "epoch");
const ABORTED: Field = Field::one("aborted", 8, FieldType::Bool, "1 if aborted");
const RESERVED: Field = Field::fixed("reserved", 9, FieldType::Reserved, 3, "reserved");
const SAMPLES: Field = Field::one("samples", 12, FieldType::U64, "camera samples rendered");
const LIGHT_PATHS: Field = Field::one("lightPaths", 20, FieldType::U64, "light paths traced");
const SECONDS: Field = Field::one("seconds", 28, FieldType::F32, "seconds it ran");

/// A render finished: its budget ran out or it was aborted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Finish {
    /// Its epoch.
    pub epoch: u32,
    /// True when stopped by abort (a new camera or parameters), false when its budget ran out.
    pub aborted: bool,
    /// Camera samples it rendered.
    pub samples: u64,
    /// Light paths it traced.
    pub light_paths: u64,
    /// Seconds it ran.
    pub seconds: f32,
}

impl Finish {
    /// Field table of FINISH.
    pub const LAYOUT: Layout = Layout::message(
        "FINISH",
        kind::FINISH,
        Direction::ToViewer,
        &[EPOCH, ABORTED, RESERVED, SAMPLES, LIGHT_PATHS, SECONDS],
    );

    /// Encodes it.
    pub fn write(&self) -> Vec<u8> {
        let mut w = Writer::new(&Self::LAYOUT, 0);
        w.put(&EPOCH, self.epoch);
        w.put(&ABORTED, self.aborted as u8);
        w.put(&SAMPLES, self.samples);
        w.put(&LIGHT_PATHS, self.light_paths);
        w.put(&SECONDS, self.seconds);
        w.finish()
    }

    pub(super) fn decode(r: &Reader) -> Result<Self, ProtocolError> {
        Ok(Self {
            epoch: r.get(&EPOCH)?,
            aborted: r.get::<u8>(&ABORTED)? != 0,
            samples: r.get(&SAMPLES)?,
            light_paths: r.get(&LIGHT_PATHS)?,
            seconds: r.get(&SECONDS)?,
        })
    }
}
