//! The binary WebSocket protocol between `lumo serve` and its viewers (docs/protocol.md).
//!
//! Every message is one binary WebSocket message: a 4-byte header `[type u8][version u8]
//! [reserved u16 = 0]` and a payload whose layout depends on the type. All numbers are
//! little-endian. The viewer's `web/protocol.js` mirrors this file.

use glam::Vec3;
use half::f16;

/// Protocol version; a message with another version is answered with an error.
pub const VERSION: u8 = 1;
/// Bytes of the common header.
pub const HEADER_BYTES: usize = 4;
/// Largest message a viewer may send (camera and parameter updates are far smaller).
pub const MAX_CLIENT_MESSAGE: usize = 256;
/// Bytes per packed sample: u, v as unorm16, X, Y, Z, W as IEEE half floats.
pub const SAMPLE_BYTES: usize = 12;
/// Bytes of a sample batch before its samples.
pub const BATCH_HEADER_BYTES: usize = HEADER_BYTES + 16;
/// Bytes of a frame message before its pixels.
pub const FRAME_HEADER_BYTES: usize = HEADER_BYTES + 16;
/// Longest scene name sent in a hello.
pub const MAX_NAME: usize = 200;
/// Longest error text.
pub const MAX_ERROR_TEXT: usize = 400;
/// Largest camera coordinate accepted. The renderers measure distances from the eye in single
/// precision and square them (normalising directions, the light tracer's falloff): with every
/// coordinate within ±1e18 a squared distance is at most 3·(2e18)² ≈ 1.2e37, below f32's
/// 3.4e38; beyond it they overflow and the image turns black or NaN.
pub const MAX_CAMERA_COORD: f32 = 1e18;

/// Message type bytes.
pub mod kind {
    /// Server → viewer: scene and session description.
    pub const HELLO: u8 = 0x01;
    /// Both ways: camera (viewer → server asks for it; server → viewers confirms it with the
    /// epoch of the render that uses it).
    pub const CAMERA: u8 = 0x02;
    /// Both ways: integrator and display mode.
    pub const PARAMS: u8 = 0x03;
    /// Server → viewer: packed samples of one stream.
    pub const SAMPLES: u8 = 0x10;
    /// Server → viewer: a whole filtered frame.
    pub const FRAME: u8 = 0x11;
    /// Server → viewer: counters.
    pub const STATS: u8 = 0x12;
    /// Server → viewer: a render finished (sample budget reached or aborted).
    pub const FINISH: u8 = 0x13;
    /// Server → viewer: a message was refused; the connection stays open.
    pub const ERROR: u8 = 0x7f;
}

/// Error codes carried by [`kind::ERROR`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
pub enum ErrorCode {
    /// Shorter or longer than its type requires.
    Malformed = 1,
    /// Type byte not defined.
    UnknownType = 2,
    /// Version byte is not [`VERSION`].
    Version = 3,
    /// A field is out of range (non-finite camera, bad enum value…).
    InvalidValue = 4,
    /// Larger than [`MAX_CLIENT_MESSAGE`].
    TooLarge = 5,
    /// Text WebSocket messages are not part of the protocol.
    TextMessage = 6,
    /// A type the server sends but never accepts.
    Unexpected = 7,
}

/// A refused message: code and human-readable reason.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message} (code {})", *code as u16)]
pub struct ProtocolError {
    /// Machine-readable code.
    pub code: ErrorCode,
    /// Explanation for people.
    pub message: String,
}

impl ProtocolError {
    fn new(code: ErrorCode, message: impl Into<String>) -> Self {
        Self {
            code,
            message: message.into(),
        }
    }
}

/// Which integrator feeds the sample streams.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Integrator {
    /// Path tracer: camera stream only.
    Path = 0,
    /// Light tracer: light stream only.
    Light = 1,
    /// Both, each weighted ½ so their sum estimates the image once.
    Both = 2,
}

impl Integrator {
    /// From the wire byte.
    pub fn from_u8(v: u8) -> Option<Self> {
        [Self::Path, Self::Light, Self::Both]
            .get(v as usize)
            .copied()
    }
}

/// What the server sends: progressive samples or filtered frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Sample streams for the viewer's progressive reconstruction.
    Progressive = 0,
    /// Whole frames: the running mean of 1-spp frames filtered by edge-avoiding À-Trous.
    Atrous = 1,
    /// Whole frames: the same mean filtered by the guided filter.
    Guided = 2,
}

