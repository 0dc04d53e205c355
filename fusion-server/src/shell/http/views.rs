//! The robots' camera views over HTTP: the list of the newest views (metadata), one camera's
//! newest view (the whole message, image included, or the JPEG alone), and a WebSocket that
//! pushes each view as it is kept.

use super::{error, json_text, pump, send_within};
use crate::shell::live::Live;
use axum::extract::ws::{WebSocket, WebSocketUpgrade};
use axum::extract::{Path, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use proto::camera_of_chunk;
use std::sync::Arc;
use std::sync::atomic::Ordering::Relaxed;

/// `GET /api/views`: the newest view of every camera, without the images, as a JSON array
/// of `CameraView`s (`jpeg_base64` empty) with the time each arrived (`received`).
pub async fn list(State(live): State<Arc<Live>>) -> Response {
    let now = live.clock.now();
    let rows: Vec<serde_json::Value> = live
        .views
        .all()
        .iter()
        .map(|v| {
            serde_json::json!({
                "view": v.meta,
                "received": v.received,
                "age_s": now.secs_since(v.received),
            })
        })
        .collect();
    json_text(serde_json::Value::Array(rows).to_string())
}

fn find(
    live: &Live,
    id: &str,
    camera: &str,
) -> Result<Arc<crate::camera_views::StoredView>, Box<Response>> {
    let Some(cam) = camera_of_chunk(camera) else {
        return Err(Box::new(error(
            StatusCode::BAD_REQUEST,
            format!("camera {camera:?} is not left or right"),
        )));
    };
    live.views.latest(id, cam).ok_or_else(|| {
        Box::new(error(
            StatusCode::NOT_FOUND,
            format!("no view of robot {id:?}'s {camera} camera"),
        ))
    })
}

/// `GET /api/robots/{id}/view/{camera}`: the camera's newest `CameraView`, image included.
pub async fn one(
    State(live): State<Arc<Live>>,
    Path((id, camera)): Path<(String, String)>,
) -> Response {
    match find(&live, &id, &camera) {
        Ok(v) => json_text(v.json.to_string()),
        Err(r) => *r,
    }
}

/// `GET /api/robots/{id}/view/{camera}/image`: the camera's newest image, a JPEG.
pub async fn image(
    State(live): State<Arc<Live>>,
    Path((id, camera)): Path<(String, String)>,
) -> Response {
    match find(&live, &id, &camera) {
        Ok(v) => (
            [
                (header::CONTENT_TYPE, "image/jpeg"),
                (header::CACHE_CONTROL, "no-store"),
            ],
            v.jpeg.to_vec(),
        )
            .into_response(),
        Err(r) => *r,
    }
}

/// `GET /api/views/stream` (WebSocket): every camera's newest view at once, then each view
/// as it is kept, as `CameraView` JSON text frames. A client that falls behind skips the
/// oldest (counted with the live stream's frames: sent, skipped); one that stops reading is
/// dropped after the stream's send timeout.
pub async fn stream(State(live): State<Arc<Live>>, ws: WebSocketUpgrade) -> Response {
    ws.on_upgrade(move |socket| serve_views(live, socket))
}

async fn serve_views(live: Arc<Live>, mut socket: WebSocket) {
    let mut rx = live.views.stream.subscribe();
    live.stats.ws_clients.fetch_add(1, Relaxed);
    let limit = live.ws_send_timeout();
    let mut open = true;
    for v in live.views.all() {
        if open {
            open = send_within(&live, &mut socket, v.json.as_ref(), limit).await;
        }
    }
    if open {
        pump(&live, &mut socket, &mut rx, limit).await;
    }
    live.stats.ws_clients.fetch_sub(1, Relaxed);
}
