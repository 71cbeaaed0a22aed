//! Connection limits below HTTP, which axum and hyper do not set by default: a cap on open
//! connections, a deadline and a size cap for each request until the server answers, and
//! room for a real viewer when idle connections fill the cap.
//!
//! [`GuardedListener`] wraps the TCP listener; each connection is a [`GuardedStream`] that
//! fails its reads and writes once the deadline passes, so hyper drops the connection. A
//! request over the size cap is answered here, below HTTP (414, 431 or 413: [`crate::oversize`]),
//! and the rest of it is read and dropped, bounded in bytes and by the deadline. A
//! WebSocket viewer marks its connection upgraded ([`ConnHandle::mark_upgraded`]): it may then
//! stay silent as long as it likes (its writes are bounded by the viewer's stall timeout in
//! [`crate::http`]) and is never closed to make room.

use std::future::Future;
use std::io;
use std::net::SocketAddr;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{ready, Context, Poll};
use std::time::Duration;

use axum::extract::connect_info::Connected;
use axum::serve::{IncomingStream, Listener};
use futures_util::task::AtomicWaker;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::{TcpListener, TcpStream};
use tokio::time::{Instant, Sleep};

use crate::oversize::{refusal_response, HeadScan};
use crate::Limits;

/// What a connection shares with the registry and with request handlers.
#[derive(Debug)]
struct Shared {
    id: u64,
    upgraded: AtomicBool,
    evicted: AtomicBool,
    /// Wakes the connection's task when it is evicted while waiting for data.
    waker: AtomicWaker,
}

/// The connection a request arrived on, given to handlers as `ConnectInfo<ConnHandle>`.
#[derive(Clone, Debug)]
pub struct ConnHandle(Arc<Shared>);

impl ConnHandle {
    /// Marks the connection as a WebSocket viewer: no request deadline or size cap any more,
    /// and never closed to make room for another connection.
    pub fn mark_upgraded(&self) {
        self.0.upgraded.store(true, Ordering::SeqCst);
    }
}

impl Connected<IncomingStream<'_, GuardedListener>> for ConnHandle {
    fn connect_info(stream: IncomingStream<'_, GuardedListener>) -> Self {
        ConnHandle(stream.io().shared.clone())
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Open connections in accept order.
#[derive(Debug, Default)]
struct Registry {
    conns: Mutex<Vec<Arc<Shared>>>,
    next_id: AtomicU64,
}

impl Registry {
    /// Registers a new connection, evicting the oldest non-viewer if the cap is reached; None
    /// when every slot is held by a viewer.
    fn admit(&self, max: usize) -> Option<Arc<Shared>> {
        let mut conns = lock(&self.conns);
        let live = conns
            .iter()
            .filter(|c| !c.evicted.load(Ordering::SeqCst))
            .count();
        if live >= max {
            // Oldest first: a connection that has been waiting longest without finishing a
            // request is the likeliest to be idle or hostile, and a new one may be a viewer.
            let victim = conns.iter().find(|c| {
                !c.upgraded.load(Ordering::SeqCst) && !c.evicted.load(Ordering::SeqCst)
            })?;
            victim.evicted.store(true, Ordering::SeqCst);
            victim.waker.wake();
        }
        let shared = Arc::new(Shared {
            id: self.next_id.fetch_add(1, Ordering::Relaxed),
            upgraded: AtomicBool::new(false),
            evicted: AtomicBool::new(false),
            waker: AtomicWaker::new(),
        });
        conns.push(shared.clone());
        Some(shared)
    }

    fn remove(&self, id: u64) {
        lock(&self.conns).retain(|c| c.id != id);
    }

    fn len(&self) -> usize {
        lock(&self.conns).len()
    }
}

/// A TCP listener that enforces [`Limits::max_connections`], [`Limits::request_timeout`] and
/// [`Limits::max_request_bytes`].
pub struct GuardedListener {
    inner: TcpListener,
    registry: Arc<Registry>,
    limits: Limits,
}

impl GuardedListener {
    /// Wraps `inner`.
    pub fn new(inner: TcpListener, limits: Limits) -> Self {
        Self {
            inner,
            registry: Arc::default(),
            limits,
        }
    }

    /// A handle that counts this listener's open connections, for tests and tools.
    pub fn counter(&self) -> ConnectionCounter {
        ConnectionCounter(self.registry.clone())
    }
}

/// Counts the open connections of a [`GuardedListener`].
#[derive(Clone, Debug)]
pub struct ConnectionCounter(Arc<Registry>);

impl ConnectionCounter {
    /// Connections open now (including ones told to close that have not yet closed).
    pub fn open(&self) -> usize {
        self.0.len()
    }
}

/// Errors that concern one connection only; the listener goes on at once.
fn per_connection(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::ConnectionRefused
            | io::ErrorKind::ConnectionAborted
            | io::ErrorKind::ConnectionReset
    )
}

impl Listener for GuardedListener {
    type Io = GuardedStream;
    type Addr = SocketAddr;