impl Mode {
    /// From the wire byte.
    pub fn from_u8(v: u8) -> Option<Self> {
        [Self::Progressive, Self::Atrous, Self::Guided]
            .get(v as usize)
            .copied()
    }
}

/// Which sample stream a batch belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stream {
    /// Camera samples: pixel = Σ w·c / Σ w.
    Camera = 0,
    /// Light samples: pixel = Σ filtered c / light paths.
    Light = 1,
}

/// A pinhole camera as sent over the wire.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WireCamera {
    /// Eye.
    pub origin: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up hint.
    pub up: Vec3,
    /// Field of view in degrees along the image's shorter side.
    pub fov: f32,
}

impl WireCamera {
    /// Checks that the camera defines a usable view.
    pub fn validate(&self) -> Result<(), ProtocolError> {
        let finite = [self.origin, self.target, self.up]
            .iter()
            .all(|v| v.is_finite())
            && self.fov.is_finite();
        if !finite {
            return Err(ProtocolError::new(
                ErrorCode::InvalidValue,
                "camera has non-finite numbers",
            ));
        }
        if !(1.0..=170.0).contains(&self.fov) {
            return Err(ProtocolError::new(
                ErrorCode::InvalidValue,
                format!("field of view {} outside 1..=170 degrees", self.fov),
            ));
        }
        let invalid = |m: String| Err(ProtocolError::new(ErrorCode::InvalidValue, m));
        for (name, v) in [
            ("origin", self.origin),
            ("target", self.target),
            ("up", self.up),
        ] {
            let m = v.abs().max_element();
            if m > MAX_CAMERA_COORD {
                return invalid(format!(
                    "camera {name} coordinate {m:e} is beyond ±{MAX_CAMERA_COORD:e}, where the \
                     renderer's single-precision distances overflow"
                ));
            }
        }
        // Direction first, then normalisable: within the bound above the difference and its
        // squared length stay finite, so a zero or denormal-tiny difference is what fails here.
        let Some(forward) = (self.target - self.origin).try_normalize() else {
            return invalid("camera target coincides with its origin (no view direction)".into());
        };
        // The renderer builds right = normalize(forward × up): that must be normalisable, and
        // up must not be (nearly) parallel to the view.
        let right = forward.cross(self.up);
        if right.try_normalize().is_none() || right.length() < 1e-4 * self.up.length() {
            return invalid(
                "camera up vector is zero, too short, or parallel to the view direction".into(),
            );
        }
        Ok(())
    }
}

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
    /// Scene name (at most [`MAX_NAME`] bytes).
    pub name: String,
}

/// Counters sent a few times a second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stats {
    /// Epoch of the current render.
    pub epoch: u32,
    /// Viewers connected.
    pub viewers: u32,
    /// Camera samples rendered in this epoch.
    pub samples: u64,
    /// Light paths traced in this epoch.
    pub light_paths: u64,
    /// Camera samples plus light paths per second, over the last interval.
    pub rate: f32,
    /// Sample batches dropped for this viewer because it read too slowly.
    pub dropped: u32,
}

/// A render finished.
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

/// A decoded message from a viewer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ClientMessage {
    /// New camera: restarts rendering.
    Camera(WireCamera),
    /// New integrator / mode: restarts rendering.
    Params {
        /// Integrator.
        integrator: Integrator,
        /// Mode.
        mode: Mode,
    },
}

/// A little-endian writer.
struct Writer(Vec<u8>);

impl Writer {
    fn new(kind: u8, capacity: usize) -> Self {
        let mut v = Vec::with_capacity(HEADER_BYTES + capacity);
        v.extend_from_slice(&[kind, VERSION, 0, 0]);
        Self(v)
    }
    fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    fn u16(&mut self, v: u16) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn vec3(&mut self, v: Vec3) {
        for c in v.to_array() {
            self.f32(c);
        }
    }
    fn camera(&mut self, epoch: u32, c: &WireCamera) {
        self.u32(epoch);
        self.vec3(c.origin);
        self.vec3(c.target);
        self.vec3(c.up);
        self.f32(c.fov);
    }
}

