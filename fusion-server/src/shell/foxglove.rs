//! The match live in Foxglove: a server of the Foxglove WebSocket protocol
//! (`foxglove.websocket.v1`) streaming the scene ([`crate::scene`]) and the raw channels
//! (observations, statuses, ball states) as the match log holds them.
//!
//! The [`FoxgloveHub`] ([`super::foxglove_hub`]) keeps the channel table and hands each
//! message to every connected client through one bounded broadcast queue: the publisher
//! never waits for a client. A
//! client that falls behind skips the oldest messages (counted); one that stops reading is
//! dropped once a send takes longer than the stream's send timeout (counted), like the
//! page's live stream. At most [`MAX_CLIENTS`] are served at once.
//!
//! The protocol, as far as a live view needs it: the server sends `serverInfo` and
//! `advertise` (JSON text), the client `subscribe`s and `unsubscribe`s channels, and each
//! message goes out as a binary frame: opcode 1, the subscription id (u32), the log time
//! (u64 nanoseconds), the payload (little-endian).

use crate::shell::foxglove_hub::{Channel, Event, FoxgloveHub};
use crate::shell::live::Live;
use axum::Router;
use axum::extract::State;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use serde::Deserialize;
use serde_json::json;
use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::Ordering::Relaxed;
use std::time::Duration;
use tokio::sync::broadcast::error::RecvError;

/// The WebSocket subprotocol clients ask for.
pub const SUBPROTOCOL: &str = "foxglove.websocket.v1";
/// Clients served at once; more are refused (HTTP 503).
pub const MAX_CLIENTS: u64 = 32;
/// Subscriptions one client may hold.
const MAX_SUBSCRIPTIONS: usize = 4096;
/// The largest request a client may send.
const MAX_REQUEST_BYTES: usize = 64 << 10;

/// The Foxglove WebSocket server's routes (any path upgrades).
pub fn app(live: Arc<Live>) -> Router {
    Router::new().fallback(upgrade).with_state(live)
}

async fn upgrade(
    State(live): State<Arc<Live>>,
    ws: Result<WebSocketUpgrade, axum::extract::ws::rejection::WebSocketUpgradeRejection>,
) -> Response {
    let Ok(ws) = ws else {
        return (
            StatusCode::BAD_REQUEST,
            "a Foxglove WebSocket server: connect with Foxglove (Open connection → Foxglove WebSocket)\n",
        )
            .into_response();
    };
    let Some(hub) = live.foxglove() else {
        return StatusCode::SERVICE_UNAVAILABLE.into_response();
    };
    if live.stats.foxglove_clients.load(Relaxed) >= MAX_CLIENTS {
        live.stats.foxglove_refused.fetch_add(1, Relaxed);
        return (
            StatusCode::SERVICE_UNAVAILABLE,
            "too many Foxglove clients\n",
        )
            .into_response();
    }
    ws.protocols([SUBPROTOCOL])
        .max_message_size(MAX_REQUEST_BYTES)
        .on_upgrade(move |socket| serve_client(live, hub, socket))
}

/// What a client may ask.
#[derive(Debug, Deserialize)]
#[serde(tag = "op", rename_all = "camelCase")]
enum Request {
    Subscribe {
        subscriptions: Vec<Subscription>,
    },
    Unsubscribe {
        #[serde(rename = "subscriptionIds")]
        subscription_ids: Vec<u32>,
    },
}

#[derive(Debug, Deserialize)]
struct Subscription {
    id: u32,
    #[serde(rename = "channelId")]
    channel_id: u32,
}

/// One client's subscriptions: channel id → subscription id.
#[derive(Debug, Default)]
struct Subscriptions(HashMap<u32, u32>);

impl Subscriptions {
    /// Applies a request; a warning for the client when part of it was refused.
    fn apply(&mut self, text: &str) -> Option<String> {
        match serde_json::from_str::<Request>(text) {
            Ok(Request::Subscribe { subscriptions }) => {
                for s in subscriptions {
                    if self.0.len() >= MAX_SUBSCRIPTIONS {
                        return Some(format!("at most {MAX_SUBSCRIPTIONS} subscriptions"));
                    }
                    self.0.insert(s.channel_id, s.id);
                }
                None
            }
            Ok(Request::Unsubscribe { subscription_ids }) => {
                self.0.retain(|_, sub| !subscription_ids.contains(sub));
                None
            }
            // Requests of capabilities this server does not announce are ignored.
            Err(_) if serde_json::from_str::<serde_json::Value>(text).is_ok() => None,
            Err(e) => Some(format!("not a request: {e}")),
        }
    }
}

/// The binary frame of one message.
fn message_frame(subscription: u32, log_time: u64, payload: &[u8]) -> Vec<u8> {
    let mut frame = Vec::with_capacity(13 + payload.len());
    frame.push(1);
    frame.extend_from_slice(&subscription.to_le_bytes());
    frame.extend_from_slice(&log_time.to_le_bytes());
    frame.extend_from_slice(payload);
    frame
}

fn server_info(hub: &FoxgloveHub) -> String {
    json!({
        "op": "serverInfo",
        "name": hub.name,
        "capabilities": [],
        "supportedEncodings": [],
        "metadata": {},
        "sessionId": hub.name,
    })
    .to_string()
}

fn advertise<'a>(channels: impl IntoIterator<Item = &'a Arc<Channel>>) -> String {
    let channels: Vec<_> = channels.into_iter().map(|c| c.advertisement()).collect();
    json!({"op": "advertise", "channels": channels}).to_string()
}

