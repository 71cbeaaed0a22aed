//! FRAME (0x11, server → viewer): a whole filtered frame as RGBA half floats.

use half::f16;

use super::enums::Mode;
use super::error::{ErrorCode, ProtocolError};
use super::kind;
use super::layout::{Direction, Field, FieldType, Layout, Reader, Writer};

const EPOCH: Field = Field::one("epoch", 4, FieldType::U32, "epoch");
const WIDTH: Field = Field::one("width", 8, FieldType::U16, "width");
const HEIGHT: Field = Field::one("height", 10, FieldType::U16, "height");
const MODE: Field = Field::one(
    "mode",
    12,
    FieldType::Enum(&Mode::WIRE),
    "mode that made it",
);
const RESERVED: Field = Field::fixed("reserved", 13, FieldType::Reserved, 3, "reserved");
const FRAMES: Field = Field::one(
    "frames",
    16,
    FieldType::U32,
    "1-spp frames averaged before filtering",
);
const PIXELS: Field = Field::tail(
    "pixels",
    20,
    FieldType::F16,
    4,
    &["width", "height"],
    "pixels, top row first: X, Y, Z, 1",
);

/// A FRAME message's header fields; the pixels are passed to [`Frame::write`] and returned by
/// [`Frame::read`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Frame {
    /// Epoch.
    pub epoch: u32,
    /// Width in pixels.
    pub width: u16,
    /// Height in pixels.
    pub height: u16,
    /// The filtered-frame mode that made it (the viewer labels frames by it).
    pub mode: Mode,
    /// 1-spp frames averaged before filtering.
    pub frames: u32,
}

impl Frame {
    /// Field table of FRAME.
    pub const LAYOUT: Layout = Layout::message(
        "FRAME",
        kind::FRAME,
        Direction::ToViewer,
        &[EPOCH, WIDTH, HEIGHT, MODE, RESERVED, FRAMES, PIXELS],
    );

    /// Encodes the frame with `width`×`height` XYZ pixels of `xyz` (3 floats each) as RGBA
    /// half floats with A = 1; values are clamped to [0, 65504] and non-finite ones sent as
    /// 0, so the viewer never sees a NaN.
    pub fn write(&self, xyz: &[f32]) -> Vec<u8> {
        let n = self.width as usize * self.height as usize;
        let mut w = Writer::new(&Self::LAYOUT, n * 4 * PIXELS.ty.bytes());
        w.put(&EPOCH, self.epoch);
        w.put(&WIDTH, self.width);
        w.put(&HEIGHT, self.height);
        w.put(&MODE, self.mode.code());
        w.put(&FRAMES, self.frames);
        for p in xyz.chunks_exact(3).take(n) {
            for c in [p[0], p[1], p[2], 1.0] {
                let c = if c.is_finite() {
                    c.clamp(0.0, 65504.0)
                } else {
                    0.0
                };
                w.extend(&f16::from_f32(c).to_bits().to_le_bytes());
            }
        }
        w.finish()
    }

    /// Decodes the header and the RGBA pixels.
    pub fn read(msg: &[u8]) -> Result<(Self, Vec<[f32; 4]>), ProtocolError> {
        super::read_message(msg, &Self::LAYOUT, Self::decode)
    }

    pub(super) fn decode(r: &Reader) -> Result<(Self, Vec<[f32; 4]>), ProtocolError> {
        let m = r.get::<u8>(&MODE)?;
        let mode = Mode::from_code(m)
            .ok_or_else(|| ProtocolError::new(ErrorCode::InvalidValue, format!("mode {m}")))?;
        let frame = Self {
            epoch: r.get(&EPOCH)?,
            width: r.get(&WIDTH)?,
            height: r.get(&HEIGHT)?,
            mode,
            frames: r.get(&FRAMES)?,
        };
        let n = frame.width as usize * frame.height as usize;
        let bytes = r.tail(n * 4 * PIXELS.ty.bytes(), "frame size")?;
        let half = |h: &[u8]| f16::from_bits(u16::from_le_bytes([h[0], h[1]])).to_f32();
        let pixels = bytes
            .chunks_exact(4 * PIXELS.ty.bytes())
            .map(|p| {
                let mut c = p.chunks_exact(PIXELS.ty.bytes()).map(half);
                [0; 4].map(|_| c.next().unwrap_or(0.0))
            })
            .collect();
        Ok((frame, pixels))
    }
}