/// A little-endian reader over a payload.
struct Reader<'a>(&'a [u8]);

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> Result<[u8; N], ProtocolError> {
        if self.0.len() < N {
            return Err(ProtocolError::new(
                ErrorCode::Malformed,
                "message too short",
            ));
        }
        let (a, b) = self.0.split_at(N);
        self.0 = b;
        a.try_into()
            .map_err(|_| ProtocolError::new(ErrorCode::Malformed, "message too short"))
    }
    fn u8(&mut self) -> Result<u8, ProtocolError> {
        Ok(self.take::<1>()?[0])
    }
    fn u32(&mut self) -> Result<u32, ProtocolError> {
        Ok(u32::from_le_bytes(self.take()?))
    }
    fn f32(&mut self) -> Result<f32, ProtocolError> {
        Ok(f32::from_le_bytes(self.take()?))
    }
    fn vec3(&mut self) -> Result<Vec3, ProtocolError> {
        Ok(Vec3::new(self.f32()?, self.f32()?, self.f32()?))
    }
    fn camera(&mut self) -> Result<(u32, WireCamera), ProtocolError> {
        let epoch = self.u32()?;
        let camera = WireCamera {
            origin: self.vec3()?,
            target: self.vec3()?,
            up: self.vec3()?,
            fov: self.f32()?,
        };
        Ok((epoch, camera))
    }
    fn end(&self) -> Result<(), ProtocolError> {
        if self.0.is_empty() {
            Ok(())
        } else {
            Err(ProtocolError::new(
                ErrorCode::Malformed,
                format!("{} unexpected trailing bytes", self.0.len()),
            ))
        }
    }
}

/// Checks the header and returns the type byte and payload.
fn split_header(msg: &[u8]) -> Result<(u8, &[u8]), ProtocolError> {
    if msg.len() < HEADER_BYTES {
        return Err(ProtocolError::new(
            ErrorCode::Malformed,
            format!("{} bytes is shorter than the 4-byte header", msg.len()),
        ));
    }
    if msg[1] != VERSION {
        return Err(ProtocolError::new(
            ErrorCode::Version,
            format!("protocol version {} (server speaks {VERSION})", msg[1]),
        ));
    }
    Ok((msg[0], &msg[HEADER_BYTES..]))
}

/// Decodes a viewer's message; every failure is an error to send back, never a panic.
pub fn decode_client(msg: &[u8]) -> Result<ClientMessage, ProtocolError> {
    if msg.len() > MAX_CLIENT_MESSAGE {
        return Err(ProtocolError::new(
            ErrorCode::TooLarge,
            format!("{} bytes exceeds {MAX_CLIENT_MESSAGE}", msg.len()),
        ));
    }
    let (kind, payload) = split_header(msg)?;
    let mut r = Reader(payload);
    let out = match kind {
        kind::CAMERA => {
            let (_, camera) = r.camera()?;
            camera.validate()?;
            ClientMessage::Camera(camera)
        }
        kind::PARAMS => {
            let (i, m) = (r.u8()?, r.u8()?);
            r.take::<2>()?;
            let integrator = Integrator::from_u8(i).ok_or_else(|| {
                ProtocolError::new(ErrorCode::InvalidValue, format!("integrator {i}"))
            })?;
            let mode = Mode::from_u8(m)
                .ok_or_else(|| ProtocolError::new(ErrorCode::InvalidValue, format!("mode {m}")))?;
            ClientMessage::Params { integrator, mode }
        }
        kind::HELLO | kind::SAMPLES | kind::FRAME | kind::STATS | kind::FINISH | kind::ERROR => {
            return Err(ProtocolError::new(
                ErrorCode::Unexpected,
                format!("message type {kind:#04x} is sent by the server only"),
            ))
        }
        other => {
            return Err(ProtocolError::new(
                ErrorCode::UnknownType,
                format!("unknown message type {other:#04x}"),
            ))
        }
    };
    r.end()?;
    Ok(out)
}

/// Encodes a camera message (either direction; the epoch is ignored from viewers).
pub fn encode_camera(epoch: u32, camera: &WireCamera) -> Vec<u8> {
    let mut w = Writer::new(kind::CAMERA, 44);
    w.camera(epoch, camera);
    w.0
}

/// Encodes a parameter message.
pub fn encode_params(integrator: Integrator, mode: Mode) -> Vec<u8> {
    let mut w = Writer::new(kind::PARAMS, 4);
    w.u8(integrator as u8);
    w.u8(mode as u8);
    w.u16(0);
    w.0
}

