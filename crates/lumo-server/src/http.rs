//! HTTP and WebSocket endpoints: the embedded viewer files and `/ws`.
//!
//! Requests are accepted only with exactly one `Host` header naming `localhost` or an IP
//! literal (a DNS-rebinding page cannot reach the server under its own host name; malformed or
//! duplicate headers get 400), and the WebSocket only from the page's own origin or from
//! non-browser clients that send no `Origin` (several `Origin` headers are refused).
//!
//! A viewer's messages are read at most [`crate::Limits::messages_per_second`] (faster senders
//! wait at their own socket); invalid ones get an ERROR reply until
//! [`crate::Limits::violation_burst`] is used up, then the viewer is closed with code 1008.

use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::ws::{CloseFrame, Message, WebSocket, WebSocketUpgrade};
use axum::extract::{ConnectInfo, Request, State};
use axum::http::{header, Extensions, HeaderMap, StatusCode};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use futures_util::{SinkExt, StreamExt};

use crate::assets;
use crate::bucket::Bucket;
use crate::conn::{ConnHandle, GuardedListener};
use crate::hub::Hub;
use crate::outbox::{Kind, Next as Queued, Outgoing, CLOSE_POLICY, CLOSE_TRY_LATER};
use crate::protocol::{self, ClientMessage, ErrorCode, Params, ProtocolError};

/// Largest WebSocket message or frame accepted at all; larger ones close the connection in
/// the WebSocket layer. Between [`protocol::MAX_CLIENT_MESSAGE`] and this, the viewer gets an
/// error reply and stays connected.
pub const MAX_WS_MESSAGE: usize = 64 * 1024;

/// The router: viewer files, `/ws`, host checks.
pub fn router(hub: Arc<Hub>) -> Router {
    Router::new()
        .route("/ws", get(ws_handler))
        .route("/workers", get(workers_json))
        .fallback(get(asset))
        .layer(middleware::from_fn(check_host))
        .with_state(hub)
}

/// Serves until the listener fails; also runs the hub's pump. Connections go through a
/// [`GuardedListener`] with the hub's [`crate::Limits`].
pub async fn serve(listener: tokio::net::TcpListener, hub: Arc<Hub>) -> std::io::Result<()> {
    serve_guarded(GuardedListener::new(listener, hub.limits().clone()), hub).await
}

/// [`serve`] on a listener made by the caller (to watch its connection count).
pub async fn serve_guarded(listener: GuardedListener, hub: Arc<Hub>) -> std::io::Result<()> {
    tokio::spawn(hub.clone().pump());
    let app = router(hub).into_make_service_with_connect_info::<ConnHandle>();
    axum::serve(listener, app).await
}

/// Why a request's `Host` header was refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum HostError {
    /// No `Host` header (HTTP/1.1 requires one).
    #[error("no Host header")]
    Missing,
    /// More than one `Host` header: which one a proxy or browser meant is ambiguous.
    #[error("more than one Host header")]
    Duplicate,
    /// Not `host[:port]` with a valid host and a decimal port.
    #[error("malformed Host header")]
    Malformed,
    /// Well-formed, but neither `localhost` nor an IP literal.
    #[error("host {0:?} is not localhost or an IP address")]
    NotAllowed(String),
}

impl HostError {
    fn status(&self) -> StatusCode {
        match self {
            HostError::NotAllowed(_) => StatusCode::FORBIDDEN,
            _ => StatusCode::BAD_REQUEST,
        }
    }
}

/// Checks a `Host` value strictly (RFC 9110 `uri-host [":" port]`, nothing else: no user
/// info, no path) and accepts only `localhost` and IP literals.
pub fn check_host_value(value: &str) -> Result<(), HostError> {
    let (host, port) = if let Some(rest) = value.strip_prefix('[') {
        let (inside, after) = rest.split_once(']').ok_or(HostError::Malformed)?;
        inside
            .parse::<std::net::Ipv6Addr>()
            .map_err(|_| HostError::Malformed)?;
        let port = match after {
            "" => None,
            p => Some(p.strip_prefix(':').ok_or(HostError::Malformed)?),
        };
        (None, port)
    } else {
        match value.split_once(':') {
            Some((h, p)) => (Some(h), Some(p)),
            None => (Some(value), None),
        }
    };
    if let Some(p) = port {
        if p.is_empty() || !p.bytes().all(|b| b.is_ascii_digit()) || p.parse::<u16>().is_err() {
            return Err(HostError::Malformed);
        }
    }
    let Some(host) = host else {
        // A bracketed IPv6 literal, already parsed.
        return Ok(());
    };
    if host.eq_ignore_ascii_case("localhost") || host.parse::<std::net::Ipv4Addr>().is_ok() {
        return Ok(());
    }
    let name_chars = |b: u8| b.is_ascii_alphanumeric() || b == b'-' || b == b'.';
    if host.is_empty() || !host.bytes().all(name_chars) {
        return Err(HostError::Malformed);
    }
    Err(HostError::NotAllowed(host.to_string()))
}

