//! [`RecorderHandle`]: an [`McapRecorder`] on its own thread, fed through a bounded queue
//! that never blocks the sender.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::Instant;

use proto::Stamp;

use super::recorder::{Fault, FaultCause};
use super::{McapRecorder, Record, RecordError, RecordSummary, RecorderConfig};

/// How the recording stands, for /metrics, the log and the coach's page.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize)]
pub struct RecordingHealth {
    /// True while a failing file or disk keeps the recording stopped.
    pub stopped: bool,
    /// Why, as a metric label (`disk_full`, `permission`, `io`) ...
    pub cause: Option<&'static str>,
    /// ... and in plain words, with the error.
    pub reason: Option<String>,
    /// Seconds since it stopped.
    pub stopped_for_s: Option<f64>,
    /// Records not written since it stopped.
    pub lost_since_stopped: u64,
    /// The file being written, or the one that failed while stopped.
    pub file: Option<PathBuf>,
    /// Failed writes and flushes of files and disks, by cause label.
    pub errors: Vec<(&'static str, u64)>,
    /// Records the writer refused or could not write (stopped, failed, refused).
    pub failed: u64,
    /// Times the recording resumed into a new file after stopping.
    pub resumed: u64,
}

/// Counters of a running recorder.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct RecorderStats {
    /// Records written to a file.
    pub written: u64,
    /// Records dropped because the queue was full, by count or by bytes (or the writer
    /// thread had stopped).
    pub dropped: u64,
    /// Of `dropped`, those that would have taken the queue past its byte bound.
    pub dropped_for_bytes: u64,
    /// Payload bytes waiting in the queue.
    pub queued_bytes: u64,
    /// Records the writer refused or failed to write.
    pub failed: u64,
    /// The file being written.
    pub current_file: Option<PathBuf>,
    /// The latest write or flush error, as text.
    pub last_error: Option<String>,
}

/// What the sending side and the writer thread share.
#[derive(Debug, Default)]
struct Shared {
    written: AtomicU64,
    dropped: AtomicU64,
    dropped_for_bytes: AtomicU64,
    queued_bytes: AtomicU64,
    failed: AtomicU64,
    current_file: Mutex<Option<PathBuf>>,
    last_error: Mutex<Option<String>>,
    /// Failed writes and flushes, by [`FaultCause::ALL`] index.
    errors: [AtomicU64; 3],
    resumed: AtomicU64,
    /// The fault keeping the recording stopped, if one does.
    fault: Mutex<Option<Fault>>,
}

impl Shared {
    fn set_error(&self, e: &RecordError) {
        *self
            .last_error
            .lock()
            .unwrap_or_else(PoisonError::into_inner) = Some(e.to_string());
    }
}

/// A match-log writer thread. [`RecorderHandle::send`] queues a record without blocking;
/// the thread writes records in queue order and flushes every
/// [`RecorderConfig::flush_interval_s`], idle or not.
///
/// Dropping the handle closes the queue and waits for the thread to write what is queued
/// and complete the file, ignoring errors; [`RecorderHandle::finish`] does the same and
/// reports them.
#[derive(Debug)]
pub struct RecorderHandle {
    tx: Option<SyncSender<Record>>,
    thread: Option<JoinHandle<Result<RecordSummary, RecordError>>>,
    shared: Arc<Shared>,
    max_queued_bytes: u64,
}

impl RecorderHandle {
    /// Opens the first file (see [`McapRecorder::create`]) and starts the writer thread
    /// with a queue of [`RecorderConfig::queue_capacity`] records.
    pub fn spawn(cfg: RecorderConfig, start: Stamp) -> Result<Self, RecordError> {
        let capacity = cfg.queue_capacity;
        let max_queued_bytes = cfg.queue_max_bytes;
        let recorder = McapRecorder::create(cfg, start)?;
        let shared = Arc::new(Shared::default());
        *shared
            .current_file
            .lock()
            .unwrap_or_else(PoisonError::into_inner) = recorder.current_file().map(Into::into);
        let (tx, rx) = mpsc::sync_channel(capacity);
        let thread_shared = Arc::clone(&shared);
        let thread = std::thread::Builder::new()
            .name("mcap-recorder".to_owned())
            .spawn(move || run(recorder, rx, &thread_shared))
            .map_err(RecordError::Spawn)?;
        Ok(Self {
            tx: Some(tx),
            thread: Some(thread),
            shared,
            max_queued_bytes,
        })
    }

