//! The binary WebSocket protocol between `lumo serve` and its viewers (docs/protocol.md).
//!
//! Every message is one binary WebSocket message: a 4-byte header `[type u8][version u8]
//! [reserved u16 = 0]` and a payload whose layout depends on the type. All numbers are
//! little-endian.
//!
//! Each message is one struct in its own file with `write` and `read` side by side, and one
//! `const` field table ([`layout::Layout`]) that both go through: the offsets exist once. The
//! tables ([`MESSAGES`], [`RECORDS`], [`ENUMS`]) are also written out as
//! `web/protocol_layout.js`, from which `web/protocol.js` takes every offset and code, and as
//! the message tables of docs/protocol.md ([`generate`]; a test fails when either file
//! differs from what the tables say).

mod animate;
mod camera;
mod edit;
mod enums;
mod error;
mod finish;
mod frame;
pub mod generate;
mod hello;
pub mod layout;
mod params;
mod pick;
pub mod remote;
mod samples;
mod stats;
#[cfg(test)]
mod tests;

pub use animate::Animate;
pub use camera::{CameraUpdate, WireCamera};
pub use edit::{Edit, MAX_EDIT_COORD, MAX_EDIT_RADIANCE};
pub use enums::{EditOp, Integrator, Mode, PickTarget, Stream};
pub use error::{ErrorCode, ErrorReply, ProtocolError};
pub use finish::Finish;
pub use frame::Frame;
pub use hello::Hello;
pub use params::Params;
pub use pick::{Pick, PickHit};
pub use samples::{SampleBatch, SAMPLE};
pub use stats::Stats;

use layout::{Direction, Layout, Reader, WireEnum};

/// Protocol version; a message with another version is answered with an error.
pub const VERSION: u8 = 1;
/// Bytes of the common header.
pub const HEADER_BYTES: usize = 4;
/// Largest message a viewer may send (camera and parameter updates are far smaller).
pub const MAX_CLIENT_MESSAGE: usize = 256;
/// Bytes per packed sample: u, v as unorm16, X, Y, Z, W as IEEE half floats.
pub const SAMPLE_BYTES: usize = SAMPLE.bytes;
/// Bytes of a sample batch before its samples.
pub const BATCH_HEADER_BYTES: usize = SampleBatch::LAYOUT.bytes;
/// Bytes of a frame message before its pixels.
pub const FRAME_HEADER_BYTES: usize = Frame::LAYOUT.bytes;
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
    /// Both ways: play or pause the animation (`lumo serve --animate`).
    pub const ANIMATE: u8 = 0x04;
    /// Both ways: what is under an image position (viewer asks, server answers that viewer).
    pub const PICK: u8 = 0x05;
    /// Both ways: a scene edit (viewer asks, server confirms it to every viewer).
    pub const EDIT: u8 = 0x06;
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

/// Every message's field table, in type order.
pub const MESSAGES: &[&Layout] = &[
    &Hello::LAYOUT,
    &CameraUpdate::LAYOUT,
    &Params::LAYOUT,
    &Animate::LAYOUT,
    &Pick::LAYOUT,
    &Edit::LAYOUT,
    &SampleBatch::LAYOUT,
    &Frame::LAYOUT,
    &Stats::LAYOUT,
    &Finish::LAYOUT,
    &ErrorReply::LAYOUT,
];

/// The records: the common header and the packed sample.
pub const RECORDS: &[&Layout] = &[&layout::HEADER, &SAMPLE];

/// Every enumeration on the wire.
pub const ENUMS: &[&WireEnum] = &[
    &Integrator::WIRE,
    &Mode::WIRE,
    &Stream::WIRE,
    &PickTarget::WIRE,
    &EditOp::WIRE,
    &ErrorCode::WIRE,
];

/// Checks the header and returns the type byte.
fn split_header(msg: &[u8]) -> Result<u8, ProtocolError> {
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
    Ok(msg[0])
}

/// Reads a whole message of `layout`: header, fields (`decode`), nothing after them.
fn read_message<T>(
    msg: &[u8],
    layout: &Layout,
    decode: impl FnOnce(&Reader) -> Result<T, ProtocolError>,
) -> Result<T, ProtocolError> {
    let kind = split_header(msg)?;
    if kind != layout.kind {
        return Err(ProtocolError::new(
            ErrorCode::UnknownType,
            format!("message type {kind:#04x} is not {}", layout.name),
        ));
    }
    let r = Reader::new(msg, layout)?;
    let value = decode(&r)?;
    r.end()?;
    Ok(value)
}

/// Adds `read` (a whole message: header, fields, no trailing bytes) to messages whose
/// `decode` returns `Self`.
macro_rules! reads {
    ($($t:ty),+) => {$(
        impl $t {
            /// Decodes a whole message of this type; every failure is an error, never a panic.
            pub fn read(msg: &[u8]) -> Result<Self, ProtocolError> {
                read_message(msg, &Self::LAYOUT, Self::decode)
            }
        }
    )+};
}
reads!(
    Hello,
    CameraUpdate,
    Params,
    Animate,
    Pick,
    Edit,
    Stats,
    Finish,
    ErrorReply
);

