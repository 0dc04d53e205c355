//! Reading match logs back for replay, tolerant of files cut short.
//!
//! A log is read front to back. A file whose writer was killed (no summary, no footer,
//! perhaps half a chunk at the end) yields every message of the complete chunks before
//! the cut, with [`LogRead::complete`] false and the reason in [`LogRead::problem`]. A
//! chunk's messages are only returned once its CRC has been checked, so a torn chunk
//! contributes nothing. Reading stops at the first damage: later chunks, even intact
//! ones, are not searched for.

use std::collections::HashMap;
use std::fs::File;
use std::io::{self, BufReader, Read};
use std::path::{Path, PathBuf};

use mcap::records::Record as McapRecord;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use proto::Stamp;

/// The most the reader buffers for one record or chunk. Above what the recorder writes
/// (chunks of at most [`crate::matchlog::record::MAX_CHUNK_SIZE_BYTES`] plus one payload of at most
/// [`crate::matchlog::record::MAX_PAYLOAD_BYTES`]); a damaged length field asking for more is
/// reported as damage instead of being allocated.
pub const RECORD_LENGTH_LIMIT_BYTES: usize = 128 << 20;

/// Bytes read from the source per request, so memory follows the data actually present
/// rather than lengths claimed by the file.
const READ_STEP_BYTES: usize = 1 << 20;

/// One logged message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogMessage {
    /// Channel topic.
    pub topic: String,
    /// Name of the channel's schema (empty when the channel has none).
    pub schema_name: String,
    /// When the server received or produced the message.
    pub log_time: Stamp,
    /// When the message was published.
    pub publish_time: Stamp,
    /// The payload (JSON for logs from [`crate::matchlog::record`]).
    pub data: Vec<u8>,
}

/// The messages of one log (or several, see [`read_logs`]).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct LogRead {
    /// Messages in file order (the order they were written).
    pub messages: Vec<LogMessage>,
    /// Whether every file was read to its footer and end magic without damage.
    pub complete: bool,
    /// Why reading stopped early, when it did.
    pub problem: Option<String>,
}

/// Why a log could not be read at all.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file could not be opened or read.
    #[error("reading {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    /// The file does not start with the MCAP magic.
    #[error("{path} is not an MCAP file")]
    NotMcap { path: PathBuf },
}

/// Reads one log file; see the module documentation for damaged files.
pub fn read_log(path: &Path) -> Result<LogRead, ReadError> {
    let file = File::open(path).map_err(|source| ReadError::Io {
        path: path.to_owned(),
        source,
    })?;
    read_log_from(BufReader::new(file), path)
}

/// Reads rotated log files in the given order and concatenates their messages.
/// `complete` holds only when every file is complete; problems are prefixed with the
/// file's path. A file that cannot be read at all is an error.
pub fn read_logs<P: AsRef<Path>>(paths: &[P]) -> Result<LogRead, ReadError> {
    let mut all = LogRead {
        messages: Vec::new(),
        complete: true,
        problem: None,
    };
    let mut problems = Vec::new();
    for path in paths {
        let path = path.as_ref();
        let read = read_log(path)?;
        all.messages.extend(read.messages);
        all.complete &= read.complete;
        if let Some(problem) = read.problem {
            problems.push(format!("{}: {problem}", path.display()));
        }
    }
    if !problems.is_empty() {
        all.problem = Some(problems.join("; "));
    }
    Ok(all)
}

/// Reads a log from any byte source; `name` is only used in errors. An empty source, or
/// one that ends within the magic, is an incomplete log without messages.
pub fn read_log_from<R: Read>(mut source: R, name: &Path) -> Result<LogRead, ReadError> {
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_prevalidate_chunk_crcs(true)
            .with_validate_data_section_crc(true)
            .with_validate_summary_section_crc(true)
            .with_record_length_limit(RECORD_LENGTH_LIMIT_BYTES),
    );
    let mut log = LogIndex::default();
    let mut head = Vec::with_capacity(mcap::MAGIC.len());
    let mut saw_record = false;
    let mut saw_footer = false;
    let mut problem = None;
    while let Some(event) = reader.next_event() {
        match event {
            Ok(LinearReadEvent::ReadRequest(want)) => {
                let buf = reader.insert(want.clamp(1, READ_STEP_BYTES));
                let got = read_some(&mut source, buf).map_err(|source| ReadError::Io {
                    path: name.to_owned(),
                    source,
                })?;
                let keep = got.min(mcap::MAGIC.len() - head.len());
                head.extend_from_slice(&buf[..keep]);
                reader.notify_read(got);
            }
            Ok(LinearReadEvent::Record { opcode, data }) => {
                saw_record = true;
                match mcap::parse_record(opcode, data) {
                    Ok(McapRecord::Footer(_)) => saw_footer = true,
                    Ok(record) => {
                        if let Err(why) = log.add(record) {
                            problem = Some(why);
                            break;
                        }
                    }
                    Err(e) => {
                        problem = Some(format!("damaged record (opcode {opcode:#04x}): {e}"));
                        break;
                    }
                }
            }
            Err(e) => {
                if !saw_record && !mcap::MAGIC.starts_with(&head) {
                    return Err(ReadError::NotMcap {
                        path: name.to_owned(),
                    });
                }
                problem = Some(describe(&e));
                break;
            }
        }
    }
    if problem.is_none() && !saw_footer {
        problem = Some("the file ends before its footer".to_owned());
    }
    Ok(LogRead {
        messages: log.messages,
        complete: problem.is_none(),
        problem,
    })
}

