//! SAMPLES (0x10, server → viewer): a batch of packed samples of one stream, and the 12-byte
//! sample record the viewer uploads to a vertex buffer as it is.

use half::f16;

use super::enums::Stream;
use super::error::{ErrorCode, ProtocolError};
use super::kind;
use super::layout::{Direction, Field, FieldType, Layout, Reader, Writer};
use crate::streams::Sample;

const UV: Field = Field::fixed(
    "uv",
    0,
    FieldType::Unorm16,
    2,
    "u, v · 65535: screen position in [0,1]², u left to right, v top to bottom",
);
const XYZW: Field = Field::fixed(
    "xyzw",
    4,
    FieldType::F16,
    4,
    "X, Y, Z (CIE 1931, D65 white; linear) and W, the sample weight (1)",
);

/// The packed sample: two normalised `UNSIGNED_SHORT` and four `HALF_FLOAT` vertex
/// attributes, so the viewer draws the bytes without decoding them.
pub const SAMPLE: Layout = Layout::record("SAMPLE", &[UV, XYZW]);

const EPOCH: Field = Field::one("epoch", 4, FieldType::U32, "epoch");
const STREAM: Field = Field::one("stream", 8, FieldType::Enum(&Stream::WIRE), "sample stream");
const RESERVED: Field = Field::fixed("reserved", 9, FieldType::Reserved, 3, "reserved");
const COUNT: Field = Field::one("count", 12, FieldType::U32, "count");
const LIGHT_PATHS: Field = Field::one(
    "lightPaths",
    16,
    FieldType::U32,
    "light paths this message accounts for (0 for the camera stream)",
);
const SAMPLES: Field = Field::tail(
    "samples",
    20,
    FieldType::Record(&SAMPLE),
    1,
    &["count"],
    "samples",
);

/// A SAMPLES message's header fields; the samples are passed to [`SampleBatch::write`] and
/// returned by [`SampleBatch::read`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleBatch {
    /// Epoch the samples belong to.
    pub epoch: u32,
    /// Their stream.
    pub stream: Stream,
    /// Light paths this batch accounts for (0 for the camera stream).
    pub light_paths: u32,
}

impl SampleBatch {
    /// Field table of SAMPLES.
    pub const LAYOUT: Layout = Layout::message(
        "SAMPLES",
        kind::SAMPLES,
        Direction::ToViewer,
        &[EPOCH, STREAM, RESERVED, COUNT, LIGHT_PATHS, SAMPLES],
    );

    /// Encodes the batch with `samples` (the count is theirs).
    pub fn write(&self, samples: &[Sample]) -> Vec<u8> {
        let mut w = Writer::new(&Self::LAYOUT, samples.len() * SAMPLE.bytes);
        w.put(&EPOCH, self.epoch);
        w.put(&STREAM, self.stream.code());
        w.put(&COUNT, samples.len() as u32);
        w.put(&LIGHT_PATHS, self.light_paths);
        for s in samples {
            w.extend(&pack(s));
        }
        w.finish()
    }

    /// Decodes the header and unpacks the samples (as the viewer's GPU reads them).
    pub fn read(msg: &[u8]) -> Result<(Self, Vec<Sample>), ProtocolError> {
        super::read_message(msg, &Self::LAYOUT, Self::decode)
    }

    pub(super) fn decode(r: &Reader) -> Result<(Self, Vec<Sample>), ProtocolError> {
        let s = r.get::<u8>(&STREAM)?;
        let stream = Stream::from_code(s)
            .ok_or_else(|| ProtocolError::new(ErrorCode::InvalidValue, format!("stream {s}")))?;
        let count = r.get::<u32>(&COUNT)? as usize;
        let bytes = count
            .checked_mul(SAMPLE.bytes)
            .ok_or_else(|| ProtocolError::new(ErrorCode::Malformed, "sample count"))?;
        let samples = r.tail(bytes, "sample count")?;
        let batch = Self {
            epoch: r.get(&EPOCH)?,
            stream,
            light_paths: r.get(&LIGHT_PATHS)?,
        };
        Ok((
            batch,
            samples.chunks_exact(SAMPLE.bytes).map(unpack).collect(),
        ))
    }
}

