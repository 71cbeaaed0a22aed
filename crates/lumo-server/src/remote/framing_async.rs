//! The hub's side of the worker framing ([`crate::protocol::remote::framing`]) on tokio sockets.

use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};

use crate::protocol::remote::framing::{check_length, FrameError, PREFIX_BYTES};

/// Reads one framed message of at most `max` bytes; `Ok(None)` when the peer closed before
/// a new message began. The length is checked before anything is allocated.
pub(crate) async fn read_msg(
    r: &mut (impl AsyncRead + Unpin),
    max: usize,
) -> Result<Option<Vec<u8>>, FrameError> {
    let mut prefix = [0u8; PREFIX_BYTES];
    if r.read(&mut prefix[..1]).await? == 0 {
        return Ok(None);
    }
    r.read_exact(&mut prefix[1..]).await?;
    let len = check_length(prefix, max)?;
    let mut msg = vec![0u8; len];
    r.read_exact(&mut msg).await?;
    Ok(Some(msg))
}

/// Writes `msg` with its length prefix.
pub(crate) async fn write_msg(
    w: &mut (impl AsyncWrite + Unpin),
    msg: &[u8],
) -> std::io::Result<()> {
    let mut buf = Vec::with_capacity(PREFIX_BYTES + msg.len());
    buf.extend_from_slice(&(msg.len() as u32).to_le_bytes());
    buf.extend_from_slice(msg);
    w.write_all(&buf).await
}
