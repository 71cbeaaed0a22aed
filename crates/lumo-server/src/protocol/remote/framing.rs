//! Message framing on a worker connection: each message is preceded by its length as a
//! little-endian `u32`, so a reader knows where it ends on a byte stream, and refuses a length
//! over its bound before reading (or allocating) any of it.

use std::io::{self, Read, Write};

/// Bytes of the length prefix.
pub const PREFIX_BYTES: usize = 4;

/// Why a framed message could not be read.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    /// The socket failed or closed mid-message.
    #[error(transparent)]
    Io(#[from] io::Error),
    /// The length prefix is over the reader's bound (or zero: no message is empty).
    #[error("message length {len} outside 4..={max} bytes")]
    Length {
        /// The length announced.
        len: u32,
        /// The reader's bound.
        max: usize,
    },
}

/// Checks a length prefix against `max` (a message holds at least its 4-byte header).
pub fn check_length(prefix: [u8; PREFIX_BYTES], max: usize) -> Result<usize, FrameError> {
    let len = u32::from_le_bytes(prefix);
    if (len as usize) < super::super::HEADER_BYTES || len as usize > max {
        return Err(FrameError::Length { len, max });
    }
    Ok(len as usize)
}

/// Writes `msg` with its length prefix (one write, so small messages go out in one segment).
pub fn write_frame(w: &mut impl Write, msg: &[u8]) -> io::Result<()> {
    let mut buf = Vec::with_capacity(PREFIX_BYTES + msg.len());
    buf.extend_from_slice(&(msg.len() as u32).to_le_bytes());
    buf.extend_from_slice(msg);
    w.write_all(&buf)
}

/// Reads one framed message of at most `max` bytes; `Ok(None)` when the peer closed
/// cleanly before a new message began.
pub fn read_frame(r: &mut impl Read, max: usize) -> Result<Option<Vec<u8>>, FrameError> {
    let mut prefix = [0u8; PREFIX_BYTES];
    let mut got = 0;
    while got < PREFIX_BYTES {
        match r.read(&mut prefix[got..]) {
            Ok(0) if got == 0 => return Ok(None),
            Ok(0) => return Err(io::Error::from(io::ErrorKind::UnexpectedEof).into()),
            Ok(n) => got += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e.into()),
        }
    }
    let len = check_length(prefix, max)?;
    let mut msg = vec![0u8; len];
    r.read_exact(&mut msg)?;
    Ok(Some(msg))
}
