//! Match logs: the messages the server receives and sends, written as MCAP files that
//! Foxglove opens and the replay reads back ([`crate::matchlog::read`]).
//!
//! - [`McapRecorder`]: the synchronous writer. Channels are created the first time a topic
//!   is seen (message encoding `json`, schema encoding `jsonschema`), files rotate by size
//!   or by log-time span, and [`McapRecorder::flush_if_due`] ends the open chunk and hands
//!   it to the operating system, so a killed process loses at most one flush interval.
//! - [`RecorderHandle`]: an [`McapRecorder`] on its own thread behind a bounded queue;
//!   sending never blocks, and a full queue drops (and counts) the record.
//!
//! Records are written in the order they are given: nothing is sorted by log time.

mod file_name;
mod handle;
mod log_file;
mod recorder;
#[cfg(test)]
pub(crate) mod test_support;

use std::path::PathBuf;
use std::sync::Arc;

use proto::Stamp;

pub use handle::{RecorderHandle, RecordingHealth};
pub use recorder::{FaultCause, McapRecorder, RETRY_INTERVAL};

/// The largest payload one record may carry. Larger records are refused, so that every
/// file stays readable by [`crate::matchlog::read`], which caps what it buffers.
pub const MAX_PAYLOAD_BYTES: usize = 32 << 20;

/// The largest [`RecorderConfig::chunk_size_bytes`] accepted, for the same reason.
pub const MAX_CHUNK_SIZE_BYTES: u64 = 32 << 20;

/// Message encoding of the wire messages' channels.
pub const MESSAGE_ENCODING: &str = "json";

/// Schema encoding of the wire messages' schemas.
pub const SCHEMA_ENCODING: &str = "jsonschema";

/// Name of the metadata record at the start of every file.
pub const METADATA_NAME: &str = "fusion-server";

/// How chunks are compressed. Both are read by Foxglove and the `mcap` tools.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogCompression {
    /// Chunks stored as they are.
    None,
    /// Chunks compressed with zstd (default level). JSON shrinks several-fold.
    Zstd,
}

/// Where and how match logs are written.
#[derive(Debug, Clone, PartialEq)]
pub struct RecorderConfig {
    /// Directory of the log files; created when missing.
    pub dir: PathBuf,
    /// Start of every file name: `{file_prefix}-{UTC date-time}-{index:03}.mcap`. Must be
    /// non-empty and hold no path separator.
    pub file_prefix: String,
    /// A new file is started before a record that finds the current one at or above this
    /// size (on-disk bytes plus the uncompressed bytes of the open chunk).
    pub max_bytes: Option<u64>,
    /// A new file is started before a record whose log time is more than this many seconds
    /// after the current file's first message.
    pub max_duration_s: Option<f64>,
    /// Seconds between flushes: the data a killed process can lose.
    pub flush_interval_s: f64,
    /// The open chunk is ended once its uncompressed messages reach this size.
    pub chunk_size_bytes: u64,
    /// Chunk compression.
    pub compression: LogCompression,
    /// Records the [`RecorderHandle`] queue holds before it drops new ones.
    pub queue_capacity: usize,
    /// Payload bytes the [`RecorderHandle`] queue holds before it drops new records: a
    /// slow disk must not let the queue take the server's memory.
    pub queue_max_bytes: u64,
}

impl RecorderConfig {
    /// Default flush interval: the durability window of a killed server.
    pub const DEFAULT_FLUSH_INTERVAL_S: f64 = 0.25;
    /// Default chunk size (uncompressed).
    pub const DEFAULT_CHUNK_SIZE_BYTES: u64 = 1 << 20;
    /// Default queue capacity of a [`RecorderHandle`].
    pub const DEFAULT_QUEUE_CAPACITY: usize = 1 << 16;
    /// Default byte bound of a [`RecorderHandle`]'s queue (64 MiB).
    pub const DEFAULT_QUEUE_MAX_BYTES: u64 = 64 << 20;