/// Checks that a request has exactly one acceptable `Host` header.
pub fn check_host_headers(headers: &HeaderMap) -> Result<(), HostError> {
    let mut all = headers.get_all(header::HOST).iter();
    let first = all.next().ok_or(HostError::Missing)?;
    if all.next().is_some() {
        return Err(HostError::Duplicate);
    }
    check_host_value(first.to_str().map_err(|_| HostError::Malformed)?)
}

async fn check_host(req: Request, next: Next) -> Response {
    if let Err(e) = check_host_headers(req.headers()) {
        return (e.status(), e.to_string()).into_response();
    }
    next.run(req).await
}

/// Same-origin check: the Origin's authority must equal the Host header. Several `Origin`
/// headers are refused, as several `Host`s are: the check read the first while another layer
/// might act on the second (a WebSocket upgrade with two was accepted on the first).
fn origin_allowed(headers: &HeaderMap) -> bool {
    let mut all = headers.get_all(header::ORIGIN).iter();
    let Some(origin) = all.next() else {
        return true;
    };
    if all.next().is_some() {
        return false;
    }
    let (Ok(origin), Some(Ok(host))) = (
        origin.to_str(),
        headers.get(header::HOST).map(|h| h.to_str()),
    ) else {
        return false;
    };
    origin
        .strip_prefix("http://")
        .or_else(|| origin.strip_prefix("https://"))
        .is_some_and(|authority| authority.eq_ignore_ascii_case(host))
}

/// `GET /workers`: the remote render workers connected now and their counters, as JSON (for
/// scripts and tests that watch a hub; behind the same Host check as the viewer).
async fn workers_json(State(hub): State<Arc<Hub>>) -> Response {
    let workers: Vec<serde_json::Value> = hub
        .remote_workers()
        .into_iter()
        .map(|w| {
            serde_json::json!({
                "id": w.id,
                "name": w.name,
                "peer": w.peer.to_string(),
                "ready": w.ready,
                "samples": w.samples,
                "light_paths": w.light_paths,
                "batches": w.batches,
                "bytes": w.bytes,
                "old_batches": w.old_batches,
            })
        })
        .collect();
    (
        [(header::CONTENT_TYPE, "application/json")],
        serde_json::Value::Array(workers).to_string(),
    )
        .into_response()
}

async fn asset(uri: axum::http::Uri) -> Response {
    match assets::find(uri.path()) {
        Some(a) => (
            [
                (header::CONTENT_TYPE, a.content_type),
                (header::CACHE_CONTROL, "no-cache"),
            ],
            a.body,
        )
            .into_response(),
        None => (StatusCode::NOT_FOUND, "not found").into_response(),
    }
}

async fn ws_handler(
    ws: WebSocketUpgrade,
    headers: HeaderMap,
    extensions: Extensions,
    State(hub): State<Arc<Hub>>,
) -> Response {
    if !origin_allowed(&headers) {
        return (StatusCode::FORBIDDEN, "cross-origin WebSocket refused").into_response();
    }
    // Checked again, exactly, in Hub::join; refusing here spares the upgrade.
    if hub.viewer_count() >= hub.limits().max_viewers {
        return (StatusCode::SERVICE_UNAVAILABLE, "too many viewers").into_response();
    }
    // Present when served by `serve` (absent when the router runs under another listener).
    let conn = extensions
        .get::<ConnectInfo<ConnHandle>>()
        .map(|c| c.0.clone());
    ws.max_message_size(MAX_WS_MESSAGE)
        .max_frame_size(MAX_WS_MESSAGE)
        .on_upgrade(move |socket| async move {
            if let Some(c) = conn {
                c.mark_upgraded();
            }
            connection(socket, hub).await
        })
}

fn error_reply(e: &ProtocolError) -> Outgoing {
    Outgoing {
        kind: Kind::Error,
        bytes: Bytes::from(e.write()),
    }
}

fn close_message(code: u16, reason: &str) -> Message {
    Message::Close(Some(CloseFrame {
        code,
        reason: reason.into(),
    }))
}

/// Why the reading loop of a connection ended.
enum End {
    /// The peer closed or the socket failed.
    Peer,
    /// The server closes (budget exceeded, violations, stall): its close frame is queued.
    Server,
}

