//! The hub's listener for remote workers and one task pair per worker: the handshake (hello
//! within a deadline, token, version and protocol checked, welcome, the worker's status), then
//! a writer that sends the queued edits and newest epoch state, and a reader that checks each
//! sample batch and merges it ([`Hub::merge_remote`]), read no faster than the worker's rate.
//! Whatever a worker does wrong closes its connection with a log line naming it; nothing of the
//! offending message reaches the image.

use std::io;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::{Duration, Instant};

use axum::body::Bytes;
use tokio::io::AsyncWriteExt;
use tokio::net::tcp::{OwnedReadHalf, OwnedWriteHalf};
use tokio::net::{TcpListener, TcpStream};

use super::framing_async::{read_msg, write_msg};
use super::registry::WorkerLink;
use super::token::same_token;
use super::{worker_seed, RemoteConfig, MAX_WORKER_MESSAGE};
use crate::bucket::Bucket;
use crate::hub::{Hub, Merged};
use crate::protocol::remote::{
    kind, WorkerHello, WorkerState, WorkerStatus, LUMO_VERSION, WORKER_PROTOCOL,
};
use crate::protocol::{self, ErrorCode, ProtocolError};

/// How long a refusal may take to go out before the connection is dropped.
const REFUSAL_GRACE: Duration = Duration::from_secs(1);
/// Old-epoch drops are logged at most this often per worker (they are routine after every
/// camera move; the count says how many).
const OLD_LOG_INTERVAL: Duration = Duration::from_secs(2);

/// Accepts remote workers on `listener` until it fails. Needs a hub made with
/// [`crate::ServerConfig::remote`] set.
pub async fn serve_workers(listener: TcpListener, hub: Arc<Hub>) -> io::Result<()> {
    let Some(config) = hub.remote_config().cloned() else {
        return Err(io::Error::other(
            "remote workers are off (ServerConfig::remote is None)",
        ));
    };
    let config = Arc::new(config);
    loop {
        let (stream, peer) = match listener.accept().await {
            Ok(c) => c,
            Err(e) => {
                // Out of file descriptors and the like: wait instead of spinning.
                hub.remote()
                    .log(format!("worker listener: accept failed: {e}"));
                tokio::time::sleep(Duration::from_millis(100)).await;
                continue;
            }
        };
        if !hub.remote().begin_handshake(config.max_handshakes) {
            hub.remote().log(format!(
                "worker at {peer}: refused: {} connections are already in their handshake",
                config.max_handshakes
            ));
            continue;
        }
        let (hub, config) = (hub.clone(), config.clone());
        tokio::spawn(async move {
            connection(stream, peer, &hub, &config).await;
        });
    }
}

/// Sends `e` as ERROR (best effort, briefly) and logs it naming `who`.
async fn refuse(wr: &mut OwnedWriteHalf, hub: &Hub, who: &str, e: &ProtocolError) {
    hub.remote().log(format!("{who}: refused: {}", e.message));
    let _ = tokio::time::timeout(REFUSAL_GRACE, async {
        write_msg(wr, &e.write()).await?;
        wr.shutdown().await
    })
    .await;
}

/// Checks a hello against the hub: token, protocol number, lumo version.
fn check_hello(hello: &WorkerHello, config: &RemoteConfig) -> Result<(), ProtocolError> {
    if !same_token(&hello.token, &config.token) {
        return Err(ProtocolError::new(
            ErrorCode::InvalidValue,
            "wrong token (use the one lumo serve printed)",
        ));
    }
    if hello.protocol != WORKER_PROTOCOL || hello.version != LUMO_VERSION {
        return Err(ProtocolError::new(
            ErrorCode::Version,
            format!(
                "worker runs lumo {} (worker protocol {}), the hub lumo {LUMO_VERSION} (worker \
                 protocol {WORKER_PROTOCOL}); install the same lumo on both",
                hello.version, hello.protocol
            ),
        ));
    }
    Ok(())
}

async fn connection(stream: TcpStream, peer: SocketAddr, hub: &Arc<Hub>, config: &RemoteConfig) {
    let _ = stream.set_nodelay(true);
    let (mut rd, mut wr) = stream.into_split();
    let who = format!("worker at {peer}");
    let hello = tokio::time::timeout(config.hello_timeout, read_msg(&mut rd, 1024)).await;
    let hello = match hello {
        Err(_) => Err(ProtocolError::new(
            ErrorCode::Malformed,
            format!("no hello within {:?}", config.hello_timeout),
        )),
        Ok(Ok(Some(msg))) => WorkerHello::read(&msg),
        Ok(Ok(None)) => Err(ProtocolError::new(
            ErrorCode::Malformed,
            "closed before its hello",
        )),
        Ok(Err(e)) => Err(ProtocolError::new(ErrorCode::Malformed, e.to_string())),
    };
    // A hello that decoded names the worker, refused or not.
    let who = match &hello {
        Ok(h) => format!("worker {:?} at {peer}", h.name),
        Err(_) => who,
    };
    let hello = match hello.and_then(|h| check_hello(&h, config).map(|()| h)) {
        Ok(h) => h,
        Err(e) => {
            hub.remote().end_handshake();
            refuse(&mut wr, hub, &who, &e).await;
            return;
        }
    };
    let Some(link) = hub.remote().register(hello.name.clone(), peer) else {
        hub.remote().end_handshake();
        let e = ProtocolError::new(
            ErrorCode::TooLarge,
            format!("the hub has {} workers already", config.max_workers),
        );
        refuse(&mut wr, hub, &who, &e).await;
        return;
    };
    hub.remote().end_handshake();
    let who = format!("worker {:?} (#{}) at {peer}", hello.name, link.id);
    let ended = match welcome(&mut rd, &mut wr, hub, config, &link).await {
        Ok(threads) => {
            link.set_ready();
            hub.remote()
                .log(format!("{who}: joined, {threads} render threads"));
            serve_ready(rd, wr, hub, config, &link, &who).await
        }
        Err(e) => e,
    };
    hub.remote().remove(link.id);
    link.close();
    hub.remote().log(format!("{who}: {ended}"));
}

