//! Ball tracks read from CSV files: a header naming a time column and the ball's x and y
//! (aliases accepted, extra columns ignored), optionally a track id column that splits one
//! file into several tracks. Comma, tab or semicolon delimited, quoted fields as RFC 4180
//! has them (read by the `csv` crate). Pure: [`parse`] takes the text, [`read`] is the thin
//! file shell.
//!
//! Rows with an empty, NaN or infinite time or position are skipped and counted (a tracker
//! that lost the ball often writes them); a row whose time repeats the previous row's is
//! skipped and counted too. Anything else malformed is an error naming the file and line:
//! text where a number belongs, a short row, time going backwards, too few usable rows.
//!
//! Times are kept relative to the file's first usable time, so that epoch timestamps in
//! nanoseconds do not lose precision in f64.

use csv::StringRecord;
use std::path::Path;
use std::str::FromStr;
use thiserror::Error;

/// One position of the ball, `t_s` seconds after the file's first usable time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackSample {
    pub t_s: f64,
    pub position_m: [f64; 2],
}

/// One ball track: samples in strictly increasing time.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// The file's name, with `#id` when the file holds several tracks.
    pub name: String,
    pub samples: Vec<TrackSample>,
}

/// Consecutive samples further apart in time than this are a break: the ball was off the
/// pitch or out of the tracker's sight (picked up, placed elsewhere), and nothing is known
/// of it in between.
pub const MAX_GAP_S: f64 = 0.3;
/// Consecutive samples further apart than this in space, faster than [`MAX_SPEED_MPS`],
/// are a break too: the ball was moved by hand between them.
pub const MIN_JUMP_M: f64 = 0.3;
pub const MAX_SPEED_MPS: f64 = 20.0;

impl Track {
    pub fn start_s(&self) -> f64 {
        self.samples.first().map_or(0.0, |s| s.t_s)
    }

    pub fn end_s(&self) -> f64 {
        self.samples.last().map_or(0.0, |s| s.t_s)
    }

    pub fn duration_s(&self) -> f64 {
        self.end_s() - self.start_s()
    }

    /// Whether samples `i` and `i + 1` are separated by a break (see [`MAX_GAP_S`]).
    fn breaks_after(&self, i: usize) -> bool {
        let (Some(a), Some(b)) = (self.samples.get(i), self.samples.get(i + 1)) else {
            return false;
        };
        let dt = b.t_s - a.t_s;
        let d = (b.position_m[0] - a.position_m[0]).hypot(b.position_m[1] - a.position_m[1]);
        dt > MAX_GAP_S || (d > MIN_JUMP_M && d > MAX_SPEED_MPS * dt)
    }

    /// The times at which the ball reappears after a break: where it was placed (or first
    /// seen again), the start of a relocation.
    pub fn relocations_s(&self) -> Vec<f64> {
        (0..self.samples.len().saturating_sub(1))
            .filter(|i| self.breaks_after(*i))
            .map(|i| self.samples[i + 1].t_s)
            .collect()
    }

    /// Whether the ball is known at `t_s`: within the track's span and not in a break.
    pub fn covers(&self, t_s: f64) -> bool {
        self.position_at(t_s).is_some()
    }

    /// The position at `t_s`, interpolated linearly; `None` outside the track's span and
    /// inside its breaks.
    pub fn position_at(&self, t_s: f64) -> Option<[f64; 2]> {
        if self.samples.is_empty() || t_s < self.start_s() || t_s > self.end_s() {
            return None;
        }
        let i = self.samples.partition_point(|s| s.t_s <= t_s);
        if i == 0 {
            return self.samples.first().map(|s| s.position_m);
        }
        let a = self.samples[i - 1];
        let Some(b) = self.samples.get(i) else {
            return Some(a.position_m);
        };
        if t_s > a.t_s && self.breaks_after(i - 1) {
            return None;
        }
        let f = (t_s - a.t_s) / (b.t_s - a.t_s);
        Some([
            a.position_m[0] + f * (b.position_m[0] - a.position_m[0]),
            a.position_m[1] + f * (b.position_m[1] - a.position_m[1]),
        ])
    }
}

/// Unit of the time column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TimeUnit {
    Seconds,
    Milliseconds,
    Nanoseconds,
}

