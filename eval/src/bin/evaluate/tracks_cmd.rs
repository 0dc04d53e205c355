//! `evaluate --tracks FILE.csv`: recorded ball tracks, observed by simulated robots, each
//! method scored against the track itself.

use anyhow::Context;
use eval::plot::write_png;
use eval::track_eval::{TrackSetup, evaluate_tracks};
use eval::track_obs::ObserverSetup;
use eval::track_report::{self, FileSummary, SECTION_BEGIN, SECTION_END};
use proto::{Pitch, WallSide};
use std::path::{Path, PathBuf};
use tools::tracks::{self, ReadOptions, TimeUnit, Track};

/// Where a track's coordinates start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Origin {
    /// The field frame: origin at the pitch centre.
    Centre,
    /// Origin at the corner (−length/2, −width/2), x along the length, y along the width.
    Corner,
}

/// A pitch size `LxW` in metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PitchSize {
    pub length_m: f64,
    pub width_m: f64,
}

impl std::str::FromStr for PitchSize {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || format!("pitch size {s:?} is not LxW in metres (e.g. 3.9x2.6)");
        let (l, w) = s.split_once(['x', 'X']).ok_or_else(bad)?;
        let (length_m, width_m) = (
            l.trim().parse::<f64>().map_err(|_| bad())?,
            w.trim().parse::<f64>().map_err(|_| bad())?,
        );
        if !(length_m.is_finite() && width_m.is_finite() && length_m > 0.0 && width_m > 0.0) {
            return Err(bad());
        }
        Ok(PitchSize { length_m, width_m })
    }
}

/// The flags of the tracks mode.
#[derive(Debug, Clone, clap::Args)]
pub struct TrackArgs {
    /// Score the fusion core on recorded ball tracks: CSV files (comma-separated or the flag
    /// repeated) whose header names a time column (`t`, `time`, `t_s`, `timestamp`, `t_ns`,
    /// …), `x` / `x_m` and `y` / `y_m`, optionally `track` / `id` to split a file into
    /// several tracks; other columns are ignored. Its generated section is marked
    /// `<!-- evaluate-tracks:begin -->` / `<!-- evaluate-tracks:end -->`.
    #[arg(long, value_delimiter = ',', conflicts_with_all = ["vision", "scenarios"])]
    pub tracks: Vec<PathBuf>,
    /// Unit of the tracks' time column: s, ms or ns (default: from the column's name,
    /// `*_ns` or `*_ms`, else seconds).
    #[arg(long, requires = "tracks")]
    pub time_unit: Option<TimeUnit>,
    /// Multiply the tracks' positions by this (0.001 for millimetres).
    #[arg(long, default_value_t = 1.0, requires = "tracks")]
    pub scale: f64,
    /// Where the tracks' origin is.
    #[arg(long, value_enum, default_value = "centre", requires = "tracks")]
    pub origin: Origin,
    /// Pitch size LxW in metres, walls on all sides (default: the MiRo pitch, 3.9x2.6).
    #[arg(long, requires = "tracks")]
    pub pitch: Option<PitchSize>,
    /// Ball radius (default: the MiRo pitch's, 0.04 m).
    #[arg(long, requires = "tracks")]
    pub ball_radius_m: Option<f64>,
    /// Robots observing each track, at fixed poses around the pitch facing its centre.
    #[arg(long, default_value_t = ObserverSetup::default().robots, requires = "tracks")]
    pub robots: usize,
    /// Captures per second per robot.
    #[arg(long, default_value_t = ObserverSetup::default().rate_hz, requires = "tracks")]
    pub rate_hz: f64,
    /// σ of each observation's position noise (isotropic; the covariance says so).
    #[arg(long, default_value_t = ObserverSetup::default().noise_m, requires = "tracks")]
    pub noise_m: f64,
    /// Mean delay from capture to arrival (half fixed, half exponential jitter).
    #[arg(long, default_value_t = ObserverSetup::default().latency_s, requires = "tracks")]
    pub latency_s: f64,
    /// Probability that a capture is lost.
    #[arg(long, default_value_t = ObserverSetup::default().dropout, requires = "tracks")]
    pub dropout: f64,
    /// The first robot's clock runs this many milliseconds ahead (a robot whose clock was
    /// never set): its stamps are late by it.
    #[arg(long, default_value_t = 0.0, requires = "tracks")]
    pub clock_offset_ms: f64,
    /// Name the generated section and chart: `<!-- evaluate-tracks-NAME:begin -->` and
    /// `tracks-NAME_horizon_error.png`, so runs with different setups keep their own
    /// sections in one document (letters, digits and `-`).
    #[arg(long, requires = "tracks", value_parser = section_name)]
    pub section: Option<String>,
    /// A track with fewer usable rows is an error.
    #[arg(long, default_value_t = ReadOptions::default().min_rows, requires = "tracks")]
    pub min_rows: usize,
}