    /// Logs in `dir` named `match-…`, no rotation, a flush every 0.25 s, 1 MiB zstd chunks
    /// and a queue of 65 536 records or 64 MiB of payloads, whichever is reached first.
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        Self {
            dir: dir.into(),
            file_prefix: "match".to_owned(),
            max_bytes: None,
            max_duration_s: None,
            flush_interval_s: Self::DEFAULT_FLUSH_INTERVAL_S,
            chunk_size_bytes: Self::DEFAULT_CHUNK_SIZE_BYTES,
            compression: LogCompression::Zstd,
            queue_capacity: Self::DEFAULT_QUEUE_CAPACITY,
            queue_max_bytes: Self::DEFAULT_QUEUE_MAX_BYTES,
        }
    }

    /// Checks every field; the first problem found is returned as [`RecordError::Config`].
    pub fn validate(&self) -> Result<(), RecordError> {
        let bad = |why: String| Err(RecordError::Config(why));
        if self.file_prefix.is_empty()
            || self.file_prefix.contains(['/', '\\'])
            || self.file_prefix == "."
            || self.file_prefix == ".."
        {
            return bad(format!(
                "file prefix {:?} must be non-empty and hold no path separator",
                self.file_prefix
            ));
        }
        if self.max_bytes == Some(0) {
            return bad("max_bytes must be positive".to_owned());
        }
        if let Some(s) = self.max_duration_s.filter(|s| !(s.is_finite() && *s > 0.0)) {
            return bad(format!(
                "max_duration_s must be positive and finite, not {s}"
            ));
        }
        let flush_s = self.flush_interval_s;
        if !(flush_s.is_finite() && flush_s > 0.0 && flush_s <= 86_400.0) {
            return bad(format!(
                "flush_interval_s must be in (0, 86400], not {flush_s}"
            ));
        }
        if self.chunk_size_bytes == 0 || self.chunk_size_bytes > MAX_CHUNK_SIZE_BYTES {
            return bad(format!(
                "chunk_size_bytes must be in 1..={MAX_CHUNK_SIZE_BYTES}, not {}",
                self.chunk_size_bytes
            ));
        }
        if self.queue_capacity == 0 {
            return bad("queue_capacity must be positive".to_owned());
        }
        if self.queue_max_bytes == 0 {
            return bad("queue_max_bytes must be positive".to_owned());
        }
        Ok(())
    }
}

/// A named schema, written once per file as an MCAP schema record, with the encoding of
/// its channels' messages. Shared between records as `Arc<Schema>`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Schema {
    /// Schema name, e.g. `Observation`; one schema record per name and file.
    pub name: String,
    /// How `data` is written: `jsonschema` or `protobuf`.
    pub encoding: String,
    /// The schema itself: a JSON Schema document as UTF-8 JSON, or a serialised protobuf
    /// `FileDescriptorSet`.
    pub data: Vec<u8>,
    /// How messages of this schema are encoded: `json` or `protobuf`.
    pub message_encoding: String,
}

impl Schema {
    /// A JSON Schema from its name and JSON text, for JSON messages.
    pub fn new(name: impl Into<String>, json: impl Into<Vec<u8>>) -> Self {
        Self {
            name: name.into(),
            encoding: SCHEMA_ENCODING.into(),
            data: json.into(),
            message_encoding: MESSAGE_ENCODING.into(),
        }
    }

    /// A schema with other encodings (Foxglove's protobuf messages, say).
    pub fn encoded(
        name: impl Into<String>,
        encoding: impl Into<String>,
        data: impl Into<Vec<u8>>,
        message_encoding: impl Into<String>,
    ) -> Self {
        Self {
            name: name.into(),
            encoding: encoding.into(),
            data: data.into(),
            message_encoding: message_encoding.into(),
        }
    }
}

/// Removes the logs in `dir` that an earlier run of the same command wrote
/// (`{prefix}-….mcap`): a tool that writes the same file again replaces it. A missing
/// folder holds nothing to remove.
pub fn remove_earlier(dir: &std::path::Path, prefix: &str) -> std::io::Result<()> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    let stem = format!("{prefix}-");
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with(&stem) && name.ends_with(".mcap") {
            std::fs::remove_file(e.path())?;
        }
    }
    Ok(())
}

/// The JSON Schemas of every wire message (`proto::schema::all()`), ready to attach to
/// records.
pub fn proto_schemas() -> Vec<Arc<Schema>> {
    proto::schema::all()
        .into_iter()
        .map(|(name, schema)| Arc::new(Schema::new(name, proto::schema::to_pretty_json(&schema))))
        .collect()
}

