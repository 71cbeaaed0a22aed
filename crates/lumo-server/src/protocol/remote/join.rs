//! WORKER_HELLO (0x20, worker → hub, first message): the token, the worker's lumo version and
//! protocol number, and its name.

use super::super::error::{ErrorCode, ProtocolError};
use super::super::layout::{Direction, Field, FieldType, Layout, Reader, Writer};
use super::super::{read_message, truncate_utf8};
use super::{kind, padded_text};

/// Longest token (ASCII hex characters).
pub const MAX_TOKEN: usize = 64;
/// Longest worker name in bytes.
pub const MAX_WORKER_NAME: usize = 64;
/// Bytes of the version field.
const VERSION_BYTES: usize = 32;

const PROTOCOL: Field = Field::one(
    "protocol",
    4,
    FieldType::U16,
    "worker protocol number (1); the hub refuses another",
);
const RESERVED: Field = Field::fixed("reserved", 6, FieldType::Reserved, 2, "reserved, 0");
const TOKEN: Field = Field::fixed(
    "token",
    8,
    FieldType::Utf8,
    MAX_TOKEN,
    "the hub's token, ASCII hex, zero-padded",
);
const LUMO_VERSION: Field = Field::fixed(
    "lumoVersion",
    72,
    FieldType::Utf8,
    VERSION_BYTES,
    "the worker's lumo version (its Cargo package version), zero-padded; the hub refuses another",
);
const NAME_LENGTH: Field = Field::one(
    "nameLength",
    104,
    FieldType::U16,
    "worker name length in bytes (1..=64)",
);
const NAME: Field = Field::tail(
    "name",
    106,
    FieldType::Utf8,
    1,
    &["nameLength"],
    "worker name, UTF-8 (the hub's log lines name the worker by it)",
);

/// A worker introduces itself.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WorkerHello {
    /// [`super::WORKER_PROTOCOL`] of the worker's build.
    pub protocol: u16,
    /// The token the hub printed (at most [`MAX_TOKEN`] bytes are sent).
    pub token: String,
    /// The worker's lumo version ([`super::LUMO_VERSION`] of its build).
    pub version: String,
    /// The worker's name (at most [`MAX_WORKER_NAME`] bytes are sent).
    pub name: String,
}

impl WorkerHello {
    /// Field table of WORKER_HELLO.
    pub const LAYOUT: Layout = Layout::message(
        "WORKER_HELLO",
        kind::WORKER_HELLO,
        Direction::FromWorker,
        &[PROTOCOL, RESERVED, TOKEN, LUMO_VERSION, NAME_LENGTH, NAME],
    );

    /// Encodes it.
    pub fn write(&self) -> Vec<u8> {
        let name = truncate_utf8(&self.name, MAX_WORKER_NAME);
        let mut w = Writer::new(&Self::LAYOUT, name.len());
        w.put(&PROTOCOL, self.protocol);
        w.put_bytes(&TOKEN, self.token.as_bytes());
        w.put_bytes(&LUMO_VERSION, self.version.as_bytes());
        w.put(&NAME_LENGTH, name.len() as u16);
        w.extend(name.as_bytes());
        w.finish()
    }

    /// Decodes a whole message; a name that is empty, too long or not UTF-8 is refused.
    pub fn read(msg: &[u8]) -> Result<Self, ProtocolError> {
        read_message(msg, &Self::LAYOUT, Self::decode)
    }

    fn decode(r: &Reader) -> Result<Self, ProtocolError> {
        let len = r.get::<u16>(&NAME_LENGTH)? as usize;
        if len == 0 || len > MAX_WORKER_NAME {
            return Err(ProtocolError::new(
                ErrorCode::InvalidValue,
                format!("worker name of {len} bytes (1..={MAX_WORKER_NAME})"),
            ));
        }
        let name = std::str::from_utf8(r.tail(len, "name length")?)
            .map_err(|_| ProtocolError::new(ErrorCode::Malformed, "worker name is not UTF-8"))?;
        Ok(Self {
            protocol: r.get(&PROTOCOL)?,
            token: padded_text(r.bytes(&TOKEN)?, "token")?,
            version: padded_text(r.bytes(&LUMO_VERSION)?, "lumo version")?,
            name: name.to_string(),
        })
    }
}
