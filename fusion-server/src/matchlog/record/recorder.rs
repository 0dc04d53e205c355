//! [`McapRecorder`]: the synchronous match-log writer (file sequence, rotation, flushing).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use proto::Stamp;

use super::log_file::OpenLog;
use super::{MAX_PAYLOAD_BYTES, Record, RecordError, RecordSummary, RecorderConfig};

/// A stopped recording tries a new file this often (when there is something to write).
pub const RETRY_INTERVAL: Duration = Duration::from_secs(2);

/// Why a recording stopped: what the file or the disk refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FaultCause {
    /// No space left on the device (or the quota is used up).
    DiskFull,
    /// Writing or creating the file was not permitted.
    Permission,
    /// Any other input/output error.
    Io,
}

impl FaultCause {
    pub const ALL: [FaultCause; 3] = [FaultCause::DiskFull, FaultCause::Permission, FaultCause::Io];

    /// The cause as a metric label.
    pub fn label(self) -> &'static str {
        match self {
            FaultCause::DiskFull => "disk_full",
            FaultCause::Permission => "permission",
            FaultCause::Io => "io",
        }
    }

    /// The cause in plain words.
    pub fn plain(self) -> &'static str {
        match self {
            FaultCause::DiskFull => "the disk is full",
            FaultCause::Permission => "writing there is not permitted",
            FaultCause::Io => "the disk reported an input/output error",
        }
    }

    /// The cause of `e` when the file or the disk failed; `None` for a record refused
    /// for itself (too large, another schema on its topic).
    pub fn of(e: &RecordError) -> Option<FaultCause> {
        let io = match e {
            RecordError::Io { source, .. } => Some(source),
            RecordError::Mcap {
                source: mcap::McapError::Io(source),
                ..
            } => Some(source),
            RecordError::Mcap { .. } => None,
            _ => return None,
        };
        let raw = io.and_then(std::io::Error::raw_os_error);
        Some(match io.map(std::io::Error::kind) {
            Some(std::io::ErrorKind::StorageFull | std::io::ErrorKind::QuotaExceeded) => {
                FaultCause::DiskFull
            }
            Some(std::io::ErrorKind::FileTooLarge) => FaultCause::DiskFull,
            Some(std::io::ErrorKind::PermissionDenied | std::io::ErrorKind::ReadOnlyFilesystem) => {
                FaultCause::Permission
            }
            // ENOSPC as errno, should the kind be lost on the way.
            _ if raw == Some(28) => FaultCause::DiskFull,
            _ => FaultCause::Io,
        })
    }
}

/// `e` and the errors under it, each once: "writing …: I/O error …: No space left on
/// device (os error 28)".
fn with_causes(e: &RecordError) -> String {
    let mut text = e.to_string();
    let mut source = std::error::Error::source(e);
    while let Some(s) = source {
        let more = s.to_string();
        if !text.contains(&more) {
            text = format!("{text}: {more}");
        }
        source = s.source();
    }
    text
}

/// A recording stopped by a failing file.
#[derive(Debug, Clone, PartialEq)]
pub struct Fault {
    pub cause: FaultCause,
    /// The error that stopped it, as text.
    pub error: String,
    pub since: Instant,
    /// The file that was being written (closed: completed, or cut back to its last
    /// flush), if one was open.
    pub file: Option<PathBuf>,
    /// Records not written since.
    pub lost: u64,
    next_try: Instant,
    /// A new file is being tried: the recording resumes once a flush puts it on disk.
    trying: bool,
}

/// Writes records to a sequence of MCAP files, rotating by size and log-time span.
///
/// The first file is opened (and named after `start`) by [`McapRecorder::create`]; each
/// later file is named after the log time of the record that opened it. Dropping a
/// recorder without [`McapRecorder::finish`] still completes the current file, but
/// silently: call `finish` to learn about errors.
#[derive(Debug)]
pub struct McapRecorder {
    cfg: RecorderConfig,
    flush_interval: Duration,
    current: Option<OpenLog>,
    files: Vec<PathBuf>,
    messages: u64,
    /// Per-topic MCAP sequence numbers, continued across files.
    sequences: HashMap<String, u32>,
    last_flush: Instant,
    /// Set while a failing file or disk keeps the recording stopped.
    fault: Option<Fault>,
}

