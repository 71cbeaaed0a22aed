//! ANIMATE (0x04, both ways): play or pause the scene's animation (`lumo serve --animate`).

use super::error::{ErrorCode, ProtocolError};
use super::kind;
use super::layout::{Direction, Field, FieldType, Layout, Reader, Writer};

const PLAYING: Field = Field::one("playing", 4, FieldType::Bool, "1 while the animation plays");
const RESERVED: Field = Field::fixed("reserved", 5, FieldType::Reserved, 3, "reserved, 0");
const TIME: Field = Field::one(
    "time",
    8,
    FieldType::F32,
    "animation time in seconds of the current epoch (server → viewer; 0 from a viewer)",
);
const DURATION: Field = Field::one(
    "duration",
    12,
    FieldType::F32,
    "length of the clips in seconds; play loops over it (server → viewer; 0 from a viewer)",
);

/// ANIMATE: a viewer asks to play or pause the animation; the server tells every viewer the
/// state (on joining an animated scene and on each change). While it plays, the server poses
/// the scene anew and restarts rendering at every pump tick (a new epoch per frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Animate {
    /// Playing (true) or paused.
    pub playing: bool,
    /// Animation time shown, in seconds (the server's; a viewer sends 0).
    pub time: f32,
    /// Length of the clips in seconds (the server's; a viewer sends 0).
    pub duration: f32,
}

impl Animate {
    /// Field table of ANIMATE.
    pub const LAYOUT: Layout = Layout::message(
        "ANIMATE",
        kind::ANIMATE,
        Direction::Both,
        &[PLAYING, RESERVED, TIME, DURATION],
    );

    /// Encodes it.
    pub fn write(&self) -> Vec<u8> {
        let mut w = Writer::new(&Self::LAYOUT, 0);
        w.put(&PLAYING, self.playing as u8);
        w.put(&TIME, self.time);
        w.put(&DURATION, self.duration);
        w.finish()
    }

    /// Decodes the fields; `playing` must be 0 or 1 and the times finite.
    pub(super) fn decode(r: &Reader) -> Result<Self, ProtocolError> {
        let playing = match r.get::<u8>(&PLAYING)? {
            0 => false,
            1 => true,
            p => {
                return Err(ProtocolError::new(
                    ErrorCode::InvalidValue,
                    format!("playing {p} (0 or 1)"),
                ))
            }
        };
        let (time, duration): (f32, f32) = (r.get(&TIME)?, r.get(&DURATION)?);
        if !time.is_finite() || !duration.is_finite() {
            return Err(ProtocolError::new(
                ErrorCode::InvalidValue,
                format!("time {time} / duration {duration} (finite seconds)"),
            ));
        }
        Ok(Self {
            playing,
            time,
            duration,
        })
    }
}