    /// Queues `record` without blocking. Returns false, and counts the record as dropped,
    /// when the queue is full or the writer has stopped.
    pub fn send(&self, record: Record) -> bool {
        let bytes = record.payload.len() as u64;
        let s = &self.shared;
        // Reserve the bytes first; give them back if the record does not go in.
        let before = s.queued_bytes.fetch_add(bytes, Ordering::Relaxed);
        if before + bytes > self.max_queued_bytes {
            s.queued_bytes.fetch_sub(bytes, Ordering::Relaxed);
            s.dropped_for_bytes.fetch_add(1, Ordering::Relaxed);
            s.dropped.fetch_add(1, Ordering::Relaxed);
            return false;
        }
        let queued = match &self.tx {
            Some(tx) => match tx.try_send(record) {
                Ok(()) => true,
                Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => false,
            },
            None => false,
        };
        if !queued {
            s.queued_bytes.fetch_sub(bytes, Ordering::Relaxed);
        }
        if !queued {
            self.shared.dropped.fetch_add(1, Ordering::Relaxed);
        }
        queued
    }

    /// Queues `record`, waiting while the queue is full (offline tools, which must not
    /// lose anything). Returns false, and counts the record as dropped, when the writer
    /// has stopped.
    pub fn send_waiting(&self, record: Record) -> bool {
        let bytes = record.payload.len() as u64;
        self.shared.queued_bytes.fetch_add(bytes, Ordering::Relaxed);
        let queued = self.tx.as_ref().is_some_and(|tx| tx.send(record).is_ok());
        if !queued {
            self.shared.queued_bytes.fetch_sub(bytes, Ordering::Relaxed);
        }
        if !queued {
            self.shared.dropped.fetch_add(1, Ordering::Relaxed);
        }
        queued
    }

    /// How the recording stands at `now`.
    pub fn health(&self, now: Instant) -> RecordingHealth {
        let s = &self.shared;
        let fault = s
            .fault
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone();
        let current = s
            .current_file
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone();
        RecordingHealth {
            stopped: fault.is_some(),
            cause: fault.as_ref().map(|f| f.cause.label()),
            reason: fault
                .as_ref()
                .map(|f| format!("{} ({})", f.cause.plain(), f.error)),
            stopped_for_s: fault
                .as_ref()
                .map(|f| now.saturating_duration_since(f.since).as_secs_f64()),
            lost_since_stopped: fault.as_ref().map_or(0, |f| f.lost),
            file: fault.and_then(|f| f.file).or(current),
            errors: FaultCause::ALL
                .iter()
                .zip(&s.errors)
                .map(|(c, n)| (c.label(), n.load(Ordering::Relaxed)))
                .collect(),
            failed: s.failed.load(Ordering::Relaxed),
            resumed: s.resumed.load(Ordering::Relaxed),
        }
    }

    /// The counters so far.
    pub fn stats(&self) -> RecorderStats {
        let s = &self.shared;
        RecorderStats {
            written: s.written.load(Ordering::Relaxed),
            dropped: s.dropped.load(Ordering::Relaxed),
            dropped_for_bytes: s.dropped_for_bytes.load(Ordering::Relaxed),
            queued_bytes: s.queued_bytes.load(Ordering::Relaxed),
            failed: s.failed.load(Ordering::Relaxed),
            current_file: s
                .current_file
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .clone(),
            last_error: s
                .last_error
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .clone(),
        }
    }

    /// Closes the queue, waits until every queued record is written and the file is
    /// complete, and reports what was written.
    pub fn finish(mut self) -> Result<RecordSummary, RecordError> {
        self.tx = None;
        match self.thread.take() {
            Some(thread) => thread.join().unwrap_or(Err(RecordError::ThreadPanicked)),
            None => Err(RecordError::ThreadPanicked),
        }
    }
}

impl Drop for RecorderHandle {
    fn drop(&mut self) {
        self.tx = None;
        if let Some(thread) = self.thread.take() {
            // Errors have nowhere to go here; `finish` reports them.
            let _ = thread.join();
        }
    }
}