impl McapRecorder {
    /// Validates `cfg`, creates its directory if missing and opens the first file, named
    /// after `start`.
    pub fn create(cfg: RecorderConfig, start: Stamp) -> Result<Self, RecordError> {
        cfg.validate()?;
        let flush_interval = Duration::try_from_secs_f64(cfg.flush_interval_s)
            .map_err(|e| RecordError::Config(format!("flush_interval_s: {e}")))?;
        let mut recorder = Self {
            cfg,
            flush_interval,
            current: None,
            files: Vec::new(),
            messages: 0,
            sequences: HashMap::new(),
            last_flush: Instant::now(),
            fault: None,
        };
        recorder.current = Some(recorder.open(start)?);
        Ok(recorder)
    }

    /// Writes one record (see [`McapRecorder::write_at`]), now.
    #[cfg(test)]
    pub fn write(&mut self, record: &Record) -> Result<(), RecordError> {
        self.write_at(record, Instant::now())
    }

    /// Writes one record, first starting a new file when the current one is full by size
    /// or log-time span. A record that fails is not written. When the file or the disk
    /// fails ([`FaultCause::of`]) the file is closed and the recording stops: records are
    /// refused as [`RecordError::Stopped`] until, [`RETRY_INTERVAL`] later, a record opens
    /// a new file again; the recording resumes there once a flush has put it on disk
    /// ([`McapRecorder::flush_if_due`]).
    pub fn write_at(&mut self, record: &Record, now: Instant) -> Result<(), RecordError> {
        if record.payload.len() > MAX_PAYLOAD_BYTES {
            return Err(RecordError::PayloadTooLarge {
                topic: record.topic.clone(),
                bytes: record.payload.len(),
            });
        }
        if let Some(f) = &mut self.fault
            && !f.trying
        {
            if now < f.next_try {
                f.lost += 1;
                return Err(RecordError::Stopped(f.cause));
            }
            // Try a new file: the recording resumes once a flush has put it on disk.
            f.trying = true;
            f.next_try = now + RETRY_INTERVAL;
        }
        let result = self.write_unchecked(record);
        if let Err(e) = &result {
            self.failed(e, now);
        }
        result
    }

    fn write_unchecked(&mut self, record: &Record) -> Result<(), RecordError> {
        if self
            .current
            .as_ref()
            .is_some_and(|log| log.full_before(&self.cfg, record.log_time))
        {
            self.close_current()?;
        }
        let log = match self.current.take() {
            Some(log) => log,
            None => self.open(record.log_time)?,
        };
        let log = self.current.insert(log);
        let sequence = self.sequences.entry(record.topic.clone()).or_insert(0);
        *sequence = sequence.wrapping_add(1);
        log.write(record, *sequence, self.cfg.chunk_size_bytes)?;
        self.messages += 1;
        Ok(())
    }

    /// After error `e`: when the file or the disk failed, closes the file and stops (or
    /// stays stopped, counting the record lost).
    fn failed(&mut self, e: &RecordError, now: Instant) {
        let Some(cause) = FaultCause::of(e) else {
            return;
        };
        let file = self.current.take().and_then(|log| {
            let path = log.path.clone();
            if log.abandon() {
                Some(path)
            } else {
                // A file tried and refused before any message reached the disk is gone.
                self.files.retain(|f| *f != path);
                None
            }
        });
        if let Some(f) = &mut self.fault {
            f.lost += 1;
            f.trying = false;
            f.next_try = now + RETRY_INTERVAL;
            return;
        }
        self.fault = Some(Fault {
            cause,
            error: with_causes(e),
            since: now,
            file,
            lost: 1,
            next_try: now + RETRY_INTERVAL,
            trying: false,
        });
    }

    /// Why the recording is stopped, while it is.
    pub fn fault(&self) -> Option<&Fault> {
        self.fault.as_ref()
    }

    /// Flushes (see [`McapRecorder::flush`]) when a flush interval has passed since the
    /// last one. Returns whether it flushed.
    pub fn flush_if_due(&mut self, now: Instant) -> Result<bool, RecordError> {
        if now.saturating_duration_since(self.last_flush) < self.flush_interval {
            return Ok(false);
        }
        // Count the attempt even when it fails, so a failing disk is not retried per record.
        self.last_flush = now;
        if let Err(e) = self.flush() {
            self.failed(&e, now);
            return Err(e);
        }
        // A new file tried after a failure is on disk: the recording has resumed.
        if self
            .fault
            .as_ref()
            .is_some_and(|f| f.trying && self.current.is_some())
        {
            self.fault = None;
        }
        Ok(true)
    }

    /// Time from `now` until the next flush is due (zero when overdue).
    pub fn time_until_flush(&self, now: Instant) -> Duration {
        (self.last_flush + self.flush_interval).saturating_duration_since(now)
    }