/// Reads into `buf`, retrying interruptions; 0 means the end of the source.
fn read_some<R: Read>(source: &mut R, buf: &mut [u8]) -> io::Result<usize> {
    loop {
        match source.read(buf) {
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            other => return other,
        }
    }
}

fn describe(e: &mcap::McapError) -> String {
    match e {
        mcap::McapError::UnexpectedEof => {
            "the file is cut short (no footer; a record or chunk at the end is incomplete)"
                .to_owned()
        }
        other => format!("damaged log: {other}"),
    }
}

/// Schemas and channels seen so far, and the messages resolved through them. Only the
/// data section is used; the summary section repeats its schemas and channels.
#[derive(Debug, Default)]
struct LogIndex {
    /// Schema id → name.
    schemas: HashMap<u16, String>,
    /// Whether the data section has ended: the summary after it holds no messages.
    data_ended: bool,
    /// Channel id → (topic, schema id).
    channels: HashMap<u16, (String, u16)>,
    messages: Vec<LogMessage>,
}

impl LogIndex {
    fn add(&mut self, record: McapRecord<'_>) -> Result<(), String> {
        match record {
            McapRecord::DataEnd(_) => self.data_ended = true,
            _ if self.data_ended => {}
            McapRecord::Schema { header, .. } => {
                self.schemas.insert(header.id, header.name);
            }
            McapRecord::Channel(channel) => {
                self.channels
                    .insert(channel.id, (channel.topic, channel.schema_id));
            }
            McapRecord::Message { header, data } => {
                let Some((topic, schema_id)) = self.channels.get(&header.channel_id) else {
                    return Err(format!(
                        "damaged log: a message on unknown channel {}",
                        header.channel_id
                    ));
                };
                let schema_name = match schema_id {
                    0 => String::new(),
                    id => match self.schemas.get(id) {
                        Some(name) => name.clone(),
                        None => {
                            return Err(format!(
                                "damaged log: channel {topic:?} names unknown schema {id}"
                            ));
                        }
                    },
                };
                self.messages.push(LogMessage {
                    topic: topic.clone(),
                    schema_name,
                    log_time: Stamp(header.log_time),
                    publish_time: Stamp(header.publish_time),
                    data: data.into_owned(),
                });
            }
            _ => {}
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    use crate::matchlog::record::test_support::*;
    use crate::matchlog::record::{LogCompression, McapRecorder, Record};

    const BOTH: [LogCompression; 2] = [LogCompression::None, LogCompression::Zstd];

    fn expected_all(records: &[Record]) -> Vec<LogMessage> {
        records.iter().map(expected).collect()
    }

    #[test]
    fn garbage_is_not_mcap() {
        let name = Path::new("garbage");
        let bytes: Vec<u8> = (0..10_000u32).map(|i| (i * 7919 % 251) as u8).collect();
        for len in [1, 3, 8, 9, 100, bytes.len()] {
            let got = read_log_from(&bytes[..len], name);
            assert!(
                matches!(got, Err(ReadError::NotMcap { .. })),
                "{len}: {got:?}"
            );
        }
        let text = b"{\"not\": \"an mcap file\"}\n";
        assert!(matches!(
            read_log_from(&text[..], name),
            Err(ReadError::NotMcap { .. })
        ));
    }

    #[test]
    fn a_cut_magic_is_an_empty_incomplete_log() {
        for len in 0..=mcap::MAGIC.len() {
            let read = read_log_from(&mcap::MAGIC[..len], Path::new("cut")).expect("read bytes");
            assert!(read.messages.is_empty());
            assert!(!read.complete);
            assert!(read.problem.is_some());
        }
    }

    #[test]
    fn a_missing_file_is_an_io_error() {
        let dir = tempfile::tempdir().expect("temp dir");
        let got = read_log(&dir.path().join("absent.mcap"));
        assert!(matches!(got, Err(ReadError::Io { .. })), "{got:?}");
    }

    #[test]
    fn a_file_from_another_writer_is_read() {
        // A plain mcap-crate writer with default options (zstd chunks, its own chunking).
        let mut buf = std::io::Cursor::new(Vec::new());
        {
            let mut w = mcap::Writer::new(&mut buf).expect("writer");
            let schema = w.add_schema("S", "jsonschema", b"{}").expect("schema");
            let chan = w
                .add_channel(schema, "/t", "json", &Default::default())
                .expect("channel");
            let header = |i: u64| mcap::records::MessageHeader {
                channel_id: chan,
                sequence: i as u32,
                log_time: 10 + i,
                publish_time: 5 + i,
            };
            for i in 0..100 {
                w.write_to_known_channel(&header(i), format!("{{\"i\":{i}}}").as_bytes())
                    .expect("write");
            }
            w.finish().expect("finish");
        }
        let read = read_log_from(&buf.get_ref()[..], Path::new("other")).expect("read bytes");
        assert!(read.complete, "{:?}", read.problem);
        assert_eq!(read.messages.len(), 100);
        assert_eq!(read.messages[7].topic, "/t");
        assert_eq!(read.messages[7].schema_name, "S");
        assert_eq!(read.messages[7].log_time, Stamp(17));
        assert_eq!(read.messages[7].publish_time, Stamp(12));
        assert_eq!(read.messages[7].data, b"{\"i\":7}");
    }

    /// Writes `chunks` groups of records, flushing after each; returns the file's bytes,
    /// the file length after each flush and the records.
    fn flushed_chunks(
        compression: LogCompression,
        chunks: u64,
        per_chunk: u64,
    ) -> (Vec<u8>, Vec<usize>, Vec<Record>) {
        let dir = tempfile::tempdir().expect("temp dir");
        let records = mixed_records(chunks * per_chunk);
        let mut recorder =
            McapRecorder::create(config(dir.path(), compression), Stamp(T0_NS)).expect("recorder");
        let path = recorder.current_file().expect("current file").to_owned();
        let mut ends = Vec::new();
        for chunk in records.chunks(per_chunk as usize) {
            for r in chunk {
                recorder.write(r).expect("write");
            }
            recorder.flush().expect("flush");
            ends.push(fs::metadata(&path).expect("file length").len() as usize);
        }
        recorder.finish().expect("finish");
        (fs::read(&path).expect("read file"), ends, records)
    }

    #[test]
    fn a_file_cut_within_a_chunk_yields_the_chunks_before() {
        for compression in BOTH {
            let (bytes, ends, records) = flushed_chunks(compression, 3, 20);
            for (k, pair) in ends.windows(2).enumerate() {
                let cut = (pair[0] + pair[1]) / 2;
                let read = read_log_from(&bytes[..cut], Path::new("cut")).expect("read bytes");
                assert!(!read.complete);
                assert_eq!(
                    read.messages,
                    expected_all(&records[..20 * (k + 1)]),
                    "{compression:?} cut {cut}"
                );
            }
        }
    }

    #[test]
    fn every_cut_yields_a_prefix_and_only_the_whole_file_is_complete() {
        for compression in BOTH {
            let (bytes, ends, records) = flushed_chunks(compression, 3, 4);
            let all = expected_all(&records);
            let mut previous = 0;
            for cut in 0..=bytes.len() {
                let read = read_log_from(&bytes[..cut], Path::new("cut")).expect("read bytes");
                let n = read.messages.len();
                assert_eq!(read.messages, all[..n], "{compression:?} cut {cut}");
                assert!(n >= previous, "{compression:?} cut {cut}");
                let flushed = ends.iter().filter(|&&end| end <= cut).count();
                assert!(n >= 4 * flushed, "{compression:?} cut {cut}");
                assert_eq!(
                    read.complete,
                    cut == bytes.len(),
                    "{compression:?} cut {cut}"
                );
                previous = n;
            }
            assert_eq!(previous, all.len());
        }
    }

    #[test]
    fn damaged_bytes_never_panic() {
        for compression in BOTH {
            let (bytes, _, records) = flushed_chunks(compression, 2, 3);
            let all = expected_all(&records);
            for at in 0..bytes.len() {
                for flip in [0x01, 0x80, 0xff] {
                    let mut damaged = bytes.clone();
                    damaged[at] ^= flip;
                    match read_log_from(damaged.as_slice(), Path::new("damaged")) {
                        Ok(read) => assert!(read.messages.len() <= all.len(), "{at}: {read:?}"),
                        Err(e) => assert!(at < mcap::MAGIC.len(), "{at}: {e}"),
                    }
                }
            }
        }
    }
}
