//! One open match-log file: its MCAP writer, the channels created in it, and the byte
//! count that drives rotation by size.

use std::collections::{BTreeMap, HashMap};
use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use mcap::records::{MessageHeader, Metadata};
use proto::Stamp;

use super::file_name::log_file_name;
use super::{LogCompression, METADATA_NAME, Record, RecordError, RecorderConfig};

/// Bytes a message record adds to its payload: opcode and length (9), channel id (2),
/// sequence (4), log and publish time (16).
const MESSAGE_RECORD_OVERHEAD_BYTES: u64 = 31;

/// One open log file and the channels created in it.
pub(super) struct OpenLog {
    writer: mcap::Writer<CountingFile>,
    pub(super) path: PathBuf,
    /// Bytes handed to the file so far (buffered or written).
    written_bytes: Arc<AtomicU64>,
    /// Bytes on disk, in complete records, after the last successful flush, and the
    /// messages among them.
    durable_bytes: u64,
    durable_messages: u64,
    first_log_time: Option<Stamp>,
    messages: u64,
    /// Payload and record bytes in the chunk not yet ended.
    open_chunk_bytes: u64,
    /// Schema name → schema id.
    schema_ids: HashMap<String, u16>,
    /// Topic → (channel id, schema name).
    channels: HashMap<String, (u16, String)>,
}

impl std::fmt::Debug for OpenLog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OpenLog")
            .field("path", &self.path)
            .field("messages", &self.messages)
            .finish_non_exhaustive()
    }
}

/// Tries per name this many alternatives (`-1`, `-2`, …) when the plain one exists.
const UNIQUE_SUFFIXES: u32 = 999;

/// Creates the log file, never overwriting one: when the name is taken (another server
/// recording into the same directory started in the same second), the next free
/// `{name}-{n}.mcap` is used instead.
fn create_unique(
    cfg: &RecorderConfig,
    name_time: Stamp,
    index: u32,
) -> Result<(PathBuf, File), RecordError> {
    let plain = log_file_name(&cfg.file_prefix, name_time, index);
    let stem = plain.trim_end_matches(".mcap");
    let mut n = 0;
    loop {
        let name = if n == 0 {
            plain.clone()
        } else {
            format!("{stem}-{n}.mcap")
        };
        let path = cfg.dir.join(name);
        match OpenOptions::new().write(true).create_new(true).open(&path) {
            Ok(file) => return Ok((path, file)),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists && n < UNIQUE_SUFFIXES => n += 1,
            Err(source) => {
                return Err(RecordError::Io {
                    action: "creating log file",
                    path,
                    source,
                });
            }
        }
    }
}

impl OpenLog {
    pub(super) fn create(
        cfg: &RecorderConfig,
        name_time: Stamp,
        index: u32,
    ) -> Result<Self, RecordError> {
        fs::create_dir_all(&cfg.dir).map_err(|source| RecordError::Io {
            action: "creating log directory",
            path: cfg.dir.clone(),
            source,
        })?;
        let (path, file) = create_unique(cfg, name_time, index)?;
        // A file whose header the disk refused holds nothing: it does not stay behind (a
        // stopped recording tries a new file every few seconds).
        Self::start(cfg, index, path.clone(), file).inspect_err(|_| {
            let _ = fs::remove_file(&path);
        })
    }

    /// The MCAP writer on a new `file` at `path`, its header and metadata on disk.
    fn start(
        cfg: &RecorderConfig,
        index: u32,
        path: PathBuf,
        file: File,
    ) -> Result<Self, RecordError> {
        let written_bytes = Arc::new(AtomicU64::new(0));
        let out = CountingFile {
            out: BufWriter::new(file),
            written: Arc::clone(&written_bytes),
        };
        let compression = match cfg.compression {
            LogCompression::None => None,
            LogCompression::Zstd => Some(mcap::Compression::Zstd),
        };
        let mcap_error = |source| RecordError::Mcap {
            path: path.clone(),
            source,
        };
        let version = env!("CARGO_PKG_VERSION");
        let mut writer = mcap::WriteOptions::new()
            .library(format!(
                "fusion-server/{version} {}",
                mcap::LIBRARY_IDENTIFIER
            ))
            .compression(compression)
            // Chunks are ended by this recorder (size and flush), and kept in memory until
            // complete: the file never holds a chunk with a placeholder header.
            .chunk_size(None)
            .disable_seeking(true)
            .compression_threads(0)
            .create(out)
            .map_err(mcap_error)?;
        let metadata = BTreeMap::from([
            ("version".to_owned(), version.to_owned()),
            ("file_index".to_owned(), index.to_string()),
        ]);
        writer
            .write_metadata(&Metadata {
                name: METADATA_NAME.to_owned(),
                metadata,
            })
            .map_err(mcap_error)?;
        // Put the header on disk at once: a file is readable from its creation on.
        writer.flush().map_err(mcap_error)?;
        let durable_bytes = written_bytes.load(Ordering::Relaxed);
        Ok(Self {
            writer,
            path,
            written_bytes,
            durable_bytes,
            durable_messages: 0,
            first_log_time: None,
            messages: 0,
            open_chunk_bytes: 0,
            schema_ids: HashMap::new(),
            channels: HashMap::new(),
        })
    }

