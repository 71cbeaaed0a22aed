//! STATUS (0x23, worker → hub): after WELCOME, the worker says it is ready (scene loaded,
//! render threads started) or why it cannot render; the hub logs the reason naming the worker.

use super::super::error::{ErrorCode, ProtocolError};
use super::super::layout::{wire_enum, Direction, Field, FieldType, Layout, Reader, Writer};
use super::super::{read_message, truncate_utf8, MAX_ERROR_TEXT};
use super::kind;

wire_enum! {
    /// What a worker reports.
    pub enum WorkerState: u8, "workerState" {
        /// Scene loaded, render threads started: send EPOCH.
        Ready = 0, "ready", "ready";
        /// The scene could not be read or built on the worker's machine.
        SceneFailed = 1, "sceneFailed", "cannot load the scene";
        /// Another failure (the render threads could not start).
        Failed = 2, "failed", "failed";
    }
}

const STATE: Field = Field::one("state", 4, FieldType::Enum(&WorkerState::WIRE), "state");
const RESERVED: Field = Field::fixed("reserved", 5, FieldType::Reserved, 1, "reserved, 0");
const THREADS: Field = Field::one("threads", 6, FieldType::U16, "render threads (ready)");
const LENGTH: Field = Field::one("length", 8, FieldType::U16, "text length in bytes (≤ 400)");
const MESSAGE: Field = Field::tail(
    "message",
    10,
    FieldType::Utf8,
    1,
    &["length"],
    "why it cannot render, UTF-8 (empty when ready)",
);

/// A worker's state after the welcome.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WorkerStatus {
    /// Ready or failed.
    pub state: WorkerState,
    /// Render threads the worker runs.
    pub threads: u16,
    /// Why it failed (cut to [`MAX_ERROR_TEXT`] bytes).
    pub message: String,
}

impl WorkerStatus {
    /// Field table of STATUS.
    pub const LAYOUT: Layout = Layout::message(
        "STATUS",
        kind::STATUS,
        Direction::FromWorker,
        &[STATE, RESERVED, THREADS, LENGTH, MESSAGE],
    );

    /// Encodes it.
    pub fn write(&self) -> Vec<u8> {
        let text = truncate_utf8(&self.message, MAX_ERROR_TEXT);
        let mut w = Writer::new(&Self::LAYOUT, text.len());
        w.put(&STATE, self.state.code());
        w.put(&THREADS, self.threads);
        w.put(&LENGTH, text.len() as u16);
        w.extend(text.as_bytes());
        w.finish()
    }

    /// Decodes a whole message.
    pub fn read(msg: &[u8]) -> Result<Self, ProtocolError> {
        read_message(msg, &Self::LAYOUT, Self::decode)
    }

    fn decode(r: &Reader) -> Result<Self, ProtocolError> {
        let s = r.get::<u8>(&STATE)?;
        let state = WorkerState::from_code(s).ok_or_else(|| {
            ProtocolError::new(ErrorCode::InvalidValue, format!("worker state {s}"))
        })?;
        let len = r.get::<u16>(&LENGTH)? as usize;
        if len > MAX_ERROR_TEXT {
            return Err(ProtocolError::new(ErrorCode::TooLarge, "status text"));
        }
        let text = r.tail(len, "text length")?;
        Ok(Self {
            state,
            threads: r.get(&THREADS)?,
            message: String::from_utf8_lossy(text).into_owned(),
        })
    }
}
