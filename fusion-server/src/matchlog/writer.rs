//! The server's match log: what the live shell hands over ([`MatchLog`]) turned into MCAP
//! records on a background writer, with the proto JSON Schemas on every channel.

use crate::matchlog::record::{
    Record, RecordError, RecordSummary, RecorderConfig, RecorderHandle, RecordingHealth, Schema,
};
use crate::matchlog::{LogKind, MatchLog};
use proto::Stamp;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// The schemas a match log uses, by name: the wire messages (JSON) and the scene's
/// (Foxglove's protobuf messages).
pub fn schemas() -> HashMap<String, Arc<Schema>> {
    crate::matchlog::record::proto_schemas()
        .into_iter()
        .chain(crate::scene::schemas())
        .chain(crate::camera_views::images::schemas())
        .map(|s| (s.name.clone(), s))
        .collect()
}

/// The schema a kind of message is logged with.
pub fn schema_name(kind: LogKind) -> &'static str {
    match kind {
        LogKind::Observation => "Observation",
        LogKind::Status => "RobotStatus",
        LogKind::BallState => "BallState",
        LogKind::Scene => crate::scene::SCENE_SCHEMA,
        LogKind::Transforms => crate::scene::TRANSFORMS_SCHEMA,
        LogKind::View => crate::camera_views::images::VIEW_SCHEMA,
        LogKind::Image => crate::camera_views::images::IMAGE_SCHEMA,
        LogKind::Annotations => crate::camera_views::images::ANNOTATIONS_SCHEMA,
    }
}

/// A [`MatchLog`] writing MCAP files in the background. `finish` completes the last file.
#[derive(Debug)]
pub struct McapLog {
    handle: Mutex<Option<RecorderHandle>>,
    schemas: HashMap<String, Arc<Schema>>,
}

impl McapLog {
    pub fn start(cfg: RecorderConfig, start: Stamp) -> Result<Self, RecordError> {
        Ok(McapLog {
            handle: Mutex::new(Some(RecorderHandle::spawn(cfg, start)?)),
            schemas: schemas(),
        })
    }

    /// Writes a record whose schema is one of [`schemas`]; false when dropped or unknown.
    pub fn write(&self, topic: &str, schema: &str, log_time: Stamp, payload: &[u8]) -> bool {
        let Some(schema) = self.schemas.get(schema) else {
            return false;
        };
        let guard = self.handle.lock().unwrap_or_else(|p| p.into_inner());
        match guard.as_ref() {
            Some(h) => h.send(Record {
                topic: topic.to_string(),
                schema: schema.clone(),
                log_time,
                publish_time: log_time,
                payload: payload.to_vec(),
            }),
            None => false,
        }
    }

    /// Finishes the log (summary and footer written); later writes are dropped.
    pub fn finish(&self) -> Result<Option<RecordSummary>, RecordError> {
        let handle = self.handle.lock().unwrap_or_else(|p| p.into_inner()).take();
        handle.map(RecorderHandle::finish).transpose()
    }
}

impl MatchLog for McapLog {
    fn log(&self, kind: LogKind, topic: &str, at: Stamp, payload: &[u8]) {
        self.write(topic, schema_name(kind), at, payload);
    }

    fn counts(&self) -> (u64, u64) {
        let guard = self.handle.lock().unwrap_or_else(|p| p.into_inner());
        guard
            .as_ref()
            .map(|h| {
                let s = h.stats();
                (s.written, s.dropped)
            })
            .unwrap_or_default()
    }

    fn queued_bytes(&self) -> u64 {
        let guard = self.handle.lock().unwrap_or_else(|p| p.into_inner());
        guard.as_ref().map_or(0, |h| h.stats().queued_bytes)
    }

    fn health(&self) -> Option<RecordingHealth> {
        let guard = self.handle.lock().unwrap_or_else(|p| p.into_inner());
        guard.as_ref().map(|h| h.health(std::time::Instant::now()))
    }
}

/// A [`crate::matchlog::replay::ReplaySink`] for offline tools: records go to a writer thread
/// (compression runs beside the fusion) and are never dropped.
#[derive(Debug)]
pub struct RecorderSink {
    handle: RecorderHandle,
    schemas: HashMap<String, Arc<Schema>>,
    sent: u64,
}

impl RecorderSink {
    pub fn create(cfg: RecorderConfig, start: Stamp) -> Result<Self, RecordError> {
        Self::with_schemas(cfg, start, Vec::new())
    }

    /// [`create`](Self::create), with schemas for channels beyond the wire messages (a
    /// simulator's ground truth, say): records naming them carry them.
    pub fn with_schemas(
        cfg: RecorderConfig,
        start: Stamp,
        extra: Vec<Arc<Schema>>,
    ) -> Result<Self, RecordError> {
        let mut schemas = schemas();
        schemas.extend(extra.into_iter().map(|s| (s.name.clone(), s)));
        Ok(RecorderSink {
            handle: RecorderHandle::spawn(cfg, start)?,
            schemas,
            sent: 0,
        })
    }

    /// Waits for every record to be written and completes the file.
    pub fn finish(self) -> Result<RecordSummary, RecordError> {
        let sent = self.sent;
        let summary = self.handle.finish()?;
        if summary.messages < sent {
            return Err(RecordError::Config(format!(
                "{} of {sent} records could not be written",
                sent - summary.messages
            )));
        }
        Ok(summary)
    }
}

impl crate::matchlog::replay::ReplaySink for RecorderSink {
    fn write(&mut self, topic: &str, schema: &str, log_time: Stamp, payload: &[u8]) {
        let schema = match self.schemas.get(schema) {
            Some(s) => s.clone(),
            None => Arc::new(Schema::new(schema, b"{}".to_vec())),
        };
        self.sent += 1;
        self.handle.send_waiting(Record {
            topic: topic.to_string(),
            schema,
            log_time,
            publish_time: log_time,
            payload: payload.to_vec(),
        });
    }
}
