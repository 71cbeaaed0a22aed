//! ERROR (0x7f): a refused message, and the error type every decoder returns.

use super::layout::{wire_enum, Direction, Field, FieldType, Layout, Reader, Writer};
use super::{kind, truncate_utf8, MAX_ERROR_TEXT};

wire_enum! {
    /// Error codes carried by [`kind::ERROR`].
    pub enum ErrorCode: u16, "errorCode" {
        /// Shorter or longer than its type requires.
        Malformed = 1, "malformed", "malformed, wrong length";
        /// Type byte not defined.
        UnknownType = 2, "unknownType", "unknown type";
        /// Version byte is not [`super::VERSION`].
        Version = 3, "version", "wrong version";
        /// A field is out of range (non-finite camera, bad enum value…).
        InvalidValue = 4, "invalidValue", "invalid value";
        /// Larger than [`super::MAX_CLIENT_MESSAGE`].
        TooLarge = 5, "tooLarge", "too large";
        /// Text WebSocket messages are not part of the protocol.
        TextMessage = 6, "textMessage", "text message";
        /// A type the server sends but never accepts.
        Unexpected = 7, "unexpected", "a server-only type sent by a viewer";
    }
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
    /// An error with `code` and `message`.
    pub fn new(code: ErrorCode, message: impl Into<String>) -> Self {
        Self {
            code,
            message: message.into(),
        }
    }

    /// The ERROR message that answers it (text cut to [`MAX_ERROR_TEXT`] bytes).
    pub fn write(&self) -> Vec<u8> {
        ErrorReply {
            code: self.code as u16,
            message: truncate_utf8(&self.message, MAX_ERROR_TEXT).into(),
        }
        .write()
    }
}

const CODE: Field = Field::one("code", 4, FieldType::Enum(&ErrorCode::WIRE), "error code");
const LENGTH: Field = Field::one("length", 6, FieldType::U16, "text length in bytes (≤ 400)");
const MESSAGE: Field = Field::tail(
    "message",
    8,
    FieldType::Utf8,
    1,
    &["length"],
    "explanation, UTF-8",
);

/// An ERROR message as it travels: the code stays a number, since a newer server may send
/// one this side does not know.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ErrorReply {
    /// [`ErrorCode`] value.
    pub code: u16,
    /// Explanation (written as given; [`ProtocolError::write`] cuts it to the limit).
    pub message: String,
}

impl ErrorReply {
    /// Field table of ERROR.
    pub const LAYOUT: Layout = Layout::message(
        "ERROR",
        kind::ERROR,
        Direction::ToViewer,
        &[CODE, LENGTH, MESSAGE],
    );

    /// Encodes it. The text must fit a u16 length (callers cut it to [`MAX_ERROR_TEXT`]).
    pub fn write(&self) -> Vec<u8> {
        let text = truncate_utf8(&self.message, u16::MAX as usize);
        let mut w = Writer::new(&Self::LAYOUT, text.len());
        w.put(&CODE, self.code);
        w.put(&LENGTH, text.len() as u16);
        w.extend(text.as_bytes());
        w.finish()
    }

    /// Decodes the fields of a message whose header was checked; invalid UTF-8 is replaced
    /// (the text is for people).
    pub(super) fn decode(r: &Reader) -> Result<Self, super::ProtocolError> {
        let code = r.get::<u16>(&CODE)?;
        let len = r.get::<u16>(&LENGTH)? as usize;
        let text = r.tail(len, "error length")?;
        Ok(Self {
            code,
            message: String::from_utf8_lossy(text).into_owned(),
        })
    }
}
