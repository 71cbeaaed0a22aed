//! PARAMS (0x03, both ways): integrator and mode; a change restarts rendering.

use super::enums::{Integrator, Mode};
use super::error::{ErrorCode, ProtocolError};
use super::kind;
use super::layout::{Direction, Field, FieldType, Layout, Reader, Writer};

const INTEGRATOR: Field = Field::one(
    "integrator",
    4,
    FieldType::Enum(&Integrator::WIRE),
    "integrator",
);
const MODE: Field = Field::one("mode", 5, FieldType::Enum(&Mode::WIRE), "mode");
const RESERVED: Field = Field::fixed("reserved", 6, FieldType::Reserved, 2, "reserved, 0");

/// PARAMS: a viewer picks the integrator and mode; the server confirms them to every viewer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Params {
    /// Integrator.
    pub integrator: Integrator,
    /// Mode.
    pub mode: Mode,
}

impl Params {
    /// Field table of PARAMS.
    pub const LAYOUT: Layout = Layout::message(
        "PARAMS",
        kind::PARAMS,
        Direction::Both,
        &[INTEGRATOR, MODE, RESERVED],
    );

    /// Encodes them.
    pub fn write(&self) -> Vec<u8> {
        let mut w = Writer::new(&Self::LAYOUT, 0);
        w.put(&INTEGRATOR, self.integrator.code());
        w.put(&MODE, self.mode.code());
        w.finish()
    }

    /// Decodes the fields; an unknown code is an invalid value.
    pub(super) fn decode(r: &Reader) -> Result<Self, ProtocolError> {
        let (i, m) = (r.get::<u8>(&INTEGRATOR)?, r.get::<u8>(&MODE)?);
        let integrator = Integrator::from_code(i).ok_or_else(|| {
            ProtocolError::new(ErrorCode::InvalidValue, format!("integrator {i}"))
        })?;
        let mode = Mode::from_code(m)
            .ok_or_else(|| ProtocolError::new(ErrorCode::InvalidValue, format!("mode {m}")))?;
        Ok(Self { integrator, mode })
    }
}
