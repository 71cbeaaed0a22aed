//! HTTP and WebSocket endpoints: the embedded viewer files and `/ws`.
//!
//! Requests are accepted only with a `Host` of `localhost` or an IP literal (a DNS-rebinding
//! page cannot reach the server under its own host name), and the WebSocket only from the
//! page's own origin or from non-browser clients that send no `Origin`.

use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Request, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use futures_util::{SinkExt, StreamExt};

use crate::assets;
use crate::hub::Hub;
use crate::outbox::{Kind, Outgoing};
use crate::protocol::{self, ClientMessage, ErrorCode, ProtocolError};

/// Largest WebSocket message or frame accepted at all; larger ones close the connection in
/// the WebSocket layer. Between [`protocol::MAX_CLIENT_MESSAGE`] and this, the viewer gets an
/// error reply and stays connected.
pub const MAX_WS_MESSAGE: usize = 64 * 1024;

/// The router: viewer files, `/ws`, host checks.
pub fn router(hub: Arc<Hub>) -> Router {
    Router::new()
        .route("/ws", get(ws_handler))
        .fallback(get(asset))
        .layer(middleware::from_fn(check_host))
        .with_state(hub)
}

/// Serves until the listener fails; also runs the hub's pump.
pub async fn serve(listener: tokio::net::TcpListener, hub: Arc<Hub>) -> std::io::Result<()> {
    tokio::spawn(hub.clone().pump());
    axum::serve(listener, router(hub)).await
}

fn host_of(authority: &str) -> &str {
    // "[::1]:8080" → "[::1]", "localhost:80" → "localhost".
    if authority.starts_with('[') {
        return authority
            .split(']')
            .next()
            .map_or(authority, |h| &authority[..h.len() + 1]);
    }
    authority.rsplit_once(':').map_or(authority, |(h, _)| h)
}

/// True for `localhost` and IP literals.
fn local_or_ip(host: &str) -> bool {
    let bare = host.trim_start_matches('[').trim_end_matches(']');
    host.eq_ignore_ascii_case("localhost") || bare.parse::<std::net::IpAddr>().is_ok()
}

async fn check_host(req: Request, next: Next) -> Response {
    let ok = req
        .headers()
        .get(header::HOST)
        .and_then(|h| h.to_str().ok())
        .is_some_and(|h| local_or_ip(host_of(h)));
    if !ok {
        return (StatusCode::FORBIDDEN, "host not allowed").into_response();
    }
    next.run(req).await
}

/// Same-origin check: the Origin's authority must equal the Host header.
fn origin_allowed(headers: &HeaderMap) -> bool {
    let Some(origin) = headers.get(header::ORIGIN) else {
        return true;
    };
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
    State(hub): State<Arc<Hub>>,
) -> Response {
    if !origin_allowed(&headers) {
        return (StatusCode::FORBIDDEN, "cross-origin WebSocket refused").into_response();
    }
    ws.max_message_size(MAX_WS_MESSAGE)
        .max_frame_size(MAX_WS_MESSAGE)
        .on_upgrade(move |socket| connection(socket, hub))
}

fn error_reply(e: &ProtocolError) -> Outgoing {
    Outgoing {
        kind: Kind::Control,
        bytes: Bytes::from(protocol::encode_error(e)),
    }
}

/// One viewer: a writer task drains its outbox; this task reads its messages.
async fn connection(socket: WebSocket, hub: Arc<Hub>) {
    let (id, outbox) = hub.join();
    let (mut sink, mut stream) = socket.split();
    let out = outbox.clone();
    let writer = tokio::spawn(async move {
        while let Some(m) = out.pop().await {
            if sink.send(Message::Binary(m.bytes)).await.is_err() {
                break;
            }
        }
        let _ = sink.close().await;
    });
    while let Some(msg) = stream.next().await {
        match msg {
            Ok(Message::Binary(b)) => match protocol::decode_client(&b) {
                Ok(ClientMessage::Camera(c)) => hub.set_camera(c),
                Ok(ClientMessage::Params { integrator, mode }) => hub.set_params(integrator, mode),
                Err(e) => outbox.push(error_reply(&e)),
            },
            Ok(Message::Text(_)) => outbox.push(error_reply(&ProtocolError {
                code: ErrorCode::TextMessage,
                message: "text messages are not part of the protocol; send binary".into(),
            })),
            Ok(Message::Close(_)) | Err(_) => break,
            Ok(Message::Ping(_) | Message::Pong(_)) => {}
        }
    }
    hub.leave(id);
    // The writer may be stuck sending to a peer that stopped reading; it has nothing left to do.
    writer.abort();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn host_and_origin_rules() {
        assert!(local_or_ip(host_of("127.0.0.1:8080")));
        assert!(local_or_ip(host_of("localhost:8080")));
        assert!(local_or_ip(host_of("[::1]:8080")));
        assert!(local_or_ip(host_of("192.168.1.5")));
        assert!(!local_or_ip(host_of("evil.example:8080")));
        let mut h = HeaderMap::new();
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
    }
}