impl TimeUnit {
    fn seconds_per_unit(self) -> f64 {
        match self {
            TimeUnit::Seconds => 1.0,
            TimeUnit::Milliseconds => 1e-3,
            TimeUnit::Nanoseconds => 1e-9,
        }
    }

    /// The unit a column's name implies: `*_ns`, `*_ms`, else seconds.
    fn of_column(name: &str) -> TimeUnit {
        if name.ends_with("_ns") {
            TimeUnit::Nanoseconds
        } else if name.ends_with("_ms") {
            TimeUnit::Milliseconds
        } else {
            TimeUnit::Seconds
        }
    }
}

impl FromStr for TimeUnit {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "s" => Ok(TimeUnit::Seconds),
            "ms" => Ok(TimeUnit::Milliseconds),
            "ns" => Ok(TimeUnit::Nanoseconds),
            _ => Err(format!("unknown time unit {s:?} (s, ms or ns)")),
        }
    }
}

/// How to read a file.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadOptions {
    /// Overrides the unit the time column's name implies.
    pub time_unit: Option<TimeUnit>,
    /// Positions are multiplied by this (0.001 for millimetres) ...
    pub scale: f64,
    /// ... and then shifted by this (to move a corner origin to the pitch centre).
    pub offset_m: [f64; 2],
    /// A track with fewer usable rows is an error.
    pub min_rows: usize,
}

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions {
            time_unit: None,
            scale: 1.0,
            offset_m: [0.0, 0.0],
            min_rows: 10,
        }
    }
}

/// Accepted names of the time, x, y and track columns (compared case-insensitively).
pub const TIME_COLUMNS: [&str; 13] = [
    "t",
    "time",
    "t_s",
    "time_s",
    "timestamp",
    "stamp",
    "t_ms",
    "time_ms",
    "timestamp_ms",
    "t_ns",
    "time_ns",
    "timestamp_ns",
    "stamp_ns",
];
pub const X_COLUMNS: [&str; 4] = ["x", "x_m", "ball_x", "pos_x"];
pub const Y_COLUMNS: [&str; 4] = ["y", "y_m", "ball_y", "pos_y"];
pub const TRACK_COLUMNS: [&str; 4] = ["track", "track_id", "id", "ball_id"];

/// What was read from one file.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackFile {
    pub file: String,
    /// The text of `# source:` comment lines: where the data came from.
    pub source: Option<String>,
    pub time_unit: TimeUnit,
    pub tracks: Vec<Track>,
    /// Data rows read (usable or not).
    pub rows: usize,
    /// Rows skipped for an empty or non-finite value, or a repeated time ...
    pub skipped_rows: usize,
    /// ... and the first few of their line numbers.
    pub skipped_lines: Vec<usize>,
}

const SKIPPED_LINES_KEPT: usize = 5;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum TrackError {
    #[error("{file}: {message}")]
    Io { file: String, message: String },
    #[error("{file}: no header line")]
    NoHeader { file: String },
    #[error("{file}:{line}: {message}")]
    Csv {
        file: String,
        line: u64,
        message: String,
    },
    #[error("{file}:{line}: no {what} column in the header (accepted: {accepted})")]
    MissingColumn {
        file: String,
        line: usize,
        what: &'static str,
        accepted: String,
    },
    #[error("{file}:{line}: {fields} fields, but the header names {needed}")]
    ShortRow {
        file: String,
        line: usize,
        fields: usize,
        needed: usize,
    },
    #[error("{file}:{line}: {column} is {value:?}, not a number")]
    NotANumber {
        file: String,
        line: usize,
        column: String,
        value: String,
    },
    #[error(
        "{file}:{line}: time goes backwards ({t_s:.6} s after {previous_s:.6} s){}",
        track_suffix(track)
    )]
    TimeGoesBack {
        file: String,
        line: usize,
        t_s: f64,
        previous_s: f64,
        track: Option<String>,
    },
    #[error(
        "{file}: {rows} usable rows{}, at least {min} needed",
        track_suffix(track)
    )]
    TooFewRows {
        file: String,
        track: Option<String>,
        rows: usize,
        min: usize,
    },
}

fn track_suffix(track: &Option<String>) -> String {
    track
        .as_ref()
        .map_or(String::new(), |t| format!(" in track {t:?}"))
}

/// The columns found in the header.
struct Columns {
    t: usize,
    x: usize,
    y: usize,
    track: Option<usize>,
    unit: TimeUnit,
    names: Vec<String>,
}

