//! The HTTP face of the server: the JSON API, the live WebSocket stream, health, metrics and
//! the coach's page (embedded at build time), and the replay's control endpoints.

use crate::query::{self, BallQuery, QueryError};
use crate::shell::live::Live;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Query, State};
use axum::http::{StatusCode, Uri, header};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use std::sync::Arc;
use std::sync::atomic::Ordering::Relaxed;
use tokio::sync::broadcast::error::RecvError;

const HTML: &str = "text/html; charset=utf-8";
const JS: &str = "text/javascript; charset=utf-8";

/// The coach's page and its assets: (path, content type, bytes). Plain files, no build
/// step; embedded so the page works offline from the binary alone.
const WEB: &[(&str, &str, &[u8])] = &[
    ("/", HTML, include_bytes!("../../../web/index.html")),
    (
        "/index.html",
        HTML,
        include_bytes!("../../../web/index.html"),
    ),
    ("/app.js", JS, include_bytes!("../../../web/app.js")),
    ("/pitch.js", JS, include_bytes!("../../../web/pitch.js")),
    ("/panel.js", JS, include_bytes!("../../../web/panel.js")),
    ("/replay.js", JS, include_bytes!("../../../web/replay.js")),
    ("/chart.js", JS, include_bytes!("../../../web/chart.js")),
    ("/labels.js", JS, include_bytes!("../../../web/labels.js")),
    ("/views.js", JS, include_bytes!("../../../web/views.js")),
    ("/camera.js", JS, include_bytes!("../../../web/camera.js")),
    (
        "/page.css",
        "text/css; charset=utf-8",
        include_bytes!("../../../web/page.css"),
    ),
    (
        "/favicon.svg",
        "image/svg+xml",
        include_bytes!("../../../web/favicon.svg"),
    ),
    // Browsers ask for it by this name when a page names none.
    (
        "/favicon.ico",
        "image/svg+xml",
        include_bytes!("../../../web/favicon.svg"),
    ),
];

/// The router over the live server state.
pub fn app(live: Arc<Live>) -> Router {
    Router::new()
        .route("/api/state", get(state))
        .route("/api/robots", get(robots))
        .route("/api/history", get(history))
        .route("/api/predict", get(predict))
        .route("/api/intercept", get(intercept))
        .route("/api/stream", get(stream))
        .route("/api/views", get(views::list))
        .route("/api/views/stream", get(views::stream))
        .route("/api/robots/{id}/view/{camera}", get(views::one))
        .route("/api/robots/{id}/view/{camera}/image", get(views::image))
        .route("/api/replay", get(control::status))
        .route("/api/replay/{action}", post(control::steer))
        .route("/healthz", get(health))
        .route("/metrics", get(metrics))
        .fallback(get(web))
        .with_state(live)
}

fn json_text(body: String) -> Response {
    ([(header::CONTENT_TYPE, "application/json")], body).into_response()
}

fn error(status: StatusCode, msg: impl ToString) -> Response {
    (
        status,
        Json(serde_json::json!({ "error": msg.to_string() })),
    )
        .into_response()
}

async fn state(State(live): State<Arc<Live>>) -> Response {
    (
        [(header::CONTENT_TYPE, "application/json")],
        live.current_view().to_string(),
    )
        .into_response()
}

async fn history(State(live): State<Arc<Live>>) -> Response {
    json_text(live.history_json())
}

async fn robots(State(live): State<Arc<Live>>) -> Response {
    json_text(live.robots_json())
}

fn answer(live: &Live, q: Result<BallQuery, QueryError>) -> Response {
    let reply = q.and_then(|q| live.query(&q));
    match reply {
        Ok(r) => ([(header::CONTENT_TYPE, "application/json")], r.to_json()).into_response(),
        Err(e) if e.is_bad_request() => error(StatusCode::BAD_REQUEST, e),
        Err(e) => error(StatusCode::NOT_FOUND, e),
    }
}

/// The query's `name=value` pairs, its size checked before it is parsed (an oversized one
/// is counted as a rejected `query`, reason `too_large`).
fn params(live: &Live, uri: &Uri) -> Result<Vec<(String, String)>, (StatusCode, String)> {
    let raw = uri.query().unwrap_or_default();
    if let Err(e) = query::check_size(raw) {
        live.count_rejection("query", "too_large");
        return Err((StatusCode::URI_TOO_LONG, e.to_string()));
    }
    match Query::<Vec<(String, String)>>::try_from_uri(uri) {
        Ok(Query(p)) => Ok(p),
        Err(e) => Err((StatusCode::BAD_REQUEST, e.body_text())),
    }
}

fn pairs(p: &[(String, String)]) -> impl Iterator<Item = (&str, &str)> {
    p.iter().map(|(k, v)| (k.as_str(), v.as_str()))
}

