//! The replay's control endpoints: `GET /api/replay` for where it stands, and
//! `POST /api/replay/{pause,play,seek,speed}` to steer it.
//!
//! Steering is refused unless the request is allowed by the server's [`ControlAccess`]:
//! from this machine only (the default), or with `Authorization: Bearer TOKEN` when the
//! server has a control token. A request a browser sends from a page of another origin
//! (its `Origin` header names another host than `Host`) is refused too, so a web page
//! cannot steer the replay through the coach's browser.

use super::error;
use crate::shell::live::{ControlAccess, Live};
use crate::shell::replay_control::{ControlError, ReplayControl};
use axum::body::Bytes;
use axum::extract::{ConnectInfo, Path, State};
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::{Json, extract::Request};
use serde::Deserialize;
use std::net::SocketAddr;
use std::sync::Arc;

const NOT_REPLAYING: &str = "this server is not replaying a match log";

/// A refused request: its status and the message of its `{"error": …}` body.
#[derive(Debug)]
struct Refusal {
    status: StatusCode,
    message: String,
}

fn refuse(status: StatusCode, message: impl ToString) -> Refusal {
    Refusal {
        status,
        message: message.to_string(),
    }
}

impl IntoResponse for Refusal {
    fn into_response(self) -> Response {
        let mut r = error(self.status, self.message);
        if self.status == StatusCode::UNAUTHORIZED {
            r.headers_mut().insert(
                header::WWW_AUTHENTICATE,
                header::HeaderValue::from_static("Bearer"),
            );
        }
        r
    }
}

fn control(live: &Live) -> Result<&Arc<ReplayControl>, Refusal> {
    live.replay()
        .ok_or_else(|| refuse(StatusCode::NOT_FOUND, NOT_REPLAYING))
}

/// `GET /api/replay`.
pub async fn status(State(live): State<Arc<Live>>) -> Response {
    match control(&live) {
        Ok(c) => Json(c.status()).into_response(),
        Err(r) => r.into_response(),
    }
}

/// Compares without stopping at the first difference.
fn same_secret(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |d, (x, y)| d | (x ^ y)) == 0
}

/// The host (and port) an `Origin` header names: `http://host:port` → `host:port`.
fn origin_host(origin: &str) -> &str {
    origin.split_once("://").map_or(origin, |(_, h)| h)
}

/// Whether `Host` (`name:port`, `[v6]:port`) names this machine by a loopback address.
fn loopback_host(host: &str) -> bool {
    let name = match host.rsplit_once(':') {
        Some((name, port)) if port.chars().all(|c| c.is_ascii_digit()) => name,
        _ => host,
    };
    let name = name.trim_start_matches('[').trim_end_matches(']');
    name.eq_ignore_ascii_case("localhost")
        || name
            .parse::<std::net::IpAddr>()
            .is_ok_and(|ip| ip.is_loopback())
}

/// Whether this request may steer the replay; the refusal otherwise.
fn allowed(
    access: &ControlAccess,
    headers: &HeaderMap,
    peer: Option<SocketAddr>,
) -> Result<(), Refusal> {
    let text = |h: header::HeaderName| headers.get(h).and_then(|v| v.to_str().ok());
    if let (Some(origin), Some(host)) = (text(header::ORIGIN), text(header::HOST))
        && origin_host(origin) != host
    {
        return Err(refuse(
            StatusCode::FORBIDDEN,
            format!("control requests from pages of another origin ({origin}) are refused"),
        ));
    }
    match access {
        ControlAccess::Token(token) => {
            let given = text(header::AUTHORIZATION).and_then(|a| a.strip_prefix("Bearer "));
            match given {
                Some(g) if same_secret(g.trim().as_bytes(), token.as_bytes()) => Ok(()),
                _ => Err(refuse(
                    StatusCode::UNAUTHORIZED,
                    "this server's control needs its token: Authorization: Bearer TOKEN",
                )),
            }
        }
        ControlAccess::LoopbackOnly => match peer {
            // A page whose own name was pointed at this machine (DNS rebinding) comes from
            // loopback too, but not with a loopback name in `Host`.
            Some(p) if p.ip().is_loopback() && text(header::HOST).is_some_and(loopback_host) => {
                Ok(())
            }
            Some(p) if p.ip().is_loopback() => Err(refuse(
                StatusCode::FORBIDDEN,
                "control from this machine must address the server as localhost or by a \
                 loopback address",
            )),
            _ => Err(refuse(
                StatusCode::FORBIDDEN,
                format!(
                    "control is refused from {}: without --control-token only this machine may \
                     steer the replay",
                    peer.map_or("an unknown address".into(), |p| p.ip().to_string())
                ),
            )),
        },
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SeekBody {
    t_s: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SpeedBody {
    speed: f64,
}

fn parse_body<T: serde::de::DeserializeOwned>(bytes: &[u8], example: &str) -> Result<T, Refusal> {
    serde_json::from_slice(bytes).map_err(|e| {
        refuse(
            StatusCode::BAD_REQUEST,
            format!("the body must be JSON such as {example}: {e}"),
        )
    })
}

/// `POST /api/replay/{action}`.
pub async fn steer(
    State(live): State<Arc<Live>>,
    Path(action): Path<String>,
    request: Request,
) -> Response {
    let peer = request
        .extensions()
        .get::<ConnectInfo<SocketAddr>>()
        .map(|c| c.0);
    let (parts, raw) = request.into_parts();
    if let Err(r) = allowed(live.control_access(), &parts.headers, peer) {
        return r.into_response();
    }
    let c = match control(&live) {
        Ok(c) => c,
        Err(r) => return r.into_response(),
    };
    let bytes: Bytes = match axum::body::to_bytes(raw, 4096).await {
        Ok(b) => b,
        Err(e) => return error(StatusCode::BAD_REQUEST, format!("reading the body: {e}")),
    };
    let done: Result<(), ControlError> = match action.as_str() {
        "pause" => {
            c.pause();
            Ok(())
        }
        "play" => {
            c.play();
            Ok(())
        }
        "seek" => match parse_body::<SeekBody>(&bytes, r#"{"t_s": 12.5}"#) {
            Ok(b) => c.seek(b.t_s),
            Err(r) => return r.into_response(),
        },
        "speed" => match parse_body::<SpeedBody>(&bytes, r#"{"speed": 2}"#) {
            Ok(b) => c.set_speed(b.speed),
            Err(r) => return r.into_response(),
        },
        other => {
            return error(
                StatusCode::NOT_FOUND,
                format!("no replay action {other:?}: pause, play, seek or speed"),
            );
        }
    };
    match done {
        Ok(()) => Json(c.status()).into_response(),
        Err(e) => error(StatusCode::BAD_REQUEST, e),
    }
}

#[cfg(test)]
mod tests;