fn find(names: &[String], accepted: &[&str]) -> Option<usize> {
    accepted
        .iter()
        .find_map(|a| names.iter().position(|n| n == a))
}

fn columns(header: &StringRecord, file: &str, line: usize) -> Result<Columns, TrackError> {
    let names: Vec<String> = header.iter().map(str::to_ascii_lowercase).collect();
    let missing = |what, accepted: &[&str]| TrackError::MissingColumn {
        file: file.to_string(),
        line,
        what,
        accepted: accepted.join(", "),
    };
    let t = find(&names, &TIME_COLUMNS).ok_or_else(|| missing("time", &TIME_COLUMNS))?;
    let x = find(&names, &X_COLUMNS).ok_or_else(|| missing("x", &X_COLUMNS))?;
    let y = find(&names, &Y_COLUMNS).ok_or_else(|| missing("y", &Y_COLUMNS))?;
    Ok(Columns {
        t,
        x,
        y,
        track: find(&names, &TRACK_COLUMNS),
        unit: TimeUnit::of_column(&names[t]),
        names,
    })
}

/// The delimiter a header line uses: comma, tab or semicolon.
fn delimiter(header: &str) -> u8 {
    [b',', b'\t', b';']
        .into_iter()
        .find(|d| header.contains(char::from(*d)))
        .unwrap_or(b',')
}

/// A time value as written: integers exactly (epoch nanoseconds need all 64 bits).
#[derive(Debug, Clone, Copy)]
enum Raw {
    Int(i128),
    Float(f64),
}

impl Raw {
    fn as_f64(self) -> f64 {
        match self {
            Raw::Int(i) => i as f64,
            Raw::Float(f) => f,
        }
    }

    /// `self − origin`, exactly when both are integers.
    fn minus(self, origin: Raw) -> f64 {
        match (self, origin) {
            (Raw::Int(a), Raw::Int(b)) => (a - b) as f64,
            _ => self.as_f64() - origin.as_f64(),
        }
    }
}

/// One field as a number: `Ok(None)` for empty or non-finite (a skipped row), `Err` for text.
fn number(s: &str) -> Result<Option<Raw>, ()> {
    if s.is_empty() {
        return Ok(None);
    }
    if let Ok(i) = s.parse::<i128>() {
        return Ok(Some(Raw::Int(i)));
    }
    match s.parse::<f64>() {
        Ok(f) if f.is_finite() => Ok(Some(Raw::Float(f))),
        Ok(_) => Ok(None),
        Err(_) => Err(()),
    }
}

