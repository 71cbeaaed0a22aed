//! EDIT (0x06, both ways): a viewer changes the scene — moves an object or a light, sets a
//! light's intensity, a material's emission or base colour; the server applies it at the next
//! restart and tells every viewer.

use glam::Vec3;

use super::enums::EditOp;
use super::error::{ErrorCode, ProtocolError};
use super::kind;
use super::layout::{Direction, Field, FieldType, Layout, Reader, Writer};

/// Largest coordinate an edit may move an object or light to. Scenes are built around the
/// origin at most a few thousand units across; beyond a million units single precision keeps
/// less than a tenth of a unit of a position, so such a move is a slip, not an intent.
pub const MAX_EDIT_COORD: f32 = 1e6;
/// Largest intensity, emission or irradiance component an edit may set: far above any light
/// in the scenes (the Cornell light is 17 W/m²/sr), and a bound that keeps the sums of the
/// renderers and the viewer's half floats (≤ 65504 per sample) from overflowing.
pub const MAX_EDIT_RADIANCE: f32 = 1e6;

const OP: Field = Field::one("op", 4, FieldType::Enum(&EditOp::WIRE), "what changes");
const RESERVED: Field = Field::fixed("reserved", 5, FieldType::Reserved, 3, "reserved, 0");
const INDEX: Field = Field::one(
    "index",
    8,
    FieldType::U32,
    "the instance, light or material changed",
);
const VALUE: Field = Field::fixed(
    "value",
    12,
    FieldType::F32,
    3,
    "the new value: a position (|·| ≤ 1e6), an intensity or emission (0..=1e6) or a colour (0..=1)",
);

/// EDIT: one change to the scene, with the new absolute value (so a merged burst of edits
/// ends where the last one says, and a repeated edit changes nothing).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edit {
    /// What changes.
    pub op: EditOp,
    /// Instance (moves), light (moves, intensity) or material (emission, base colour) index.
    pub index: u32,
    /// The new value.
    pub value: Vec3,
}

impl Edit {
    /// Field table of EDIT.
    pub const LAYOUT: Layout = Layout::message(
        "EDIT",
        kind::EDIT,
        Direction::Both,
        &[OP, RESERVED, INDEX, VALUE],
    );

    /// Encodes it.
    pub fn write(&self) -> Vec<u8> {
        let mut w = Writer::new(&Self::LAYOUT, 0);
        w.put(&OP, self.op.code());
        w.put(&INDEX, self.index);
        for (i, x) in self.value.to_array().into_iter().enumerate() {
            w.put_at(&VALUE, i, x);
        }
        w.finish()
    }

    /// Checks the value against the op's bounds (the index is checked against the scene by
    /// the server, which knows it).
    pub fn validate(&self) -> Result<(), ProtocolError> {
        let v = self.value;
        let invalid = |m: String| Err(ProtocolError::new(ErrorCode::InvalidValue, m));
        if !v.is_finite() {
            return invalid(format!("edit value {v} is not finite"));
        }
        match self.op {
            EditOp::MoveInstance | EditOp::MoveLight => {
                let m = v.abs().max_element();
                if m > MAX_EDIT_COORD {
                    return invalid(format!(
                        "edit position coordinate {m:e} is beyond ±{MAX_EDIT_COORD:e}"
                    ));
                }
            }
            EditOp::LightIntensity | EditOp::Emission => {
                if v.min_element() < 0.0 || v.max_element() > MAX_EDIT_RADIANCE {
                    return invalid(format!(
                        "edit intensity {v} is outside 0..={MAX_EDIT_RADIANCE:e} per channel"
                    ));
                }
            }
            EditOp::BaseColor => {
                // Above 1 a surface would reflect more than it receives (energy appears).
                if v.min_element() < 0.0 || v.max_element() > 1.0 {
                    return invalid(format!("edit colour {v} is outside 0..=1 per channel"));
                }
            }
        }
        Ok(())
    }

    /// Decodes the fields (not [`Edit::validate`]: the server checks viewers' edits).
    pub(super) fn decode(r: &Reader) -> Result<Self, ProtocolError> {
        let o = r.get::<u8>(&OP)?;
        let op = EditOp::from_code(o)
            .ok_or_else(|| ProtocolError::new(ErrorCode::InvalidValue, format!("edit op {o}")))?;
        Ok(Self {
            op,
            index: r.get(&INDEX)?,
            value: Vec3::new(
                r.get_at(&VALUE, 0)?,
                r.get_at(&VALUE, 1)?,
                r.get_at(&VALUE, 2)?,
            ),
        })
    }
}