/// A half float's exponent bits: all ones is an infinity or NaN.
const F16_EXPONENT: u16 = 0x7c00;
/// 1.0 as a half float: the weight of every sample the renderer's streams send.
const F16_ONE: u16 = 0x3c00;

impl SampleBatch {
    /// Decodes a batch's header and checks its samples where they lie, without unpacking
    /// them: at most `max_count`, every X, Y, Z finite and every weight W exactly 1 (the
    /// positions are unorm16, inside the image by construction). The hub checks a remote
    /// worker's batch so and forwards its bytes to viewers as they are. Returns the header
    /// and the sample count.
    pub fn check_packed(msg: &[u8], max_count: usize) -> Result<(Self, usize), ProtocolError> {
        super::read_message(msg, &Self::LAYOUT, |r| {
            let s = r.get::<u8>(&STREAM)?;
            let stream = Stream::from_code(s).ok_or_else(|| {
                ProtocolError::new(ErrorCode::InvalidValue, format!("stream {s}"))
            })?;
            let count = r.get::<u32>(&COUNT)? as usize;
            if count > max_count {
                return Err(ProtocolError::new(
                    ErrorCode::TooLarge,
                    format!("{count} samples in one batch (at most {max_count})"),
                ));
            }
            let samples = r.tail(count * SAMPLE.bytes, "sample count")?;
            for (i, rec) in samples.chunks_exact(SAMPLE.bytes).enumerate() {
                let h = |c: usize| {
                    let at = XYZW.offset + 2 * c;
                    u16::from_le_bytes([rec[at], rec[at + 1]])
                };
                if (0..3).any(|c| h(c) & F16_EXPONENT == F16_EXPONENT) {
                    return Err(ProtocolError::new(
                        ErrorCode::InvalidValue,
                        format!("sample {i}: X, Y or Z is not finite"),
                    ));
                }
                if h(3) != F16_ONE {
                    return Err(ProtocolError::new(
                        ErrorCode::InvalidValue,
                        format!("sample {i}: weight W is not 1"),
                    ));
                }
            }
            let batch = Self {
                epoch: r.get(&EPOCH)?,
                stream,
                light_paths: r.get(&LIGHT_PATHS)?,
            };
            Ok((batch, count))
        })
    }
}

/// Packs one sample: `uv` in [0,1]² (clamped, NaN to 0), XYZW as half floats clamped to the
/// half range, so a firefly saturates instead of turning into infinity; NaN and infinities
/// are sent as 0.
fn pack(s: &Sample) -> [u8; SAMPLE.bytes] {
    let mut out = [0; SAMPLE.bytes];
    for (i, c) in s.uv.into_iter().enumerate() {
        let q = (c.clamp(0.0, 1.0) * 65535.0 + 0.5) as u16;
        let at = UV.offset + 2 * i;
        out[at..at + 2].copy_from_slice(&q.to_le_bytes());
    }
    for (i, c) in s.xyzw.into_iter().enumerate() {
        let c = if c.is_finite() {
            c.clamp(-65504.0, 65504.0)
        } else {
            0.0
        };
        let at = XYZW.offset + 2 * i;
        out[at..at + 2].copy_from_slice(&f16::from_f32(c).to_bits().to_le_bytes());
    }
    out
}

/// The inverse of [`pack`] up to quantisation.
fn unpack(b: &[u8]) -> Sample {
    let h = |at: usize| u16::from_le_bytes([b[at], b[at + 1]]);
    Sample {
        uv: [0, 1].map(|i| h(UV.offset + 2 * i) as f32 / 65535.0),
        xyzw: [0, 1, 2, 3].map(|i| f16::from_bits(h(XYZW.offset + 2 * i)).to_f32()),
    }
}
