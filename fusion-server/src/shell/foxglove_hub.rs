//! The Foxglove hub: the channel table of the match as Foxglove sees it, and one bounded
//! broadcast queue every connected client reads ([`super::foxglove`] serves them). The
//! publisher never waits for a client. It knows nothing of the server around it: the
//! shared state ([`super::live::Live`]) holds a hub and publishes into it.

use crate::matchlog::LogKind;
use crate::matchlog::record::Schema;
use base64::Engine as _;
use proto::Stamp;
use serde_json::json;
use std::collections::{BTreeMap, HashMap};
use std::sync::{Arc, Mutex};
use tokio::sync::broadcast;

/// Messages queued for all clients; a client further behind skips the oldest.
pub const QUEUE_MESSAGES: usize = 1024;
/// Channels at most (robots' topics are bounded by the engine's robot table already).
pub(super) const MAX_CHANNELS: usize = 1024;

/// One advertised channel.
#[derive(Debug)]
pub(super) struct Channel {
    pub(super) id: u32,
    pub(super) topic: String,
    pub(super) schema: Arc<Schema>,
}

impl Channel {
    pub(super) fn advertisement(&self) -> serde_json::Value {
        let schema = if self.schema.encoding == "protobuf" {
            base64::engine::general_purpose::STANDARD.encode(&self.schema.data)
        } else {
            String::from_utf8_lossy(&self.schema.data).into_owned()
        };
        json!({
            "id": self.id,
            "topic": self.topic,
            "encoding": self.schema.message_encoding,
            "schemaName": self.schema.name,
            "schema": schema,
            "schemaEncoding": self.schema.encoding,
        })
    }
}

#[derive(Debug, Clone)]
pub(super) enum Event {
    Advertise(Arc<Channel>),
    Message {
        channel: u32,
        log_time: u64,
        payload: Arc<[u8]>,
    },
}

/// The channels and the queue every client reads.
#[derive(Debug)]
pub struct FoxgloveHub {
    schemas: HashMap<String, Arc<Schema>>,
    pub(super) channels: Mutex<BTreeMap<String, Arc<Channel>>>,
    pub(super) tx: broadcast::Sender<Event>,
    pub(super) name: String,
}

impl FoxgloveHub {
    /// A hub for the server called `name`.
    pub fn new(name: &str) -> Self {
        let (tx, _) = broadcast::channel(QUEUE_MESSAGES);
        FoxgloveHub {
            schemas: crate::matchlog::schemas(),
            channels: Mutex::new(BTreeMap::new()),
            tx,
            name: name.to_string(),
        }
    }

    /// Whether any client is connected (nothing needs drawing for nobody).
    pub fn watched(&self) -> bool {
        self.tx.receiver_count() > 0
    }

    /// A message for the clients, on `topic` (advertised the first time it is seen).
    pub fn publish(&self, kind: LogKind, topic: &str, at: Stamp, payload: &[u8]) {
        let Some(schema) = self.schemas.get(crate::matchlog::schema_name(kind)) else {
            return;
        };
        let channel = {
            let mut channels = self.channels.lock().unwrap_or_else(|p| p.into_inner());
            match channels.get(topic) {
                Some(c) => c.clone(),
                None if channels.len() >= MAX_CHANNELS => return,
                None => {
                    let c = Arc::new(Channel {
                        id: channels.len() as u32 + 1,
                        topic: topic.to_string(),
                        schema: schema.clone(),
                    });
                    channels.insert(topic.to_string(), c.clone());
                    // Sent under the lock, so a client that joins now either finds the
                    // channel in the table or hears of it.
                    let _ = self.tx.send(Event::Advertise(c.clone()));
                    c
                }
            }
        };
        if self.watched() {
            let _ = self.tx.send(Event::Message {
                channel: channel.id,
                log_time: at.0,
                payload: Arc::from(payload),
            });
        }
    }
}