    async fn accept(&mut self) -> (Self::Io, Self::Addr) {
        loop {
            let (stream, addr) = match self.inner.accept().await {
                Ok(x) => x,
                Err(e) if per_connection(&e) => continue,
                Err(_) => {
                    // Out of file descriptors or similar: retrying at once would spin.
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            };
            let Some(shared) = self.registry.admit(self.limits.max_connections) else {
                // Every slot is a viewer: refuse by closing at once.
                drop(stream);
                continue;
            };
            let _ = stream.set_nodelay(true);
            let io = GuardedStream {
                inner: stream,
                shared,
                registry: self.registry.clone(),
                deadline: Box::pin(tokio::time::sleep(self.limits.request_timeout)),
                timeout: self.limits.request_timeout,
                max_request_bytes: self.limits.max_request_bytes,
                unanswered: 0,
                scan: HeadScan::default(),
                refusal: None,
            };
            return (io, addr);
        }
    }

    fn local_addr(&self) -> io::Result<SocketAddr> {
        self.inner.local_addr()
    }
}

/// One connection: a TCP stream with a request deadline, a request size cap and eviction.
pub struct GuardedStream {
    inner: TcpStream,
    shared: Arc<Shared>,
    registry: Arc<Registry>,
    deadline: Pin<Box<Sleep>>,
    timeout: Duration,
    max_request_bytes: usize,
    /// Bytes read since the server last wrote.
    unanswered: usize,
    /// How far those bytes got in a request.
    scan: HeadScan,
    /// A request over the size cap, being refused.
    refusal: Option<Refusal>,
}

/// The answer to a request over the size cap, and what was done with it.
struct Refusal {
    /// The complete HTTP response.
    response: Vec<u8>,
    /// Bytes of it written.
    written: usize,
    /// The write side is shut (the client sees the end of the answer).
    shut: bool,
    /// Bytes of the request read and dropped since.
    drained: usize,
}

/// Bytes of an oversized request read and dropped after the refusal, at most: enough for the
/// rest of a large header block, so that closing with unread input (a TCP reset) does not
/// destroy the answer in flight, without reading a flood for ever.
const DRAIN_LIMIT: usize = 1 << 20;

/// The error that ends a refused connection.
fn refused() -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        "request larger than the request size cap",
    )
}

impl GuardedStream {
    fn upgraded(&self) -> bool {
        self.shared.upgraded.load(Ordering::SeqCst)
    }

    /// Fails once evicted or, before an upgrade, once the request deadline has passed. Also
    /// arms the wake-ups for both, so a connection that waits for data notices them.
    fn check(&mut self, cx: &mut Context<'_>) -> io::Result<()> {
        self.shared.waker.register(cx.waker());
        if self.shared.evicted.load(Ordering::SeqCst) {
            return Err(io::Error::new(
                io::ErrorKind::ConnectionAborted,
                "closed to make room for a new connection",
            ));
        }
        if !self.upgraded() && self.deadline.as_mut().poll(cx).is_ready() {
            return Err(io::Error::new(
                io::ErrorKind::TimedOut,
                "no complete request within the request timeout",
            ));
        }
        Ok(())
    }
}

impl Drop for GuardedStream {
    fn drop(&mut self) {
        self.registry.remove(self.shared.id);
    }
}

impl AsyncRead for GuardedStream {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        self.check(cx)?;
        if self.refusal.is_some() {
            return self.poll_refuse(cx);
        }
        let before = buf.filled().len();
        ready!(Pin::new(&mut self.inner).poll_read(cx, buf))?;
        if !self.upgraded() {
            let new = &buf.filled()[before..];
            // How far the request got within the cap decides the answer (one read may hold
            // all of it).
            let room = self.max_request_bytes.saturating_sub(self.unanswered);
            self.scan.feed(&new[..new.len().min(room)]);
            self.unanswered += new.len();
            if self.unanswered > self.max_request_bytes {
                // Hyper never sees these bytes: the request is answered here.
                buf.set_filled(before);
                self.refusal = Some(Refusal {
                    response: refusal_response(&self.scan, self.max_request_bytes),
                    written: 0,
                    shut: false,
                    drained: 0,
                });
                return self.poll_refuse(cx);
            }
        }
        Poll::Ready(Ok(()))
    }
}

impl GuardedStream {
    /// Writes the refusal, shuts the write side, then reads and drops the rest of the request
    /// until the client closes or [`DRAIN_LIMIT`] is passed (or the deadline, in
    /// [`GuardedStream::check`]); then fails, so that hyper drops the connection. Pending
    /// while any of that waits on the socket.
    fn poll_refuse(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let Some(r) = self.refusal.as_mut() else {
            return Poll::Ready(Err(refused()));
        };
        let inner = &mut self.inner;
        while r.written < r.response.len() {
            match ready!(Pin::new(&mut *inner).poll_write(cx, &r.response[r.written..]))? {
                0 => return Poll::Ready(Err(refused())),
                n => r.written += n,
            }
        }
        if !r.shut {
            ready!(Pin::new(&mut *inner).poll_shutdown(cx))?;
            r.shut = true;
        }
        let mut scratch = [0u8; 4096];
        loop {
            let mut rb = ReadBuf::new(&mut scratch);
            ready!(Pin::new(&mut *inner).poll_read(cx, &mut rb))?;
            let n = rb.filled().len();
            r.drained += n;
            if n == 0 || r.drained > DRAIN_LIMIT {
                return Poll::Ready(Err(refused()));
            }
        }
    }
}

impl AsyncWrite for GuardedStream {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        self.check(cx)?;
        let n = ready!(Pin::new(&mut self.inner).poll_write(cx, buf))?;
        if n > 0 && !self.upgraded() {
            // The server answered: the client gets a fresh deadline for its next request,
            // which also bounds how long an idle keep-alive connection stays open.
            let at = Instant::now() + self.timeout;
            self.deadline.as_mut().reset(at);
            self.unanswered = 0;
            self.scan = HeadScan::default();
        }
        Poll::Ready(Ok(n))
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        self.check(cx)?;
        Pin::new(&mut self.inner).poll_flush(cx)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_shutdown(cx)
    }
}