/// One viewer: a writer task drains its outbox; this task reads its messages.
async fn connection(socket: WebSocket, hub: Arc<Hub>) {
    let limits = hub.limits().clone();
    let (mut sink, mut stream) = socket.split();
    let Some((id, outbox)) = hub.join() else {
        let frame = close_message(CLOSE_TRY_LATER, "too many viewers");
        let _ = tokio::time::timeout(limits.close_grace, sink.send(frame)).await;
        return;
    };
    let out = outbox.clone();
    let stall = limits.write_stall_timeout;
    let mut writer = tokio::spawn(async move {
        while let Some(next) = out.pop().await {
            match next {
                Queued::Send(bytes) => {
                    match tokio::time::timeout(stall, sink.send(Message::Binary(bytes))).await {
                        Ok(Ok(())) => {}
                        // The peer is gone.
                        Ok(Err(_)) => break,
                        Err(_) => {
                            // It has not read for the whole timeout: a close frame could not
                            // get through either, so just stop.
                            out.close();
                            return;
                        }
                    }
                }
                Queued::Close(code, reason) => {
                    let _ = sink.send(close_message(code, &reason)).await;
                    return;
                }
            }
        }
        // Tell the reading side in case the writer ended first.
        out.close();
        let _ = sink.close().await;
    });
    let mut rate = Bucket::new(limits.message_burst, limits.messages_per_second);
    let mut violations = Bucket::new(limits.violation_burst, limits.violations_per_second);
    let end = loop {
        let msg = tokio::select! {
            m = stream.next() => m,
            _ = outbox.closed() => break End::Server,
        };
        let refused = match msg {
            Some(Ok(Message::Binary(b))) => match protocol::decode_client(&b) {
                Ok(ClientMessage::Camera(c)) => {
                    hub.set_camera(id, c);
                    None
                }
                Ok(ClientMessage::Params(Params { integrator, mode })) => {
                    hub.set_params(integrator, mode).err()
                }
                Ok(ClientMessage::Animate(a)) => hub.set_playing(a.playing).err(),
                Ok(ClientMessage::Pick(p)) => {
                    hub.pick(id, p);
                    None
                }
                Ok(ClientMessage::Edit(e)) => hub.set_edit(e).err(),
                Err(e) => Some(e),
            },
            Some(Ok(Message::Text(_))) => Some(ProtocolError {
                code: ErrorCode::TextMessage,
                message: "text messages are not part of the protocol; send binary".into(),
            }),
            Some(Ok(Message::Ping(_) | Message::Pong(_))) => None,
            Some(Ok(Message::Close(_)) | Err(_)) | None => break End::Peer,
        };
        if let Some(e) = refused {
            if !violations.take() {
                outbox.close_with(CLOSE_POLICY, "too many invalid messages");
                break End::Server;
            }
            outbox.push(error_reply(&e));
        }
        // Read no faster than the allowed rate: a flooding viewer is slowed down at its own
        // socket (TCP flow control) instead of queueing work for everyone.
        let wait = rate.take_or_wait();
        if !wait.is_zero() {
            tokio::select! {
                _ = tokio::time::sleep(wait) => {}
                _ = outbox.closed() => break End::Server,
            }
        }
    };
    hub.leave(id);
    if tokio::time::timeout(limits.close_grace, &mut writer)
        .await
        .is_err()
    {
        // Stuck sending to a peer that stopped reading.
        writer.abort();
    }
    if matches!(end, End::Server) {
        // Let the peer's close reply (and whatever it sent before) arrive before the socket
        // is dropped: dropping it with unread data resets the connection, and the peer might
        // lose the close frame.
        let drain = async {
            while let Some(Ok(m)) = stream.next().await {
                if matches!(m, Message::Close(_)) {
                    break;
                }
            }
        };
        let _ = tokio::time::timeout(limits.close_grace, drain).await;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn host_and_origin_rules() {
        for ok in [
            "127.0.0.1:8080",
            "localhost:8080",
            "LOCALHOST",
            "[::1]:8080",
            "[::1]",
            "192.168.1.5",
        ] {
            assert_eq!(check_host_value(ok), Ok(()), "{ok}");
        }
        assert!(matches!(
            check_host_value("evil.example:8080"),
            Err(HostError::NotAllowed(_))
        ));
        for bad in [
            "[",
            "[::1",
            "[::1]x",
            "[::1]:",
            "[evil]:80",
            "localhost:8080@evil",
            "localhost:99999",
            "localhost:-1",
            "localhost:",
            ":80",
            "",
            "local host",
            "a:b:c",
            "127.0.0.1/x",
        ] {
            assert_eq!(check_host_value(bad), Err(HostError::Malformed), "{bad:?}");
        }
        let mut h = HeaderMap::new();
        assert_eq!(check_host_headers(&h), Err(HostError::Missing));
        h.insert(header::HOST, "127.0.0.1:8080".parse().expect("header"));
        assert_eq!(check_host_headers(&h), Ok(()));
        h.append(header::HOST, "evil.example".parse().expect("header"));
        assert_eq!(check_host_headers(&h), Err(HostError::Duplicate));
        h.remove(header::HOST);
        h.insert(header::HOST, "127.0.0.1:8080".parse().expect("header"));
        assert!(origin_allowed(&h));
        h.insert(
            header::ORIGIN,
            "http://127.0.0.1:8080".parse().expect("header"),
        );
        assert!(origin_allowed(&h));
        h.insert(
            header::ORIGIN,
            "http://evil.example".parse().expect("header"),
        );
        assert!(!origin_allowed(&h));
        // Two Origins, even if the first is the page's own, are refused.
        h.insert(
            header::ORIGIN,
            "http://127.0.0.1:8080".parse().expect("header"),
        );
        h.append(
            header::ORIGIN,
            "http://evil.example".parse().expect("header"),
        );
        assert!(!origin_allowed(&h));
    }
}