/// One message to log.
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    /// Channel topic, e.g. the key expression the message travelled on.
    pub topic: String,
    /// Schema of `payload`. A topic keeps the schema (by name) of its first record.
    pub schema: Arc<Schema>,
    /// When the server received or produced the message.
    pub log_time: Stamp,
    /// When the message was published (for observations, their capture time).
    pub publish_time: Stamp,
    /// The message in its schema's message encoding.
    pub payload: Vec<u8>,
}

/// What a finished recording wrote.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct RecordSummary {
    /// Every file opened, in the order written.
    pub files: Vec<PathBuf>,
    /// Messages written over all files.
    pub messages: u64,
}

/// Why a recording step failed.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The configuration is unusable.
    #[error("recorder configuration: {0}")]
    Config(String),
    /// A file or directory operation failed.
    #[error("{action} {path}: {source}")]
    Io {
        action: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The MCAP writer failed (usually an I/O error underneath).
    #[error("writing MCAP file {path}: {source}")]
    Mcap {
        path: PathBuf,
        #[source]
        source: mcap::McapError,
    },
    /// A topic's channel was created with another schema.
    #[error("topic {topic:?} is logged with schema {channel_schema:?}, not {record_schema:?}")]
    SchemaMismatch {
        topic: String,
        channel_schema: String,
        record_schema: String,
    },
    /// The recording is stopped by a failing file or disk ([`recorder::Fault`]); the
    /// record was not written.
    #[error("recording stopped: {}", .0.plain())]
    Stopped(FaultCause),
    /// The payload exceeds [`MAX_PAYLOAD_BYTES`].
    #[error("payload of {bytes} bytes on {topic:?} exceeds {MAX_PAYLOAD_BYTES} bytes")]
    PayloadTooLarge { topic: String, bytes: usize },
    /// The recorder thread could not be started.
    #[error("starting the recorder thread: {0}")]
    Spawn(#[source] std::io::Error),
    /// The recorder thread panicked; its files may lack their summary.
    #[error("the recorder thread panicked")]
    ThreadPanicked,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_earlier_run_s_logs_are_removed_and_nothing_else() -> std::io::Result<()> {
        let dir = tempfile::tempdir()?;
        for name in [
            "sim-a-1-000.mcap",
            "sim-a-1-001.mcap",
            "sim-a-10-000.mcap",
            "notes.mcap",
            "sim-a-1.txt",
        ] {
            std::fs::write(dir.path().join(name), b"x")?;
        }
        remove_earlier(dir.path(), "sim-a-1")?;
        let mut left: Vec<String> = std::fs::read_dir(dir.path())?
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, ["notes.mcap", "sim-a-1.txt", "sim-a-10-000.mcap"]);
        remove_earlier(&dir.path().join("missing"), "x")
    }

    #[test]
    fn the_default_configuration_is_valid() {
        let cfg = RecorderConfig::new("logs");
        assert!(cfg.validate().is_ok());
        assert_eq!(cfg.flush_interval_s, 0.25);
        assert_eq!(cfg.queue_capacity, 65_536);
    }

    #[test]
    fn unusable_configurations_are_refused() {
        let base = RecorderConfig::new("logs");
        let cases = [
            RecorderConfig {
                file_prefix: String::new(),
                ..base.clone()
            },
            RecorderConfig {
                file_prefix: "a/b".into(),
                ..base.clone()
            },
            RecorderConfig {
                max_bytes: Some(0),
                ..base.clone()
            },
            RecorderConfig {
                max_duration_s: Some(f64::NAN),
                ..base.clone()
            },
            RecorderConfig {
                flush_interval_s: 0.0,
                ..base.clone()
            },
            RecorderConfig {
                flush_interval_s: f64::INFINITY,
                ..base.clone()
            },
            RecorderConfig {
                chunk_size_bytes: MAX_CHUNK_SIZE_BYTES + 1,
                ..base.clone()
            },
            RecorderConfig {
                queue_capacity: 0,
                ..base.clone()
            },
            RecorderConfig {
                queue_max_bytes: 0,
                ..base.clone()
            },
        ];
        for cfg in cases {
            assert!(
                matches!(cfg.validate(), Err(RecordError::Config(_))),
                "{cfg:?}"
            );
        }
    }

    #[test]
    fn proto_schemas_hold_every_message_as_json() {
        let schemas = proto_schemas();
        assert!(schemas.iter().any(|s| s.name == "Observation"));
        for s in &schemas {
            assert!(s.data.starts_with(b"{"), "{}", s.name);
        }
    }
}