/// Parses a file's text. `file` names it in errors and in the tracks' names.
pub fn parse(text: &str, file: &str, opts: &ReadOptions) -> Result<TrackFile, TrackError> {
    // `# source:` comments before the header say where the data came from; the header's
    // delimiter is the file's.
    let mut source: Vec<String> = Vec::new();
    let mut delim = None;
    for line in text.lines() {
        let l = line.trim();
        if let Some(comment) = l.strip_prefix('#') {
            if let Some(s) = comment.trim().strip_prefix("source:") {
                source.push(s.trim().to_string());
            }
            continue;
        }
        if !l.is_empty() {
            delim = Some(delimiter(l));
            break;
        }
    }
    let delim = delim.ok_or_else(|| TrackError::NoHeader {
        file: file.to_string(),
    })?;
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .delimiter(delim)
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let csv_error = |e: csv::Error| TrackError::Csv {
        file: file.to_string(),
        line: e.position().map_or(0, csv::Position::line),
        message: e.to_string(),
    };
    // Data lines: not blank, not a comment (indented ones too), with their line numbers.
    let mut records = reader
        .records()
        .map(|r| r.map_err(csv_error))
        .filter(|r| {
            r.as_ref().map_or(true, |rec| {
                let first = rec.get(0).unwrap_or_default();
                !(first.starts_with('#') || rec.iter().all(str::is_empty))
            })
        })
        .map(|r| r.map(|rec| (line_of(&rec), rec)));
    let (header_line, header) = records.next().ok_or_else(|| TrackError::NoHeader {
        file: file.to_string(),
    })??;
    let cols = columns(&header, file, header_line)?;
    let unit = opts.time_unit.unwrap_or(cols.unit);
    let needed = [Some(cols.t), Some(cols.x), Some(cols.y), cols.track]
        .into_iter()
        .flatten()
        .max()
        .unwrap_or(0)
        + 1;
    let stem = Path::new(file)
        .file_name()
        .map_or(file.to_string(), |s| s.to_string_lossy().into_owned());
    let mut out = TrackFile {
        file: file.to_string(),
        source: (!source.is_empty()).then(|| source.join(" ")),
        time_unit: unit,
        tracks: Vec::new(),
        rows: 0,
        skipped_rows: 0,
        skipped_lines: Vec::new(),
    };
    // Per track id, in order of first appearance: its samples and last time.
    let mut ids: Vec<String> = Vec::new();
    let mut origin: Option<Raw> = None;
    let skip = |out: &mut TrackFile, n: usize| {
        out.skipped_rows += 1;
        if out.skipped_lines.len() < SKIPPED_LINES_KEPT {
            out.skipped_lines.push(n);
        }
    };
    for record in records {
        let (n, fields) = record?;
        out.rows += 1;
        if fields.len() < needed {
            return Err(TrackError::ShortRow {
                file: file.to_string(),
                line: n,
                fields: fields.len(),
                needed,
            });
        }
        let field = |c: usize| fields.get(c).unwrap_or_default();
        let value = |c: usize| {
            number(field(c)).map_err(|()| TrackError::NotANumber {
                file: file.to_string(),
                line: n,
                column: cols.names[c].clone(),
                value: field(c).to_string(),
            })
        };
        let (t, x, y) = (value(cols.t)?, value(cols.x)?, value(cols.y)?);
        let (Some(t), Some(x), Some(y)) = (t, x, y) else {
            skip(&mut out, n);
            continue;
        };
        let id = cols.track.map(|c| field(c).to_string());
        let key = id.as_deref().unwrap_or_default();
        let index = match ids.iter().position(|i| i == key) {
            Some(i) => i,
            None => {
                ids.push(key.to_string());
                out.tracks.push(Track {
                    name: match &id {
                        Some(id) => format!("{stem}#{id}"),
                        None => stem.clone(),
                    },
                    samples: Vec::new(),
                });
                ids.len() - 1
            }
        };
        let origin = *origin.get_or_insert(t);
        let t_s = t.minus(origin) * unit.seconds_per_unit();
        let samples = &mut out.tracks[index].samples;
        if let Some(prev) = samples.last() {
            if t_s < prev.t_s {
                return Err(TrackError::TimeGoesBack {
                    file: file.to_string(),
                    line: n,
                    t_s,
                    previous_s: prev.t_s,
                    track: id,
                });
            }
            if t_s == prev.t_s {
                skip(&mut out, n);
                continue;
            }
        }
        samples.push(TrackSample {
            t_s,
            position_m: [
                x.as_f64() * opts.scale + opts.offset_m[0],
                y.as_f64() * opts.scale + opts.offset_m[1],
            ],
        });
    }
    if out.tracks.is_empty() {
        return Err(TrackError::TooFewRows {
            file: file.to_string(),
            track: None,
            rows: 0,
            min: opts.min_rows,
        });
    }
    for (track, id) in out.tracks.iter().zip(&ids) {
        if track.samples.len() < opts.min_rows {
            return Err(TrackError::TooFewRows {
                file: file.to_string(),
                track: cols.track.map(|_| id.clone()),
                rows: track.samples.len(),
                min: opts.min_rows,
            });
        }
    }
    Ok(out)
}

/// The line a record starts on (1 for the first).
fn line_of(record: &StringRecord) -> usize {
    record
        .position()
        .map_or(0, |p| usize::try_from(p.line()).unwrap_or(usize::MAX))
}

/// Reads and parses one file.
pub fn read(path: &Path, opts: &ReadOptions) -> Result<TrackFile, TrackError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| TrackError::Io {
        file: file.clone(),
        message: e.to_string(),
    })?;
    parse(&text, &file, opts)
}

/// A track as CSV (`t_s,x_m,y_m`), with its source in a `# source:` comment: the format
/// [`parse`] reads back.
pub fn to_csv(samples: &[TrackSample], source: &str) -> String {
    let mut s = format!("# source: {source}\nt_s,x_m,y_m\n");
    for p in samples {
        s.push_str(&format!(
            "{:.4},{:.5},{:.5}\n",
            p.t_s, p.position_m[0], p.position_m[1]
        ));
    }
    s
}

#[cfg(test)]
mod tests;