/// Encodes the hello.
pub fn encode_hello(h: &Hello) -> Vec<u8> {
    let mut w = Writer::new(kind::HELLO, 80 + h.name.len());
    w.u32(h.width);
    w.u32(h.height);
    w.u32(h.triangles);
    w.u16(h.threads);
    w.u8(h.integrator as u8);
    w.u8(h.mode as u8);
    w.u16(SAMPLE_BYTES as u16);
    w.camera(h.epoch, &h.camera);
    let name = truncate_utf8(&h.name, MAX_NAME);
    w.u16(name.len() as u16);
    w.0.extend_from_slice(name.as_bytes());
    w.0
}

/// Encodes stats.
pub fn encode_stats(s: &Stats) -> Vec<u8> {
    let mut w = Writer::new(kind::STATS, 32);
    w.u32(s.epoch);
    w.u32(s.viewers);
    w.u64(s.samples);
    w.u64(s.light_paths);
    w.f32(s.rate);
    w.u32(s.dropped);
    w.0
}

/// Encodes a finish event.
pub fn encode_finish(f: &Finish) -> Vec<u8> {
    let mut w = Writer::new(kind::FINISH, 28);
    w.u32(f.epoch);
    w.u8(f.aborted as u8);
    w.0.extend_from_slice(&[0; 3]);
    w.u64(f.samples);
    w.u64(f.light_paths);
    w.f32(f.seconds);
    w.0
}

/// Encodes an error reply.
pub fn encode_error(e: &ProtocolError) -> Vec<u8> {
    let text = truncate_utf8(&e.message, MAX_ERROR_TEXT);
    let mut w = Writer::new(kind::ERROR, 4 + text.len());
    w.u16(e.code as u16);
    w.u16(text.len() as u16);
    w.0.extend_from_slice(text.as_bytes());
    w.0
}

/// Starts a sample batch for `count` samples; append each with [`push_sample`].
pub fn begin_batch(epoch: u32, stream: Stream, count: u32, light_paths: u32) -> Vec<u8> {
    let mut w = Writer::new(kind::SAMPLES, 16 + count as usize * SAMPLE_BYTES);
    w.u32(epoch);
    w.u8(stream as u8);
    w.0.extend_from_slice(&[0; 3]);
    w.u32(count);
    w.u32(light_paths);
    w.0
}

/// Packs one sample: `uv` in [0,1]² (clamped), XYZW as half floats (clamped to the half
/// range so a firefly saturates instead of turning into infinity).
pub fn push_sample(out: &mut Vec<u8>, uv: [f32; 2], xyzw: [f32; 4]) {
    for c in uv {
        let q = (c.clamp(0.0, 1.0) * 65535.0 + 0.5) as u16;
        out.extend_from_slice(&q.to_le_bytes());
    }
    for c in xyzw {
        let c = if c.is_finite() {
            c.clamp(-65504.0, 65504.0)
        } else {
            0.0
        };
        out.extend_from_slice(&f16::from_f32(c).to_bits().to_le_bytes());
    }
}

/// Encodes a frame of `width`×`height` XYZ pixels (3 floats each) as RGBA half floats with
/// A = 1.
pub fn encode_frame(
    epoch: u32,
    width: u16,
    height: u16,
    mode: Mode,
    frames: u32,
    xyz: &[f32],
) -> Vec<u8> {
    let n = width as usize * height as usize;
    let mut w = Writer::new(kind::FRAME, 16 + n * 8);
    w.u32(epoch);
    w.u16(width);
    w.u16(height);
    w.u8(mode as u8);
    w.0.extend_from_slice(&[0; 3]);
    w.u32(frames);
    for p in xyz.chunks_exact(3).take(n) {
        for c in [p[0], p[1], p[2], 1.0] {
            let c = if c.is_finite() {
                c.clamp(0.0, 65504.0)
            } else {
                0.0
            };
            w.u16(f16::from_f32(c).to_bits());
        }
    }
    w.0
}

fn truncate_utf8(s: &str, max: usize) -> &str {
    if s.len() <= max {
        return s;
    }
    let mut end = max;
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    &s[..end]
}

/// Decoding of server messages, for tests and tools that watch a server.
pub mod client {
    use super::*;