/// Sends WELCOME and waits for the worker's STATUS; returns its threads, or why it ended.
async fn welcome(
    rd: &mut OwnedReadHalf,
    wr: &mut OwnedWriteHalf,
    hub: &Hub,
    config: &RemoteConfig,
    link: &WorkerLink,
) -> Result<u16, String> {
    let msg = hub
        .welcome(link.id as u32, worker_seed(hub.seed(), link.id))
        .ok_or("cannot be welcomed: remote workers are off")?
        .write()
        .map_err(|e| format!("cannot be welcomed: {}", e.message))?;
    write_msg(wr, &msg)
        .await
        .map_err(|e| format!("left during the handshake: {e}"))?;
    let status = tokio::time::timeout(config.load_timeout, read_msg(rd, 1024)).await;
    let status = match status {
        Err(_) => return Err(format!("not ready within {:?}", config.load_timeout)),
        Ok(Ok(Some(msg))) => WorkerStatus::read(&msg).map_err(|e| format!("refused: {e}"))?,
        Ok(Ok(None)) => return Err("left while loading the scene".into()),
        Ok(Err(e)) => return Err(format!("refused: {e}")),
    };
    match status.state {
        WorkerState::Ready => Ok(status.threads),
        s => Err(format!("{}: {}", s.label(), status.message)),
    }
}

/// The running connection: a writer task for the hub's messages, this task reading batches.
async fn serve_ready(
    mut rd: OwnedReadHalf,
    wr: OwnedWriteHalf,
    hub: &Arc<Hub>,
    config: &RemoteConfig,
    link: &Arc<WorkerLink>,
    who: &str,
) -> String {
    let writer = tokio::spawn(write_loop(wr, link.clone(), config.write_stall_timeout));
    let mut rate = Bucket::new(config.samples_per_second, config.samples_per_second);
    let mut last_old_log: Option<Instant> = None;
    let ended = loop {
        let msg = tokio::select! {
            m = read_msg(&mut rd, MAX_WORKER_MESSAGE) => m,
            _ = link.closed() => break "dropped (its socket accepted nothing)".to_string(),
        };
        let msg = match msg {
            Ok(Some(m)) => m,
            Ok(None) => break "left".to_string(),
            Err(e) => break format!("refused, disconnected: {e}"),
        };
        let cost = match msg.first().copied() {
            Some(protocol::kind::SAMPLES) => match hub.merge_remote(Bytes::from(msg)) {
                Ok(Merged::Accepted {
                    samples,
                    light_paths,
                    bytes,
                }) => {
                    link.count(samples, light_paths, bytes);
                    (samples + light_paths) as f64
                }
                Ok(Merged::Old { epoch, current }) => {
                    let n = link.count_old();
                    if last_old_log.is_none_or(|t| t.elapsed() >= OLD_LOG_INTERVAL) {
                        last_old_log = Some(Instant::now());
                        hub.remote().log(format!(
                            "{who}: dropped a batch of old epoch {epoch} (current {current}; \
                             {n} so far)"
                        ));
                    }
                    1.0
                }
                Err(e) => break format!("refused, disconnected: {}", e.message),
            },
            Some(kind::STATUS) => match WorkerStatus::read(&msg) {
                Ok(s) => break format!("stopped: {}: {}", s.state.label(), s.message),
                Err(e) => break format!("refused, disconnected: {}", e.message),
            },
            Some(k) => break format!("refused, disconnected: unexpected message type {k:#04x}"),
            None => break "refused, disconnected: empty message".to_string(),
        };
        // Read no faster than the worker's rate: a faster one waits at its own socket.
        let wait = rate.take_n_or_wait(cost);
        if !wait.is_zero() {
            tokio::select! {
                _ = tokio::time::sleep(wait) => {}
                _ = link.closed() => break "dropped (its socket accepted nothing)".to_string(),
            }
        }
    };
    link.close();
    // A writer stuck on a worker that does not read ends at its stall timeout.
    let _ = tokio::time::timeout(REFUSAL_GRACE, writer).await;
    ended
}

/// Sends what the hub queues for the worker, edits before the newest state, until closed.
async fn write_loop(mut wr: OwnedWriteHalf, link: Arc<WorkerLink>, stall: Duration) {
    loop {
        let (edits, state) = link.take();
        let msgs = edits
            .iter()
            .map(|e| e.write())
            .chain(state.map(|s| s.write()));
        for m in msgs {
            match tokio::time::timeout(stall, write_msg(&mut wr, &m)).await {
                Ok(Ok(())) => {}
                _ => {
                    link.close();
                    return;
                }
            }
        }
        tokio::select! {
            _ = link.queued() => {}
            _ = link.closed() => break,
        }
    }
    let _ = tokio::time::timeout(REFUSAL_GRACE, wr.shutdown()).await;
}