async fn serve_client(live: Arc<Live>, hub: Arc<FoxgloveHub>, mut socket: WebSocket) {
    // Subscribed before the table is read: a channel made meanwhile is heard of.
    let mut rx = hub.tx.subscribe();
    let known: Vec<Arc<Channel>> = hub
        .channels
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .values()
        .cloned()
        .collect();
    let mut advertised: std::collections::HashSet<u32> = known.iter().map(|c| c.id).collect();
    live.stats.foxglove_clients.fetch_add(1, Relaxed);
    let limit = live.ws_send_timeout();
    let mut subs = Subscriptions::default();
    let mut open = send(
        &live,
        &mut socket,
        Message::Text(server_info(&hub).into()),
        limit,
    )
    .await
        && send(
            &live,
            &mut socket,
            Message::Text(advertise(&known).into()),
            limit,
        )
        .await;
    while open {
        tokio::select! {
            event = rx.recv() => match event {
                Ok(Event::Advertise(c)) => {
                    if advertised.insert(c.id) {
                        open = send(&live, &mut socket, Message::Text(advertise([&c]).into()), limit).await;
                    }
                }
                Ok(Event::Message { channel, log_time, payload }) => {
                    if let Some(sub) = subs.0.get(&channel) {
                        let frame = message_frame(*sub, log_time, &payload);
                        open = send(&live, &mut socket, Message::Binary(frame.into()), limit).await;
                        if open {
                            live.stats.foxglove_sent.fetch_add(1, Relaxed);
                        }
                    }
                }
                Err(RecvError::Lagged(n)) => {
                    live.stats.foxglove_dropped.fetch_add(n, Relaxed);
                }
                Err(RecvError::Closed) => open = false,
            },
            incoming = socket.recv() => match incoming {
                Some(Ok(Message::Text(text))) => {
                    if let Some(warning) = subs.apply(text.as_str()) {
                        live.stats.foxglove_bad_requests.fetch_add(1, Relaxed);
                        let status = json!({"op": "status", "level": 1, "message": warning});
                        open = send(&live, &mut socket, Message::Text(status.to_string().into()), limit).await;
                    }
                }
                Some(Ok(Message::Close(_))) | Some(Err(_)) | None => open = false,
                Some(Ok(_)) => {}
            }
        }
    }
    // What was queued for it is lost with it.
    live.stats
        .foxglove_dropped
        .fetch_add(rx.len() as u64, Relaxed);
    live.stats.foxglove_clients.fetch_sub(1, Relaxed);
}

/// Sends within `limit`; false when the client is gone or too slow (then it is dropped:
/// a stuck client must not hold a growing send buffer).
async fn send(live: &Live, socket: &mut WebSocket, message: Message, limit: Duration) -> bool {
    match tokio::time::timeout(limit, socket.send(message)).await {
        Ok(sent) => sent.is_ok(),
        Err(_) => {
            live.stats.foxglove_send_timeouts.fetch_add(1, Relaxed);
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::matchlog::LogKind;
    use base64::Engine as _;
    use proto::Stamp;

    #[test]
    fn frames_carry_the_opcode_subscription_time_and_payload() {
        let f = message_frame(7, 0x0102_0304_0506_0708, b"xy");
        assert_eq!(f[0], 1);
        assert_eq!(u32::from_le_bytes(f[1..5].try_into().expect("4")), 7);
        assert_eq!(
            u64::from_le_bytes(f[5..13].try_into().expect("8")),
            0x0102_0304_0506_0708
        );
        assert_eq!(&f[13..], b"xy");
    }

    #[test]
    fn requests_subscribe_unsubscribe_and_bad_ones_are_told() {
        let mut s = Subscriptions::default();
        let sub =
            r#"{"op":"subscribe","subscriptions":[{"id":5,"channelId":2},{"id":6,"channelId":3}]}"#;
        assert_eq!(s.apply(sub), None);
        assert_eq!(s.0.get(&2), Some(&5));
        assert_eq!(
            s.apply(r#"{"op":"unsubscribe","subscriptionIds":[5]}"#),
            None
        );
        assert_eq!(s.0.len(), 1);
        // Other operations (parameters, services, ...) are ignored; junk is answered.
        assert_eq!(
            s.apply(r#"{"op":"getParameters","parameterNames":[]}"#),
            None
        );
        assert!(s.apply("{not json").is_some());
        assert!(
            s.apply(r#"{"op":"subscribe","subscriptions":[{"id":"x"}]}"#)
                .is_none()
        );
        assert_eq!(s.0.len(), 1);
    }

    #[test]
    fn channels_are_advertised_once_with_their_schemas() {
        let hub = FoxgloveHub::new("test");
        let mut rx = hub.tx.subscribe();
        hub.publish(LogKind::Scene, "/scene", Stamp(5), b"a");
        hub.publish(LogKind::Scene, "/scene", Stamp(6), b"b");
        hub.publish(LogKind::BallState, "rf/ball/state", Stamp(7), b"{}");
        let mut ads = Vec::new();
        let mut messages = 0;
        while let Ok(e) = rx.try_recv() {
            match e {
                Event::Advertise(c) => ads.push(c.advertisement()),
                Event::Message { .. } => messages += 1,
            }
        }
        assert_eq!(messages, 3);
        assert_eq!(ads.len(), 2);
        assert_eq!(ads[0]["schemaName"], "foxglove.SceneUpdate");
        assert_eq!(ads[0]["encoding"], "protobuf");
        let descriptor = base64::engine::general_purpose::STANDARD
            .decode(ads[0]["schema"].as_str().expect("text"))
            .expect("base64");
        assert!(!descriptor.is_empty());
        assert_eq!(ads[1]["encoding"], "json");
        assert_eq!(ads[1]["schemaEncoding"], "jsonschema");
        assert!(ads[1]["schema"].as_str().expect("text").starts_with('{'));
    }
}