    /// A decoded server message.
    #[derive(Clone, Debug, PartialEq)]
    pub enum ServerMessage {
        /// The hello.
        Hello(Hello),
        /// Camera confirmed for an epoch.
        Camera(u32, WireCamera),
        /// Parameters.
        Params(Integrator, Mode),
        /// Samples: epoch, stream, light paths, unpacked (u, v, X, Y, Z, W) samples.
        Samples {
            /// Epoch.
            epoch: u32,
            /// Stream.
            stream: Stream,
            /// Light paths accounted for.
            light_paths: u32,
            /// Samples.
            samples: Vec<[f32; 6]>,
        },
        /// Frame header fields: epoch, width, height, mode, accumulated frames.
        Frame {
            /// Epoch.
            epoch: u32,
            /// Width.
            width: u16,
            /// Height.
            height: u16,
            /// The filtered-frame mode that made it (the viewer labels frames by it).
            mode: Mode,
            /// 1-spp frames averaged.
            frames: u32,
        },
        /// Stats.
        Stats(Stats),
        /// Finish.
        Finish(Finish),
        /// Error: code and text.
        Error(u16, String),
    }

    /// Decodes a server message.
    pub fn decode_server(msg: &[u8]) -> Result<ServerMessage, ProtocolError> {
        let (kind, payload) = split_header(msg)?;
        let mut r = Reader(payload);
        let bad = |m: &str| ProtocolError::new(ErrorCode::Malformed, m);
        let out = match kind {
            kind::HELLO => {
                let width = r.u32()?;
                let height = r.u32()?;
                let triangles = r.u32()?;
                let threads = u16::from_le_bytes(r.take()?);
                let integrator = Integrator::from_u8(r.u8()?).ok_or_else(|| bad("integrator"))?;
                let mode = Mode::from_u8(r.u8()?).ok_or_else(|| bad("mode"))?;
                let sample_bytes = u16::from_le_bytes(r.take()?);
                if sample_bytes as usize != SAMPLE_BYTES {
                    return Err(bad("sample size"));
                }
                let (epoch, camera) = r.camera()?;
                let len = u16::from_le_bytes(r.take()?) as usize;
                if r.0.len() != len {
                    return Err(bad("name length"));
                }
                let name = String::from_utf8(r.0.to_vec()).map_err(|_| bad("name"))?;
                r.0 = &[];
                ServerMessage::Hello(Hello {
                    width,
                    height,
                    triangles,
                    threads,
                    integrator,
                    mode,
                    epoch,
                    camera,
                    name,
                })
            }
            kind::CAMERA => {
                let (e, c) = r.camera()?;
                ServerMessage::Camera(e, c)
            }
            kind::PARAMS => {
                let i = Integrator::from_u8(r.u8()?).ok_or_else(|| bad("integrator"))?;
                let m = Mode::from_u8(r.u8()?).ok_or_else(|| bad("mode"))?;
                r.take::<2>()?;
                ServerMessage::Params(i, m)
            }
            kind::SAMPLES => {
                let epoch = r.u32()?;
                let stream = match r.u8()? {
                    0 => Stream::Camera,
                    1 => Stream::Light,
                    _ => return Err(bad("stream")),
                };
                r.take::<3>()?;
                let count = r.u32()? as usize;
                let light_paths = r.u32()?;
                if r.0.len() != count * SAMPLE_BYTES {
                    return Err(bad("sample count"));
                }
                let samples =
                    r.0.chunks_exact(SAMPLE_BYTES)
                        .map(|s| {
                            let h = |i: usize| u16::from_le_bytes([s[i], s[i + 1]]);
                            [
                                h(0) as f32 / 65535.0,
                                h(2) as f32 / 65535.0,
                                f16::from_bits(h(4)).to_f32(),
                                f16::from_bits(h(6)).to_f32(),
                                f16::from_bits(h(8)).to_f32(),
                                f16::from_bits(h(10)).to_f32(),
                            ]
                        })
                        .collect();
                r.0 = &[];
                ServerMessage::Samples {
                    epoch,
                    stream,
                    light_paths,
                    samples,
                }
            }
            kind::FRAME => {
                let epoch = r.u32()?;
                let width = u16::from_le_bytes(r.take()?);
                let height = u16::from_le_bytes(r.take()?);
                let mode = Mode::from_u8(r.u8()?).ok_or_else(|| bad("mode"))?;
                r.take::<3>()?;
                let frames = r.u32()?;
                if r.0.len() != width as usize * height as usize * 8 {
                    return Err(bad("frame size"));
                }
                r.0 = &[];
                ServerMessage::Frame {
                    epoch,
                    width,
                    height,
                    mode,
                    frames,
                }
            }
            kind::STATS => ServerMessage::Stats(Stats {
                epoch: r.u32()?,
                viewers: r.u32()?,
                samples: u64::from_le_bytes(r.take()?),
                light_paths: u64::from_le_bytes(r.take()?),
                rate: r.f32()?,
                dropped: r.u32()?,
            }),
            kind::FINISH => {
                let epoch = r.u32()?;
                let aborted = r.u8()? != 0;
                r.take::<3>()?;
                ServerMessage::Finish(Finish {
                    epoch,
                    aborted,
                    samples: u64::from_le_bytes(r.take()?),
                    light_paths: u64::from_le_bytes(r.take()?),
                    seconds: r.f32()?,
                })
            }
            kind::ERROR => {
                let code = u16::from_le_bytes(r.take()?);
                let len = u16::from_le_bytes(r.take()?) as usize;
                if r.0.len() != len {
                    return Err(bad("error length"));
                }
                let text = String::from_utf8_lossy(r.0).into_owned();
                r.0 = &[];
                ServerMessage::Error(code, text)
            }
            other => {
                return Err(ProtocolError::new(
                    ErrorCode::UnknownType,
                    format!("unknown message type {other:#04x}"),
                ))
            }
        };
        r.end()?;
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::client::{decode_server, ServerMessage};
    use super::*;

    fn camera() -> WireCamera {
        WireCamera {
            origin: Vec3::new(0.0, 0.5, 3.9),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov: 39.3,
        }
    }

    #[test]
    fn client_messages_round_trip() {
        let c = camera();
        assert_eq!(
            decode_client(&encode_camera(7, &c)),
            Ok(ClientMessage::Camera(c))
        );
        assert_eq!(
            decode_client(&encode_params(Integrator::Both, Mode::Atrous)),
            Ok(ClientMessage::Params {
                integrator: Integrator::Both,
                mode: Mode::Atrous
            })
        );
    }

    #[test]
    fn server_messages_round_trip() {
        let hello = Hello {
            width: 640,
            height: 480,
            triangles: 36,
            threads: 2,
            integrator: Integrator::Light,
            mode: Mode::Progressive,
            epoch: 3,
            camera: camera(),
            name: "cornell".into(),
        };
        assert_eq!(
            decode_server(&encode_hello(&hello)),
            Ok(ServerMessage::Hello(hello))
        );
        let stats = Stats {
            epoch: 4,
            viewers: 2,
            samples: 1 << 40,
            light_paths: 12,
            rate: 1.5e6,
            dropped: 9,
        };
        assert_eq!(
            decode_server(&encode_stats(&stats)),
            Ok(ServerMessage::Stats(stats))
        );
        let fin = Finish {
            epoch: 5,
            aborted: true,
            samples: 100,
            light_paths: 3,
            seconds: 0.25,
        };
        assert_eq!(
            decode_server(&encode_finish(&fin)),
            Ok(ServerMessage::Finish(fin))
        );
        let err = ProtocolError::new(ErrorCode::InvalidValue, "nope");
        assert_eq!(
            decode_server(&encode_error(&err)),
            Ok(ServerMessage::Error(4, "nope".into()))
        );
        let frame = encode_frame(6, 2, 1, Mode::Atrous, 8, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        assert_eq!(frame.len(), FRAME_HEADER_BYTES + 2 * 8);
        assert_eq!(
            decode_server(&frame),
            Ok(ServerMessage::Frame {
                epoch: 6,
                width: 2,
                height: 1,
                mode: Mode::Atrous,
                frames: 8
            })
        );
    }

    #[test]
    fn samples_pack_into_twelve_bytes() {
        let mut b = begin_batch(9, Stream::Light, 2, 5);
        push_sample(&mut b, [0.25, 1.0], [1.5, 0.5, 0.25, 1.0]);
        push_sample(&mut b, [-1.0, 0.5], [f32::NAN, 1e9, 0.0, -2.0]);
        assert_eq!(b.len(), BATCH_HEADER_BYTES + 2 * SAMPLE_BYTES);
        let Ok(ServerMessage::Samples {
            epoch,
            stream,
            light_paths,
            samples,
        }) = decode_server(&b)
        else {
            panic!("not a batch");
        };
        assert_eq!((epoch, stream, light_paths), (9, Stream::Light, 5));
        let s = samples[0];
        assert!((s[0] - 0.25).abs() < 1e-4 && s[1] == 1.0);
        assert_eq!(&s[2..], &[1.5, 0.5, 0.25, 1.0]);
        // Out-of-range positions clamp; NaN becomes 0; huge values saturate at the half max.
        assert_eq!(samples[1][0], 0.0);
        assert_eq!(&samples[1][2..], &[0.0, 65504.0, 0.0, -2.0]);
    }

    #[test]
    fn malformed_messages_are_refused_with_a_code() {
        let code = |m: &[u8]| decode_client(m).map_err(|e| e.code);
        assert_eq!(code(&[]), Err(ErrorCode::Malformed));
        assert_eq!(
            code(&[kind::CAMERA, VERSION, 0, 0, 1]),
            Err(ErrorCode::Malformed)
        );
        assert_eq!(code(&[0x55, VERSION, 0, 0]), Err(ErrorCode::UnknownType));
        assert_eq!(
            code(&[kind::STATS, VERSION, 0, 0]),
            Err(ErrorCode::Unexpected)
        );
        let mut c = encode_camera(0, &camera());
        c[1] = VERSION + 1;
        assert_eq!(code(&c), Err(ErrorCode::Version));
        let mut long = encode_params(Integrator::Path, Mode::Progressive);
        long.push(0);
        assert_eq!(code(&long), Err(ErrorCode::Malformed));
        assert_eq!(code(&vec![0; 300]), Err(ErrorCode::TooLarge));
        assert_eq!(
            code(&[kind::PARAMS, VERSION, 0, 0, 9, 0, 0, 0]),
            Err(ErrorCode::InvalidValue)
        );
        for bad in [
            WireCamera {
                fov: f32::NAN,
                ..camera()
            },
            WireCamera {
                fov: 0.0,
                ..camera()
            },
            WireCamera {
                target: camera().origin,
                ..camera()
            },
            WireCamera {
                up: Vec3::new(0.0, 0.5, 3.9),
                target: Vec3::ZERO,
                ..camera()
            },
        ] {
            assert_eq!(code(&encode_camera(0, &bad)), Err(ErrorCode::InvalidValue));
        }
    }

    #[test]
    fn cameras_are_checked_in_terms_of_what_the_renderer_computes() {
        let why = |c: WireCamera| c.validate().map_err(|e| e.message);
        // The overflow probe: every number finite, their difference not.
        let e = why(WireCamera {
            origin: Vec3::splat(3e38),
            target: Vec3::splat(-3e38),
            ..camera()
        });
        assert!(e.as_ref().is_err_and(|m| m.contains("beyond")), "{e:?}");
        // A far eye beyond the bound is refused for its distance, not as "parallel".
        let e = why(WireCamera {
            origin: Vec3::new(0.0, 0.0, 1e30),
            ..camera()
        });
        assert!(
            e.as_ref()
                .is_err_and(|m| m.contains("origin") && m.contains("beyond")),
            "{e:?}"
        );
        // Far but within it: accepted, and the renderer's basis is finite and orthonormal.
        for far in [1e6f32, 1e15, 9e17] {
            let c = WireCamera {
                origin: Vec3::new(far, 0.5, far),
                ..camera()
            };
            assert_eq!(why(c), Ok(()), "{far}");
            let cam = lumo_scene::Camera {
                origin: c.origin,
                target: c.target,
                up: c.up,
                fov: c.fov,
                fov_axis: lumo_scene::FovAxis::Smaller,
            };
            let (r, u, f) = cam.basis();
            for v in [r, u, f] {
                assert!(
                    v.is_finite() && (v.length() - 1.0).abs() < 1e-3,
                    "{far}: {v}"
                );
            }
        }
        // A huge or tiny up hint, or one along the view, cannot make a basis.
        for up in [Vec3::new(0.0, 1e30, 0.0), Vec3::splat(1e-30), Vec3::ZERO] {
            assert!(why(WireCamera { up, ..camera() }).is_err(), "{up}");
        }
        let e = why(WireCamera {
            up: camera().target - camera().origin,
            ..camera()
        });
        assert!(e.is_err_and(|m| m.contains("parallel")));
        // Within the bound, an up of any length works.
        assert_eq!(
            why(WireCamera {
                up: Vec3::new(0.0, 1e-3, 0.0),
                ..camera()
            }),
            Ok(())
        );
    }
}