/// `s` cut to at most `max` bytes at a character boundary.
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

/// A decoded message from a viewer.
#[derive(Clone, Debug, PartialEq)]
pub enum ClientMessage {
    /// New camera (checked by [`WireCamera::validate`]): restarts rendering.
    Camera(WireCamera),
    /// New integrator / mode: restarts rendering.
    Params(Params),
    /// Play or pause the animation (its time and duration fields are ignored).
    Animate(Animate),
    /// What is under an image position (the answer fields are ignored).
    Pick(Pick),
    /// A scene edit (checked by [`Edit::validate`]; its index by the server).
    Edit(Edit),
}

/// Decodes a viewer's message; every failure is an error to send back, never a panic.
pub fn decode_client(msg: &[u8]) -> Result<ClientMessage, ProtocolError> {
    if msg.len() > MAX_CLIENT_MESSAGE {
        return Err(ProtocolError::new(
            ErrorCode::TooLarge,
            format!("{} bytes exceeds {MAX_CLIENT_MESSAGE}", msg.len()),
        ));
    }
    match split_header(msg)? {
        kind::CAMERA => {
            // Length first, then the camera's values, then trailing bytes: a short message is
            // "malformed" whatever it holds, a bad camera "invalid" even with extra bytes.
            let r = Reader::new(msg, &CameraUpdate::LAYOUT)?;
            let update = CameraUpdate::decode(&r)?;
            update.camera.validate()?;
            r.end()?;
            Ok(ClientMessage::Camera(update.camera))
        }
        kind::PARAMS => Params::read(msg).map(ClientMessage::Params),
        kind::ANIMATE => Animate::read(msg).map(ClientMessage::Animate),
        kind::PICK => Pick::read(msg).map(ClientMessage::Pick),
        kind::EDIT => {
            // As CAMERA: length first, then the values, then trailing bytes.
            let r = Reader::new(msg, &Edit::LAYOUT)?;
            let edit = Edit::decode(&r)?;
            edit.validate()?;
            r.end()?;
            Ok(ClientMessage::Edit(edit))
        }
        k if MESSAGES
            .iter()
            .any(|m| m.kind == k && m.direction == Direction::ToViewer) =>
        {
            Err(ProtocolError::new(
                ErrorCode::Unexpected,
                format!("message type {k:#04x} is sent by the server only"),
            ))
        }
        other => Err(ProtocolError::new(
            ErrorCode::UnknownType,
            format!("unknown message type {other:#04x}"),
        )),
    }
}

/// Decoding of server messages, for tests and tools that watch a server.
pub mod client {
    use super::*;
    use crate::streams::Sample;

    /// A decoded server message.
    #[derive(Clone, Debug, PartialEq)]
    pub enum ServerMessage {
        /// The hello.
        Hello(Hello),
        /// Camera confirmed for an epoch.
        Camera(CameraUpdate),
        /// Parameters.
        Params(Params),
        /// Animation state.
        Animate(Animate),
        /// The answer to a pick.
        Pick(Pick),
        /// An edit applied.
        Edit(Edit),
        /// A sample batch and its unpacked samples.
        Samples(SampleBatch, Vec<Sample>),
        /// A filtered frame and its RGBA pixels.
        Frame(Frame, Vec<[f32; 4]>),
        /// Stats.
        Stats(Stats),
        /// Finish.
        Finish(Finish),
        /// Error: code and text.
        Error(ErrorReply),
    }

    /// Decodes a server message.
    pub fn decode_server(msg: &[u8]) -> Result<ServerMessage, ProtocolError> {
        use ServerMessage as M;
        match split_header(msg)? {
            kind::HELLO => Hello::read(msg).map(M::Hello),
            kind::CAMERA => CameraUpdate::read(msg).map(M::Camera),
            kind::PARAMS => Params::read(msg).map(M::Params),
            kind::ANIMATE => Animate::read(msg).map(M::Animate),
            kind::PICK => Pick::read(msg).map(M::Pick),
            kind::EDIT => Edit::read(msg).map(M::Edit),
            kind::SAMPLES => SampleBatch::read(msg).map(|(b, s)| M::Samples(b, s)),
            kind::FRAME => Frame::read(msg).map(|(f, p)| M::Frame(f, p)),
            kind::STATS => Stats::read(msg).map(M::Stats),
            kind::FINISH => Finish::read(msg).map(M::Finish),
            kind::ERROR => ErrorReply::read(msg).map(M::Error),
            other => Err(ProtocolError::new(
                ErrorCode::UnknownType,
                format!("unknown message type {other:#04x}"),
            )),
        }
    }
}