    /// Writes `record` as message `sequence` of its topic, creating its channel on first
    /// use, and ends the chunk once it holds `chunk_size_bytes`.
    pub(super) fn write(
        &mut self,
        record: &Record,
        sequence: u32,
        chunk_size_bytes: u64,
    ) -> Result<(), RecordError> {
        let header = MessageHeader {
            channel_id: self.channel_for(record)?,
            sequence,
            log_time: record.log_time.0,
            publish_time: record.publish_time.0,
        };
        self.writer
            .write_to_known_channel(&header, &record.payload)
            .map_err(|e| self.mcap_error(e))?;
        self.messages += 1;
        self.first_log_time.get_or_insert(record.log_time);
        self.open_chunk_bytes += record.payload.len() as u64 + MESSAGE_RECORD_OVERHEAD_BYTES;
        if self.open_chunk_bytes >= chunk_size_bytes {
            self.end_chunk()?;
        }
        Ok(())
    }

    /// Whether a record logged at `log_time` must go to a new file.
    pub(super) fn full_before(&self, cfg: &RecorderConfig, log_time: Stamp) -> bool {
        if self.messages == 0 {
            return false;
        }
        let size_bytes = self.written_bytes.load(Ordering::Relaxed) + self.open_chunk_bytes;
        let too_big = cfg.max_bytes.is_some_and(|max| size_bytes >= max);
        let too_long = match (cfg.max_duration_s, self.first_log_time) {
            (Some(max_s), Some(first)) => log_time.secs_since(first) > max_s,
            _ => false,
        };
        too_big || too_long
    }

    /// The channel of `record.topic`, creating it (and its schema) on first use.
    fn channel_for(&mut self, record: &Record) -> Result<u16, RecordError> {
        if let Some((id, schema_name)) = self.channels.get(&record.topic) {
            if *schema_name != record.schema.name {
                return Err(RecordError::SchemaMismatch {
                    topic: record.topic.clone(),
                    channel_schema: schema_name.clone(),
                    record_schema: record.schema.name.clone(),
                });
            }
            return Ok(*id);
        }
        let schema_id = match self.schema_ids.get(&record.schema.name) {
            Some(id) => *id,
            None => {
                let id = self
                    .writer
                    .add_schema(
                        &record.schema.name,
                        &record.schema.encoding,
                        &record.schema.data,
                    )
                    .map_err(|e| self.mcap_error(e))?;
                self.schema_ids.insert(record.schema.name.clone(), id);
                id
            }
        };
        let id = self
            .writer
            .add_channel(
                schema_id,
                &record.topic,
                &record.schema.message_encoding,
                &BTreeMap::new(),
            )
            .map_err(|e| self.mcap_error(e))?;
        self.channels
            .insert(record.topic.clone(), (id, record.schema.name.clone()));
        Ok(id)
    }

    pub(super) fn end_chunk(&mut self) -> Result<(), RecordError> {
        self.open_chunk_bytes = 0;
        self.writer.flush().map_err(|e| self.mcap_error(e))?;
        self.durable_bytes = self.written_bytes.load(Ordering::Relaxed);
        self.durable_messages = self.messages;
        Ok(())
    }

    /// Closes a file whose writing failed: completed when that still succeeds, else cut
    /// back to what the last successful flush left on disk (complete records, no summary:
    /// read like the log of a killed server), or removed when no message reached the disk.
    /// Whether the file is still there.
    pub(super) fn abandon(self) -> bool {
        let (path, keep) = (self.path.clone(), self.durable_bytes);
        if self.durable_messages == 0 {
            drop(self);
            return fs::remove_file(&path).is_err();
        }
        if self.finish().is_ok() {
            return true;
        }
        if let Ok(file) = OpenOptions::new().write(true).open(&path) {
            // Nothing more can be done for a file the disk refuses.
            let _ = file.set_len(keep);
        }
        true
    }

    /// Writes the summary and footer, flushes and syncs the file.
    pub(super) fn finish(mut self) -> Result<(), RecordError> {
        self.writer.finish().map_err(|e| self.mcap_error(e))?;
        let path = self.path;
        let io_error = |source| RecordError::Io {
            action: "closing log file",
            path: path.clone(),
            source,
        };
        let file = self
            .writer
            .into_inner()
            .out
            .into_inner()
            .map_err(|e| io_error(e.into_error()))?;
        file.sync_all().map_err(io_error)
    }

    fn mcap_error(&self, source: mcap::McapError) -> RecordError {
        RecordError::Mcap {
            path: self.path.clone(),
            source,
        }
    }
}

/// A buffered file that counts the bytes written to it. It only appends: the MCAP writer
/// runs with seeking disabled and only asks for the current position.
struct CountingFile {
    out: BufWriter<File>,
    written: Arc<AtomicU64>,
}

impl Write for CountingFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.out.write(buf)?;
        self.written.fetch_add(n as u64, Ordering::Relaxed);
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }
}

impl Seek for CountingFile {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        let here = self.written.load(Ordering::Relaxed);
        match pos {
            SeekFrom::Current(0) | SeekFrom::End(0) => Ok(here),
            SeekFrom::Start(to) if to == here => Ok(here),
            _ => Err(io::Error::new(
                io::ErrorKind::Unsupported,
                "log files are written front to back",
            )),
        }
    }
}