/// The outputs shared with the other modes.
#[derive(Debug)]
pub struct Outputs<'a> {
    pub seeds: u64,
    pub jobs: usize,
    pub json: Option<&'a Path>,
    pub markdown: Option<&'a Path>,
    pub doc: Option<&'a Path>,
    pub plots: &'a Path,
}

impl TrackArgs {
    fn pitch(&self) -> Pitch {
        let mut pitch = Pitch::default();
        if let Some(size) = self.pitch {
            pitch.length_m = size.length_m;
            pitch.width_m = size.width_m;
            pitch.walls = WallSide::ALL.to_vec();
        }
        if let Some(r) = self.ball_radius_m {
            pitch.ball_radius_m = r;
        }
        pitch
    }

    fn observers(&self) -> ObserverSetup {
        ObserverSetup {
            robots: self.robots,
            rate_hz: self.rate_hz,
            noise_m: self.noise_m,
            latency_s: self.latency_s,
            dropout: self.dropout,
            clock_offset_s: self.clock_offset_ms * 1e-3,
        }
    }

    fn read_options(&self, pitch: &Pitch) -> ReadOptions {
        ReadOptions {
            time_unit: self.time_unit,
            scale: self.scale,
            offset_m: match self.origin {
                Origin::Centre => [0.0, 0.0],
                Origin::Corner => [-pitch.half_length_m(), -pitch.half_width_m()],
            },
            min_rows: self.min_rows,
        }
    }

    /// The command line that reproduces a run, for the generated section.
    fn command(&self, out: &Outputs) -> String {
        let files: Vec<String> = self
            .tracks
            .iter()
            .map(|p| p.display().to_string())
            .collect();
        let mut cmd = format!(
            "cargo run --release -p eval --bin evaluate -- --tracks {}",
            files.join(",")
        );
        if out.seeds != 1 {
            cmd.push_str(&format!(" --seeds {}", out.seeds));
        }
        if let Some(u) = self.time_unit {
            let unit = match u {
                TimeUnit::Seconds => "s",
                TimeUnit::Milliseconds => "ms",
                TimeUnit::Nanoseconds => "ns",
            };
            cmd.push_str(&format!(" --time-unit {unit}"));
        }
        if self.scale != 1.0 {
            cmd.push_str(&format!(" --scale {}", self.scale));
        }
        if self.origin == Origin::Corner {
            cmd.push_str(" --origin corner");
        }
        if let Some(p) = self.pitch {
            cmd.push_str(&format!(" --pitch {}x{}", p.length_m, p.width_m));
        }
        if let Some(r) = self.ball_radius_m {
            cmd.push_str(&format!(" --ball-radius-m {r}"));
        }
        let (o, d) = (self.observers(), ObserverSetup::default());
        let flags = [
            ("robots", o.robots as f64, d.robots as f64),
            ("rate-hz", o.rate_hz, d.rate_hz),
            ("noise-m", o.noise_m, d.noise_m),
            ("latency-s", o.latency_s, d.latency_s),
            ("dropout", o.dropout, d.dropout),
            ("clock-offset-ms", o.clock_offset_s * 1e3, 0.0),
        ];
        for (name, v, default) in flags {
            if v != default {
                cmd.push_str(&format!(" --{name} {v}"));
            }
        }
        if let Some(name) = &self.section {
            cmd.push_str(&format!(" --section {name}"));
        }
        if let Some(doc) = out.doc {
            cmd.push_str(&format!(" --doc {}", doc.display()));
        }
        cmd.push_str(&format!(" --plots {}", out.plots.display()));
        cmd
    }

