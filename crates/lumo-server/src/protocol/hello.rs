//! HELLO (0x01, server → viewer, first message): the session's description.

use super::camera::{CameraFields, WireCamera};
use super::enums::{Integrator, Mode};
use super::error::{ErrorCode, ProtocolError};
use super::layout::{Direction, Field, FieldType, Layout, Reader, Writer};
use super::samples::SAMPLE;
use super::{kind, truncate_utf8, MAX_NAME};

const WIDTH: Field = Field::one("width", 4, FieldType::U32, "image width (pixels)");
const HEIGHT: Field = Field::one("height", 8, FieldType::U32, "image height");
const TRIANGLES: Field = Field::one("triangles", 12, FieldType::U32, "scene triangles");
const THREADS: Field = Field::one("threads", 16, FieldType::U16, "render threads");
const INTEGRATOR: Field = Field::one(
    "integrator",
    18,
    FieldType::Enum(&Integrator::WIRE),
    "current integrator",
);
const MODE: Field = Field::one("mode", 19, FieldType::Enum(&Mode::WIRE), "current mode");
const SAMPLE_BYTES: Field = Field::one(
    "sampleBytes",
    20,
    FieldType::U16,
    "bytes per sample in SAMPLES (12)",
);
const CAMERA: CameraFields = CameraFields::at(22, "epoch of the current render");
const NAME_LENGTH: Field = Field::one(
    "nameLength",
    66,
    FieldType::U16,
    "scene name length in bytes (≤ 200)",
);
const NAME: Field = Field::tail(
    "name",
    68,
    FieldType::Utf8,
    1,
    &["nameLength"],
    "scene name, UTF-8",
);
const FIELDS: [Field; 14] = [
    WIDTH,
    HEIGHT,
    TRIANGLES,
    THREADS,
    INTEGRATOR,
    MODE,
    SAMPLE_BYTES,
    CAMERA.epoch,
    CAMERA.origin,
    CAMERA.target,
    CAMERA.up,
    CAMERA.fov,
    NAME_LENGTH,
    NAME,
];

/// Description of the session sent first to every viewer.
#[derive(Clone, Debug, PartialEq)]
pub struct Hello {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Triangles in the scene.
    pub triangles: u32,
    /// Render threads.
    pub threads: u16,
    /// Current integrator.
    pub integrator: Integrator,
    /// Current mode.
    pub mode: Mode,
    /// Epoch of the current render.
    pub epoch: u32,
    /// Current camera.
    pub camera: WireCamera,
    /// Scene name (at most [`MAX_NAME`] bytes are sent, cut at a character boundary).
    pub name: String,
}

impl Hello {
    /// Field table of HELLO.
    pub const LAYOUT: Layout = Layout::message("HELLO", kind::HELLO, Direction::ToViewer, &FIELDS);

    /// Encodes it.
    pub fn write(&self) -> Vec<u8> {
        let name = truncate_utf8(&self.name, MAX_NAME);
        let mut w = Writer::new(&Self::LAYOUT, name.len());
        w.put(&WIDTH, self.width);
        w.put(&HEIGHT, self.height);
        w.put(&TRIANGLES, self.triangles);
        w.put(&THREADS, self.threads);
        w.put(&INTEGRATOR, self.integrator.code());
        w.put(&MODE, self.mode.code());
        w.put(&SAMPLE_BYTES, SAMPLE.bytes as u16);
        CAMERA.write(&mut w, self.epoch, &self.camera);
        w.put(&NAME_LENGTH, name.len() as u16);
        w.extend(name.as_bytes());
        w.finish()
    }

    /// Decodes the fields; a sample size other than 12 is refused (the samples could not be
    /// read).
    pub(super) fn decode(r: &Reader) -> Result<Self, ProtocolError> {
        let bad = |m: &str| ProtocolError::new(ErrorCode::Malformed, m);
        let invalid = |m: String| ProtocolError::new(ErrorCode::InvalidValue, m);
        let i = r.get::<u8>(&INTEGRATOR)?;
        let m = r.get::<u8>(&MODE)?;
        if r.get::<u16>(&SAMPLE_BYTES)? as usize != SAMPLE.bytes {
            return Err(bad("sample size"));
        }
        let (epoch, camera) = CAMERA.read(r)?;
        let len = r.get::<u16>(&NAME_LENGTH)? as usize;
        let name = std::str::from_utf8(r.tail(len, "name length")?).map_err(|_| bad("name"))?;
        Ok(Self {
            width: r.get(&WIDTH)?,
            height: r.get(&HEIGHT)?,
            triangles: r.get(&TRIANGLES)?,
            threads: r.get(&THREADS)?,
            integrator: Integrator::from_code(i)
                .ok_or_else(|| invalid(format!("integrator {i}")))?,
            mode: Mode::from_code(m).ok_or_else(|| invalid(format!("mode {m}")))?,
            epoch,
            camera,
            name: name.into(),
        })
    }
}