/// The writer thread: write what arrives, flush when due, finish when the queue closes.
fn run(
    mut recorder: McapRecorder,
    rx: Receiver<Record>,
    shared: &Shared,
) -> Result<RecordSummary, RecordError> {
    let file_key = |r: &McapRecorder| (r.files().len(), r.current_file().is_some());
    let mut file_seen = file_key(&recorder);
    loop {
        match rx.recv_timeout(recorder.time_until_flush(Instant::now())) {
            Ok(record) => {
                let written = recorder.write_at(&record, Instant::now());
                let bytes = record.payload.len() as u64;
                shared.queued_bytes.fetch_sub(bytes, Ordering::Relaxed);
                match written {
                    Ok(()) => shared.written.fetch_add(1, Ordering::Relaxed),
                    Err(e) => {
                        shared.failed_with(&e);
                        shared.failed.fetch_add(1, Ordering::Relaxed)
                    }
                };
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        if let Err(e) = recorder.flush_if_due(Instant::now()) {
            shared.failed_with(&e);
        }
        shared.follow_fault(&recorder);
        if file_key(&recorder) != file_seen {
            file_seen = file_key(&recorder);
            *shared
                .current_file
                .lock()
                .unwrap_or_else(PoisonError::into_inner) = recorder.current_file().map(Into::into);
        }
    }
    let summary = recorder.finish();
    *shared
        .current_file
        .lock()
        .unwrap_or_else(PoisonError::into_inner) = None;
    summary
}

impl Shared {
    /// Keeps the error, and counts it by cause when the file or the disk failed.
    fn failed_with(&self, e: &RecordError) {
        if matches!(e, RecordError::Stopped(_)) {
            return;
        }
        self.set_error(e);
        if let Some(cause) = FaultCause::of(e)
            && let Some(i) = FaultCause::ALL.iter().position(|c| *c == cause)
        {
            self.errors[i].fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Mirrors the recorder's fault, saying once in the log when the recording stops and
    /// when it resumes.
    fn follow_fault(&self, recorder: &McapRecorder) {
        let mut kept = self.fault.lock().unwrap_or_else(PoisonError::into_inner);
        match (kept.as_ref(), recorder.fault()) {
            (None, Some(f)) => {
                let file = f.file.as_ref().map_or_else(String::new, |p| {
                    format!(" {} is closed and opens as it is;", p.display())
                });
                tracing::error!(
                    "recording stopped: {} ({});{file} the server goes on serving, and recording \
                     resumes into a new file as soon as writing succeeds again (tried every {} s)",
                    f.cause.plain(),
                    f.error,
                    super::RETRY_INTERVAL.as_secs()
                );
            }
            (Some(was), None) => {
                self.resumed.fetch_add(1, Ordering::Relaxed);
                let into = recorder
                    .current_file()
                    .map_or_else(String::new, |p| format!(" into {}", p.display()));
                tracing::warn!(
                    "recording resumed{into} after {:.0} s stopped ({}); {} messages of that time \
                     were not recorded",
                    was.since.elapsed().as_secs_f64(),
                    was.cause.plain(),
                    was.lost
                );
            }
            _ => {}
        }
        *kept = recorder.fault().cloned();
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;
    use crate::matchlog::read::{read_log, read_logs};
    use crate::matchlog::record::LogCompression;
    use crate::matchlog::record::test_support::*;

    #[test]
    fn queued_records_are_written_and_finish_returns_the_files() {
        let dir = tempfile::tempdir().expect("temp dir");
        let cfg = RecorderConfig {
            max_bytes: Some(50_000),
            ..config(dir.path(), LogCompression::Zstd)
        };
        let records = mixed_records(2_000);
        let handle = RecorderHandle::spawn(cfg, Stamp(T0_NS)).expect("recorder thread");
        let first = handle.stats().current_file.expect("current file");
        for r in &records {
            assert!(handle.send(r.clone()));
        }
        let summary = handle.finish().expect("finish");
        assert_eq!(summary.messages, 2_000);
        assert!(summary.files.len() > 1, "{:?}", summary.files);
        assert_eq!(summary.files[0], first);
        let read = read_logs(&summary.files).expect("read logs");
        assert!(read.complete, "{:?}", read.problem);
        assert_eq!(
            read.messages,
            records.iter().map(expected).collect::<Vec<_>>()
        );
    }

    #[test]
    fn a_full_queue_drops_and_counts() {
        let dir = tempfile::tempdir().expect("temp dir");
        let cfg = RecorderConfig {
            queue_capacity: 1,
            ..config(dir.path(), LogCompression::Zstd)
        };
        let records = mixed_records(20_000);
        let handle = RecorderHandle::spawn(cfg, Stamp(T0_NS)).expect("recorder thread");
        let queued = records.iter().filter(|r| handle.send((*r).clone())).count() as u64;
        let stats = handle.stats();
        assert!(stats.dropped > 0, "{stats:?}");
        assert_eq!(queued + stats.dropped, 20_000);
        let summary = handle.finish().expect("finish");
        assert_eq!(summary.messages, queued);
        let read = read_logs(&summary.files).expect("read logs");
        assert!(read.complete);
        assert_eq!(read.messages.len() as u64, queued);
        // What got through is in order.
        let times: Vec<Stamp> = read.messages.iter().map(|m| m.log_time).collect();
        assert!(times.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn a_queue_full_of_bytes_drops_and_counts() {
        let dir = tempfile::tempdir().expect("temp dir");
        let cfg = RecorderConfig {
            queue_max_bytes: 10_000,
            ..config(dir.path(), LogCompression::Zstd)
        };
        let handle = RecorderHandle::spawn(cfg, Stamp(T0_NS)).expect("recorder thread");
        let mut big = mixed_records(1).remove(0);
        big.payload = vec![b' '; 20_000];
        assert!(!handle.send(big), "larger than the whole queue");
        let stats = handle.stats();
        assert_eq!((stats.dropped, stats.dropped_for_bytes), (1, 1));
        assert_eq!(stats.queued_bytes, 0, "the refused bytes are given back");
        for r in mixed_records(50) {
            handle.send(r);
        }
        let summary = handle.finish().expect("finish");
        assert!(summary.messages > 0);
    }

    #[test]
    fn an_idle_recorder_still_flushes_on_its_timer() {
        let dir = tempfile::tempdir().expect("temp dir");
        let cfg = RecorderConfig {
            flush_interval_s: 0.02,
            ..config(dir.path(), LogCompression::Zstd)
        };
        let records = mixed_records(30);
        let handle = RecorderHandle::spawn(cfg, Stamp(T0_NS)).expect("recorder thread");
        let path = handle.stats().current_file.expect("current file");
        for r in &records {
            assert!(handle.send(r.clone()));
        }
        // Nothing else is sent: only the timer can flush the open chunk.
        let deadline = Instant::now() + Duration::from_secs(10);
        let read = loop {
            let read = read_log(&path).expect("read log");
            if read.messages.len() == records.len() || Instant::now() > deadline {
                break read;
            }
            std::thread::sleep(Duration::from_millis(10));
        };
        assert!(!read.complete);
        assert_eq!(
            read.messages,
            records.iter().map(expected).collect::<Vec<_>>()
        );
        let stats = handle.stats();
        assert_eq!((stats.written, stats.dropped, stats.failed), (30, 0, 0));
        assert_eq!(stats.last_error, None);
        drop(handle);
        assert!(read_log(&path).expect("read log").complete);
    }

    #[test]
    fn write_errors_are_counted_not_fatal() {
        let dir = tempfile::tempdir().expect("temp dir");
        let handle = RecorderHandle::spawn(config(dir.path(), LogCompression::None), Stamp(T0_NS))
            .expect("recorder thread");
        let obs = proto_schema("Observation");
        let status = proto_schema("RobotStatus");
        handle.send(record("t", &obs, 1, b"{}".to_vec()));
        handle.send(record("t", &status, 2, b"{}".to_vec()));
        handle.send(record("t", &obs, 3, b"{}".to_vec()));
        let deadline = Instant::now() + Duration::from_secs(10);
        while handle.stats().written + handle.stats().failed < 3 && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(5));
        }
        let stats = handle.stats();
        assert_eq!((stats.written, stats.failed), (2, 1));
        assert!(
            stats
                .last_error
                .expect("error text")
                .contains("RobotStatus")
        );
        assert_eq!(handle.finish().expect("finish").messages, 2);
    }

    #[test]
    fn spawn_reports_a_bad_configuration() {
        let dir = tempfile::tempdir().expect("temp dir");
        let cfg = RecorderConfig {
            queue_capacity: 0,
            ..config(dir.path(), LogCompression::Zstd)
        };
        assert!(matches!(
            RecorderHandle::spawn(cfg, Stamp(T0_NS)),
            Err(RecordError::Config(_))
        ));
    }
}