async fn predict(State(live): State<Arc<Live>>, uri: Uri) -> Response {
    let p = match params(&live, &uri) {
        Ok(p) => p,
        Err((status, why)) => return error(status, why),
    };
    let q = query::parse(pairs(&p)).and_then(|q| match q {
        BallQuery::Predict { .. } => Ok(q),
        BallQuery::Intercept { .. } => Err(QueryError::Unknown("robot".into())),
    });
    answer(&live, q)
}

async fn intercept(State(live): State<Arc<Live>>, uri: Uri) -> Response {
    let p = match params(&live, &uri) {
        Ok(p) => p,
        Err((status, why)) => return error(status, why),
    };
    let q = query::parse(pairs(&p)).and_then(|q| match q {
        BallQuery::Intercept { .. } => Ok(q),
        BallQuery::Predict { .. } => Err(QueryError::Unknown("t".into())),
    });
    answer(&live, q)
}

async fn health(State(live): State<Arc<Live>>) -> Response {
    let (robots_online, ball) = live.with_engine(|e| {
        let now = live.clock.now();
        let online = e.robots(now).iter().filter(|r| r.online).count();
        (online, e.ball_state(now).map(|b| b.status))
    });
    Json(serde_json::json!({
        "status": "ok",
        "robots_online": robots_online,
        "ball": ball,
    }))
    .into_response()
}

async fn metrics(State(live): State<Arc<Live>>) -> Response {
    (
        [(
            header::CONTENT_TYPE,
            "application/openmetrics-text; version=1.0.0; charset=utf-8",
        )],
        live.metrics_text(),
    )
        .into_response()
}

async fn web(uri: Uri) -> Response {
    match WEB.iter().find(|(p, _, _)| *p == uri.path()) {
        Some((_, ty, body)) => ([(header::CONTENT_TYPE, *ty)], *body).into_response(),
        None => error(
            StatusCode::NOT_FOUND,
            format!("no such page: {}", uri.path()),
        ),
    }
}

async fn stream(State(live): State<Arc<Live>>, ws: WebSocketUpgrade) -> Response {
    ws.on_upgrade(move |socket| serve_stream(live, socket))
}

/// Pushes every published state to one client. The broadcast buffer is bounded: a client
/// that cannot keep up skips frames (counted) and the publisher never waits for it.
async fn serve_stream(live: Arc<Live>, mut socket: WebSocket) {
    let mut rx = live.stream.subscribe();
    live.stats.ws_clients.fetch_add(1, Relaxed);
    let limit = live.ws_send_timeout();
    let first = live.current_view().to_string();
    if send_within(&live, &mut socket, first, limit).await {
        pump(&live, &mut socket, &mut rx, limit).await;
    }
    live.stats.ws_clients.fetch_sub(1, Relaxed);
}

/// Sends each frame of `rx` to the client until it goes away or is too slow; frames it
/// skipped or lost with it are counted.
async fn pump(
    live: &Live,
    socket: &mut WebSocket,
    rx: &mut tokio::sync::broadcast::Receiver<Arc<str>>,
    limit: std::time::Duration,
) {
    let mut open = true;
    while open {
        tokio::select! {
            frame = rx.recv() => match frame {
                Ok(f) => {
                    open = send_within(live, socket, f.as_ref(), limit).await;
                    if open {
                        live.stats.ws_frames_sent.fetch_add(1, Relaxed);
                    } else {
                        // Frames published for it meanwhile are lost with it.
                        live.stats.ws_frames_dropped.fetch_add(rx.len() as u64, Relaxed);
                    }
                }
                Err(RecvError::Lagged(n)) => {
                    live.stats.ws_frames_dropped.fetch_add(n, Relaxed);
                }
                Err(RecvError::Closed) => open = false,
            },
            incoming = socket.recv() => {
                open = matches!(incoming, Some(Ok(m)) if !matches!(m, Message::Close(_)));
            }
        }
    }
}

/// Sends one frame within `limit`; false when the client is gone or too slow (then it is
/// dropped: a stuck client must not hold a growing send buffer).
async fn send_within(
    live: &Live,
    socket: &mut WebSocket,
    frame: impl Into<axum::extract::ws::Utf8Bytes>,
    limit: std::time::Duration,
) -> bool {
    match tokio::time::timeout(limit, socket.send(Message::Text(frame.into()))).await {
        Ok(sent) => sent.is_ok(),
        Err(_) => {
            live.stats.ws_send_timeouts.fetch_add(1, Relaxed);
            live.stats.ws_frames_dropped.fetch_add(1, Relaxed);
            false
        }
    }
}

mod control;
pub mod guard;
mod views;

#[cfg(test)]
mod tests;