    /// Ends the open chunk and writes everything to the operating system, so the file on
    /// disk holds every message written so far in complete chunks (no fsync).
    pub fn flush(&mut self) -> Result<(), RecordError> {
        match self.current.as_mut() {
            Some(log) => log.end_chunk(),
            None => Ok(()),
        }
    }

    /// Completes the current file (summary, footer, fsync) and reports what was written.
    pub fn finish(mut self) -> Result<RecordSummary, RecordError> {
        self.close_current()?;
        Ok(RecordSummary {
            files: self.files,
            messages: self.messages,
        })
    }

    /// The file being written, if one is open.
    pub fn current_file(&self) -> Option<&Path> {
        self.current.as_ref().map(|log| log.path.as_path())
    }

    /// Every file opened so far, in order (the last one may still be open).
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }

    /// Creates the next file, named after `name_time`, and lists it in `files`.
    fn open(&mut self, name_time: Stamp) -> Result<OpenLog, RecordError> {
        let index = u32::try_from(self.files.len()).unwrap_or(u32::MAX);
        let log = OpenLog::create(&self.cfg, name_time, index)?;
        self.files.push(log.path.clone());
        Ok(log)
    }

    fn close_current(&mut self) -> Result<(), RecordError> {
        match self.current.take() {
            Some(log) => log.finish(),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use std::fs;

    use super::*;
    use crate::matchlog::read::{LogMessage, read_log, read_logs};
    use crate::matchlog::record::LogCompression;
    use crate::matchlog::record::test_support::*;

    const BOTH: [LogCompression; 2] = [LogCompression::None, LogCompression::Zstd];

    fn write_all(recorder: &mut McapRecorder, records: &[Record]) {
        for r in records {
            recorder.write(r).expect("write");
        }
    }

    fn expected_all(records: &[Record]) -> Vec<LogMessage> {
        records.iter().map(expected).collect()
    }

    #[test]
    fn messages_come_back_in_order_with_topics_and_schemas() {
        for compression in BOTH {
            let dir = tempfile::tempdir().expect("temp dir");
            let records = mixed_records(300);
            let mut recorder = McapRecorder::create(config(dir.path(), compression), Stamp(T0_NS))
                .expect("recorder");
            write_all(&mut recorder, &records);
            let summary = recorder.finish().expect("finish");
            assert_eq!(summary.messages, 300);
            assert_eq!(
                summary.files,
                [dir.path().join("match-20261123T235959Z-000.mcap")]
            );
            let read = read_log(&summary.files[0]).expect("read log");
            assert!(read.complete, "{:?}", read.problem);
            assert_eq!(read.problem, None);
            assert_eq!(read.messages, expected_all(&records));
        }
    }

    /// Two recorders sharing a directory and a start second (two servers started
    /// together) write distinct, complete files: an existing log is never overwritten.
    #[test]
    fn recorders_sharing_a_directory_and_a_second_get_distinct_files() {
        let dir = tempfile::tempdir().expect("temp dir");
        let cfg = config(dir.path(), LogCompression::Zstd);
        let mut a = McapRecorder::create(cfg.clone(), Stamp(T0_NS)).expect("first");
        let mut b = McapRecorder::create(cfg, Stamp(T0_NS)).expect("second");
        let records = mixed_records(20);
        write_all(&mut a, &records);
        write_all(&mut b, &records);
        let (fa, fb) = (a.finish().expect("a").files, b.finish().expect("b").files);
        assert_eq!(fa, [dir.path().join("match-20261123T235959Z-000.mcap")]);
        assert_eq!(fb, [dir.path().join("match-20261123T235959Z-000-1.mcap")]);
        for f in fa.iter().chain(&fb) {
            let read = read_log(f).expect("read log");
            assert!(read.complete, "{f:?}");
            assert_eq!(read.messages, expected_all(&records));
        }
    }

    #[test]
    fn a_finished_file_has_the_summary_foxglove_reads() {
        let dir = tempfile::tempdir().expect("temp dir");
        let records = mixed_records(90);
        let mut recorder =
            McapRecorder::create(config(dir.path(), LogCompression::Zstd), Stamp(T0_NS))
                .expect("recorder");
        write_all(&mut recorder, &records);
        let files = recorder.finish().expect("finish").files;
        let bytes = fs::read(&files[0]).expect("read file");

        let summary = mcap::Summary::read(&bytes)
            .expect("summary")
            .expect("summary");
        let stats = summary.stats.as_ref().expect("stats");
        assert_eq!(stats.message_count, 90);
        assert_eq!(stats.channel_count, 3);
        assert_eq!(stats.schema_count, 2);
        let mut topics: Vec<_> = summary
            .channels
            .values()
            .map(|c| c.topic.as_str())
            .collect();
        topics.sort_unstable();
        assert_eq!(
            topics,
            [
                "ball/robots/r1/obs",
                "ball/robots/r1/status",
                "ball/robots/r2/obs"
            ]
        );
        let observation = proto_schema("Observation");
        for channel in summary.channels.values() {
            assert_eq!(channel.message_encoding, "json");
            let schema = channel.schema.as_ref().expect("schema");
            assert_eq!(schema.encoding, "jsonschema");
            if schema.name == "Observation" {
                assert_eq!(&*schema.data, observation.data.as_slice());
            }
        }
        assert!(
            summary
                .chunk_indexes
                .iter()
                .all(|c| c.compression == "zstd")
        );

        let [index] = summary.metadata_indexes.as_slice() else {
            panic!(
                "one metadata record expected: {:?}",
                summary.metadata_indexes
            );
        };
        let metadata = mcap::read::metadata(&bytes, index).expect("metadata record");
        assert_eq!(metadata.name, "fusion-server");
        assert_eq!(metadata.metadata["version"], env!("CARGO_PKG_VERSION"));
        assert_eq!(metadata.metadata["file_index"], "0");

        let streamed = mcap::MessageStream::new(&bytes).expect("message stream");
        let payloads: Vec<Vec<u8>> = streamed
            .map(|m| m.expect("streamed message").data.into_owned())
            .collect();
        let written: Vec<Vec<u8>> = records.iter().map(|r| r.payload.clone()).collect();
        assert_eq!(payloads, written);
    }

    #[test]
    fn rotation_by_size_splits_into_complete_files() {
        for compression in BOTH {
            let dir = tempfile::tempdir().expect("temp dir");
            let cfg = RecorderConfig {
                max_bytes: Some(20_000),
                chunk_size_bytes: 4_096,
                ..config(dir.path(), compression)
            };
            let records = mixed_records(1_000);
            let mut recorder = McapRecorder::create(cfg, Stamp(T0_NS)).expect("recorder");
            write_all(&mut recorder, &records);
            let summary = recorder.finish().expect("finish");
            assert!(
                summary.files.len() >= 3,
                "{compression:?}: {:?}",
                summary.files
            );
            for (i, file) in summary.files.iter().enumerate() {
                let name = file
                    .file_name()
                    .expect("file name")
                    .to_string_lossy()
                    .into_owned();
                assert!(
                    name.starts_with("match-2026112") && name.ends_with(&format!("-{i:03}.mcap")),
                    "{name}"
                );
                let read = read_log(file).expect("read log");
                assert!(read.complete, "{name}: {:?}", read.problem);
                assert!(!read.messages.is_empty());
                // Past the limit by at most one record and the summary, which repeats the
                // schemas (about 7 kB here).
                let len = fs::metadata(file).expect("file length").len();
                assert!(len < 20_000 + 12_000, "{name}: {len} bytes");
                let bytes = fs::read(file).expect("read file");
                let summary = mcap::Summary::read(&bytes)
                    .expect("summary")
                    .expect("summary");
                let [index] = summary.metadata_indexes.as_slice() else {
                    panic!("{name}")
                };
                let metadata = mcap::read::metadata(&bytes, index).expect("metadata record");
                assert_eq!(metadata.metadata["file_index"], i.to_string());
            }
            let read = read_logs(&summary.files).expect("read logs");
            assert!(read.complete);
            assert_eq!(read.messages, expected_all(&records));
        }
    }

    #[test]
    fn rotation_by_log_time_starts_a_file_per_span() {
        let dir = tempfile::tempdir().expect("temp dir");
        let cfg = RecorderConfig {
            max_duration_s: Some(1.0),
            ..config(dir.path(), LogCompression::Zstd)
        };
        // One record every 10 ms over 5 s: log times 1 ms, 11 ms, … after T0.
        let records = mixed_records(500);
        let mut recorder = McapRecorder::create(cfg, Stamp(T0_NS)).expect("recorder");
        write_all(&mut recorder, &records);
        let summary = recorder.finish().expect("finish");
        let names: Vec<String> = summary
            .files
            .iter()
            .map(|f| {
                f.file_name()
                    .expect("file name")
                    .to_string_lossy()
                    .into_owned()
            })
            .collect();
        // Files start at 0.001 s, 1.011 s, 2.021 s, 3.031 s and 4.041 s after 23:59:59.
        assert_eq!(
            names,
            [
                "match-20261123T235959Z-000.mcap",
                "match-20261124T000000Z-001.mcap",
                "match-20261124T000001Z-002.mcap",
                "match-20261124T000002Z-003.mcap",
                "match-20261124T000003Z-004.mcap",
            ]
        );
        for file in &summary.files {
            let messages = read_log(file).expect("read log").messages;
            let span_s = messages
                .last()
                .expect("last message")
                .log_time
                .secs_since(messages[0].log_time);
            assert!(span_s <= 1.0, "{file:?}: {span_s}");
        }
        let read = read_logs(&summary.files).expect("read logs");
        assert!(read.complete);
        assert_eq!(read.messages, expected_all(&records));
    }

    #[test]
    fn after_a_flush_the_open_file_holds_every_message_so_far() {
        for compression in BOTH {
            let dir = tempfile::tempdir().expect("temp dir");
            let records = mixed_records(100);
            let mut recorder = McapRecorder::create(config(dir.path(), compression), Stamp(T0_NS))
                .expect("recorder");
            let path = recorder.current_file().expect("current file").to_owned();
            let now = Instant::now();
            assert!(
                !recorder.flush_if_due(now).expect("flush"),
                "no flush before the interval"
            );
            write_all(&mut recorder, &records[..60]);
            assert!(
                recorder
                    .flush_if_due(now + Duration::from_millis(600))
                    .expect("flush")
            );
            assert!(
                !recorder
                    .flush_if_due(now + Duration::from_millis(700))
                    .expect("flush")
            );
            // What a `kill -9` now would leave behind.
            let copy = dir.path().join("copy.mcap");
            fs::copy(&path, &copy).expect("copy file");
            write_all(&mut recorder, &records[60..]);

            let read = read_log(&copy).expect("read log");
            assert!(!read.complete);
            assert!(read.problem.is_some());
            assert_eq!(read.messages, expected_all(&records[..60]));
            // The live file, with an unflushed chunk pending, reads the same.
            assert_eq!(read_log(&path).expect("read log").messages, read.messages);
            recorder.finish().expect("finish");
        }
    }

    #[test]
    fn dropping_a_recorder_completes_its_file() {
        let dir = tempfile::tempdir().expect("temp dir");
        let records = mixed_records(10);
        let mut recorder =
            McapRecorder::create(config(dir.path(), LogCompression::Zstd), Stamp(T0_NS))
                .expect("recorder");
        write_all(&mut recorder, &records);
        let path = recorder.current_file().expect("current file").to_owned();
        drop(recorder);
        let read = read_log(&path).expect("read log");
        assert!(read.complete, "{:?}", read.problem);
        assert_eq!(read.messages, expected_all(&records));
    }

    #[test]
    fn a_file_without_messages_is_complete_and_empty() {
        let dir = tempfile::tempdir().expect("temp dir");
        let nested = dir.path().join("a").join("b");
        let recorder = McapRecorder::create(config(&nested, LogCompression::Zstd), Stamp(T0_NS))
            .expect("recorder");
        let summary = recorder.finish().expect("finish");
        assert_eq!(summary.messages, 0);
        let read = read_log(&summary.files[0]).expect("read log");
        assert!(read.complete);
        assert!(read.messages.is_empty());
    }

    #[test]
    fn refused_records_are_not_written() {
        let dir = tempfile::tempdir().expect("temp dir");
        let mut recorder =
            McapRecorder::create(config(dir.path(), LogCompression::Zstd), Stamp(T0_NS))
                .expect("recorder");
        let obs = proto_schema("Observation");
        let status = proto_schema("RobotStatus");
        recorder
            .write(&record("t", &obs, 1, b"{}".to_vec()))
            .expect("write");
        let mismatch = recorder.write(&record("t", &status, 2, b"{}".to_vec()));
        assert!(
            matches!(mismatch, Err(RecordError::SchemaMismatch { .. })),
            "{mismatch:?}"
        );
        let huge = recorder.write(&record("u", &obs, 3, vec![b' '; MAX_PAYLOAD_BYTES + 1]));
        assert!(
            matches!(huge, Err(RecordError::PayloadTooLarge { .. })),
            "{huge:?}"
        );
        recorder
            .write(&record("t", &obs, 4, b"{}".to_vec()))
            .expect("write");
        let summary = recorder.finish().expect("finish");
        assert_eq!(summary.messages, 2);
        assert_eq!(
            read_log(&summary.files[0])
                .expect("read log")
                .messages
                .len(),
            2
        );
    }
}