    /// The generated section's markers and the chart's file name.
    fn section_names(&self) -> (String, String, String) {
        match &self.section {
            None => (
                SECTION_BEGIN.to_string(),
                SECTION_END.to_string(),
                "tracks_horizon_error.png".to_string(),
            ),
            Some(n) => (
                format!("<!-- evaluate-tracks-{n}:begin -->"),
                format!("<!-- evaluate-tracks-{n}:end -->"),
                format!("tracks-{n}_horizon_error.png"),
            ),
        }
    }
}

fn section_name(s: &str) -> Result<String, String> {
    let ok =
        !s.is_empty() && s.len() <= 40 && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '-');
    if ok {
        Ok(s.to_string())
    } else {
        Err(format!(
            "a section name is 1 to 40 letters, digits or '-', not {s:?}"
        ))
    }
}

/// Reads the tracks, scores every method, prints and writes the report.
pub fn run(args: &TrackArgs, out: &Outputs) -> anyhow::Result<()> {
    let pitch = args.pitch();
    anyhow::ensure!(
        pitch.ball_radius_m > 0.0 && pitch.ball_radius_m < 0.5 * pitch.width_m.min(pitch.length_m),
        "ball radius {} m does not fit the pitch",
        pitch.ball_radius_m
    );
    anyhow::ensure!(
        args.scale.is_finite() && args.scale > 0.0,
        "--scale must be positive"
    );
    let opts = args.read_options(&pitch);
    let started = std::time::Instant::now();
    let mut files = Vec::new();
    for path in &args.tracks {
        let f = tracks::read(path, &opts)?;
        if f.skipped_rows > 0 {
            eprintln!(
                "{}: skipped {} of {} rows (empty or non-finite values, repeated times), first on lines {:?}",
                f.file, f.skipped_rows, f.rows, f.skipped_lines
            );
        }
        files.push(f);
    }
    let all: Vec<Track> = files.iter().flat_map(|f| f.tracks.clone()).collect();
    let setup = TrackSetup {
        pitch: pitch.clone(),
        observers: args.observers(),
    };
    let runs = evaluate_tracks(&all, &setup, out.seeds, out.jobs)?;
    for r in runs.iter().filter(|r| r.seed == 0 && r.samples_outside > 0) {
        eprintln!(
            "warning: {}: {} samples lie outside the {} m × {} m pitch (wrong --pitch, --origin or --scale?)",
            r.track, r.samples_outside, pitch.length_m, pitch.width_m
        );
    }
    let rep = track_report::report(
        files.iter().map(FileSummary::of).collect(),
        &pitch,
        &setup.observers,
        out.seeds,
        &runs,
    );
    let text = format!(
        "{}\n{}",
        track_report::markdown_tracks(&rep),
        track_report::markdown(&rep)
    );
    println!("{text}");
    let secs = started.elapsed().as_secs_f64();
    if let Some(path) = out.json {
        eval::report::write_json(path, &rep)?;
    }
    if let Some(path) = out.markdown {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    let (begin, end, chart) = args.section_names();
    if let Some(path) = out.doc {
        let section = doc_section(args, out, &rep, &text, all.len(), secs);
        eval::report::rewrite_section_between(path, &begin, &end, &section)?;
        eprintln!("updated {}", path.display());
    }
    std::fs::create_dir_all(out.plots)
        .with_context(|| format!("creating {}", out.plots.display()))?;
    let plot = out.plots.join(chart);
    write_png(&track_report::horizon_chart(&rep), &plot)?;
    eprintln!("wrote {}", plot.display());
    Ok(())
}

/// The generated section: the command, the observers, the tables (with the data's sources).
fn doc_section(
    args: &TrackArgs,
    out: &Outputs,
    rep: &track_report::TracksReport,
    tables: &str,
    n_tracks: usize,
    secs: f64,
) -> String {
    let o = &rep.setup.observers;
    format!(
        "Produced by `{}` ({n_tracks} tracks × {} seeds, {secs:.1} s on {} worker threads).\n\n\
         Observed by {} robots at {} Hz each, σ = {} m per axis, {:.0} ms mean latency, \
         {:.0} % dropout; states every {:.0} ms on a {} m × {} m pitch (ball radius {} m).\n\n\
         {tables}",
        args.command(out),
        out.seeds,
        out.jobs,
        o.robots,
        o.rate_hz,
        o.noise_m,
        o.latency_s * 1e3,
        o.dropout * 100.0,
        rep.setup.tick_s * 1e3,
        rep.setup.pitch_m[0],
        rep.setup.pitch_m[1],
        rep.setup.ball_radius_m,
    )
}
