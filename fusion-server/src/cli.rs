//! Command-line interface: subcommands and the flags they share.

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use fusion_server::config::{FileConfig, PitchFlags};
use fusion_server::live::{Clock, MatchLog, SystemClock};
use fusion_server::matchlog::McapLog;
use fusion_server::net::NetConfig;
use fusion_server::record::RecorderConfig;
use fusion_server::replay::TimeArg;
use fusion_server::serve::{self, ServeConfig};
use fusion_server::simrobots::{self, SimRobotsConfig};
use std::path::PathBuf;
use std::sync::Arc;

#[derive(Debug, Parser)]
#[command(
    name = "fusion-server",
    version,
    about = "Team ball fusion server for MiRo robot football"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Fuse the robots' observations and serve the ball over Zenoh and HTTP.
    Serve(ServeArgs),
    /// The whole system on this machine: the server, simulated MiRos publishing over
    /// loopback Zenoh, and the coach's page.
    Demo(crate::demo::DemoArgs),
    /// Simulated MiRos only: publish a simulated match's observations in real time.
    SimRobots(SimRobotsArgs),
    /// Simulate a match and write it as a match log (observations and ground truth).
    Simulate(SimulateArgs),
    /// Replay match logs: re-fuse offline (default), or serve them as if live.
    Replay(ReplayArgs),
}

#[derive(Debug, Clone, Args)]
pub struct SimulateArgs {
    #[arg(long, default_value = "match")]
    pub scenario: String,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Match length, seconds (default: the scenario's).
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Robots on the pitch in a `match` (default five).
    #[arg(long)]
    pub team_size: Option<usize>,
    /// Directory for the log file.
    #[arg(long, default_value = "out/logs")]
    pub out: PathBuf,
    /// The simulated pitch.
    #[command(flatten)]
    pub pitch: PitchFlags,
}

#[derive(Debug, Clone, Args)]
pub struct ReplayArgs {
    /// Match log files, in order (rotated parts of one match follow each other).
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Directory for the re-fused log (offline mode); a replay of the same file replaces
    /// its earlier one.
    #[arg(long, default_value = "out/replay")]
    pub out: PathBuf,
    /// Only print the summary; write no log.
    #[arg(long)]
    pub no_log: bool,
    /// Publish the recorded observations over Zenoh and serve HTTP as if live.
    #[arg(long)]
    pub realtime: bool,
    /// Playback speed for --realtime (2 = twice as fast).
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// With --realtime: at the end of the log, stand there paused and keep serving (the
    /// coach's page can seek back) until Ctrl-C.
    #[arg(long)]
    pub stay: bool,
    /// Print the replay summary as JSON.
    #[arg(long)]
    pub json: bool,
    /// States at exactly these times instead of the grid, comma-separated: stamps
    /// (nanoseconds since the UNIX epoch) or +SECONDS after the first message (+1.5,+3)
    #[arg(long, value_name = "TIMES", value_delimiter = ',', conflicts_with_all = ["align", "until"])]
    pub at: Vec<TimeArg>,
    /// The grid of states (at --rate-hz) goes through this time instead of starting at the
    /// first message: a stamp or +SECONDS
    #[arg(long, value_name = "TIME")]
    pub align: Option<TimeArg>,
    /// The grid of states goes on to this time (inclusive), past the end of the log if need
    /// be: the ball coasting and stopping. A stamp or +SECONDS after the first message
    #[arg(long, value_name = "TIME")]
    pub until: Option<TimeArg>,
    /// Write the asked-for states (--at or the grid; with neither, on a log with states,
    /// the recomputed ones) to FILE as CSV: time, status, position, velocity, covariance,
    /// learned model, stop point
    #[arg(long, value_name = "FILE")]
    pub states_csv: Option<PathBuf>,
    #[command(flatten)]
    pub serve: ServeArgs,
}

/// Flags shared by every serving subcommand.
#[derive(Debug, Clone, Args)]
pub struct ServeArgs {
    /// TOML configuration file (flags override it).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// HTTP address for the API, the live stream and the page.
    /// [default: 127.0.0.1:8080, or `http` in the configuration file]
    #[arg(long)]
    pub http: Option<String>,
    /// Zenoh endpoint to listen on (repeatable).
    #[arg(long)]
    pub listen: Vec<String>,
    /// Zenoh endpoint to connect to, e.g. a zenohd router (repeatable).
    #[arg(long)]
    pub connect: Vec<String>,
    /// Zenoh mode: peer, client or router.
    #[arg(long)]
    pub mode: Option<String>,
    /// Turn on multicast and gossip scouting (off by default: only the given endpoints).
    #[arg(long)]
    pub scouting: bool,
    /// This server's id (its liveliness token is {prefix}/servers/{id}).
    #[arg(long)]
    pub id: Option<String>,
    /// Key prefix.
    #[arg(long)]
    pub prefix: Option<String>,
    /// Ball states published per second.
    #[arg(long)]
    pub rate_hz: Option<f64>,
    /// Also publish a state right after new observations (lowest latency).
    #[arg(long)]
    pub on_update: bool,
    /// Only accept these robots (comma-separated ids).
    #[arg(long, value_delimiter = ',')]
    pub roster: Vec<String>,
    /// Record every observation, status and published state as MCAP match logs in DIR.
    #[arg(long, value_name = "DIR")]
    pub record: Option<PathBuf>,
    /// Start a new log file after this many megabytes.
    #[arg(long)]
    pub record_max_mb: Option<f64>,
    /// Start a new log file after this many minutes.
    #[arg(long)]
    pub record_max_min: Option<f64>,
    /// Token the control endpoints (replay's pause, play, seek, speed) require as
    /// `Authorization: Bearer TOKEN`; without it only this machine may use them.
    #[arg(long, value_name = "TOKEN")]
    pub control_token: Option<String>,
    #[command(flatten)]
    pub pitch: PitchFlags,
}

#[derive(Debug, Clone, Args)]
pub struct SimRobotsArgs {
    /// Zenoh endpoint of the server (or a router).
    #[arg(long, required = true)]
    pub connect: Vec<String>,
    #[arg(long, default_value = "match")]
    pub scenario: String,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Play only these robots (comma-separated ids); default every observer.
    #[arg(long, value_delimiter = ',')]
    pub only: Vec<String>,
    /// Match length, seconds (default: the scenario's).
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Robots on the pitch in a `match` (default five).
    #[arg(long)]
    pub team_size: Option<usize>,
    /// Match start as nanoseconds since the UNIX epoch (default: now); processes that play
    /// one match together must share it.
    #[arg(long)]
    pub start_ns: Option<u64>,
    /// Play the next seed after each match, until stopped.
    #[arg(long)]
    pub repeat: bool,
    #[arg(long, default_value = proto::DEFAULT_PREFIX)]
    pub prefix: String,
    /// The simulated pitch (give the server the same).
    #[command(flatten)]
    pub pitch: PitchFlags,
}

/// Resolves the serving flags over the configuration file: the server's settings and,
/// when recording, the match log's.
pub fn serve_config(a: &ServeArgs) -> Result<(ServeConfig, Option<RecorderConfig>)> {
    let mut cfg = ServeConfig::default();
    let mut rec = fusion_server::config::RecordFile::default();
    if let Some(path) = &a.config {
        let file = FileConfig::load(path)?;
        file.apply(&mut cfg)?;
        rec = file.record;
    }
    if let Some(d) = &a.record {
        rec.dir = Some(d.clone());
    }
    rec.max_mb = a.record_max_mb.or(rec.max_mb);
    rec.max_minutes = a.record_max_min.or(rec.max_minutes);
    if let Some(h) = &a.http {
        cfg.http = h.clone();
    }
    if !a.listen.is_empty() {
        cfg.net.listen = a.listen.clone();
    }
    if !a.connect.is_empty() {
        cfg.net.connect = a.connect.clone();
    }
    if let Some(m) = &a.mode {
        cfg.net.mode = m.clone();
        // A client only connects (to a router): no default listening endpoint.
        if m == "client" && a.listen.is_empty() {
            cfg.net.listen.clear();
        }
    }
    if a.scouting {
        cfg.net.multicast_scouting = true;
        cfg.net.gossip_scouting = true;
    }
    if let Some(id) = &a.id {
        anyhow::ensure!(proto::is_valid_id(id), "--id {id:?} is not a valid id");
        cfg.server_id = id.clone();
    }
    if let Some(p) = &a.prefix {
        proto::KeySpace::new(p)?;
        cfg.prefix = p.clone();
    }
    if let Some(r) = a.rate_hz {
        anyhow::ensure!(r.is_finite() && r > 0.0, "--rate-hz must be positive");
        cfg.state_rate_hz = r;
    }
    cfg.publish_on_update |= a.on_update;
    if let Some(t) = &a.control_token {
        anyhow::ensure!(
            t.len() >= 8 && t.chars().all(|c| c.is_ascii_graphic()),
            "--control-token must be at least 8 visible ASCII characters"
        );
        cfg.control_token = Some(t.clone());
    }
    if !a.roster.is_empty() {
        cfg.engine.roster = Some(a.roster.iter().cloned().collect());
    }
    let pitch = a.pitch.over(&cfg.engine.fusion.pitch)?;
    cfg.engine.fusion.set_pitch(pitch);
    cfg.net.check()?;
    let record = rec.dir.as_ref().map(|dir| {
        let mut r = RecorderConfig::new(dir);
        r.max_bytes = rec.max_mb.map(|mb| (mb * 1e6) as u64);
        r.max_duration_s = rec.max_minutes.map(|m| m * 60.0);
        if let Some(f) = rec.flush_interval_s {
            r.flush_interval_s = f;
        }
        r
    });
    if let Some(r) = &record {
        r.validate()?;
    }
    Ok((cfg, record))
}

/// Starts the match log, if one is configured.
pub fn start_log(rec: Option<RecorderConfig>) -> Result<Option<Arc<McapLog>>> {
    rec.map(|r| {
        let dir = r.dir.clone();
        McapLog::start(r, SystemClock.now())
            .map(Arc::new)
            .with_context(|| format!("starting the match log in {}", dir.display()))
    })
    .transpose()
}

/// Finishes the match log and says where it is.
pub fn finish_log(log: Option<Arc<McapLog>>) -> Result<()> {
    if let Some(log) = log
        && let Some(summary) = log.finish()?
    {
        for f in &summary.files {
            println!("match log: {}", f.display());
        }
        println!("{} messages recorded", summary.messages);
    }
    Ok(())
}

pub fn as_match_log(log: &Option<Arc<McapLog>>) -> Option<Arc<dyn MatchLog>> {
    log.clone().map(|l| l as Arc<dyn MatchLog>)
}

/// Resolves on Ctrl-C or SIGTERM.
pub async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {}
        _ = term => {}
    }
}

pub async fn bind_http(addr: &str) -> Result<tokio::net::TcpListener> {
    tokio::net::TcpListener::bind(addr)
        .await
        .with_context(|| format!("cannot listen for HTTP on {addr} (choose another with --http)"))
}

async fn serve_cmd(a: ServeArgs) -> Result<()> {
    let (cfg, rec) = serve_config(&a)?;
    let http = bind_http(&cfg.http).await?;
    let log = start_log(rec)?;
    let live = serve::shared(&cfg, Arc::new(SystemClock), as_match_log(&log))?;
    println!("http://{}/", http.local_addr()?);
    println!("zenoh {}", cfg.net.listen.join(" "));
    let served = serve::serve(cfg, live, http, shutdown_signal()).await;
    finish_log(log)?;
    served
}

async fn sim_robots_cmd(a: SimRobotsArgs) -> Result<()> {
    let pitch = a.pitch.over(&proto::Pitch::default())?;
    let cfg = SimRobotsConfig {
        scenario: a.scenario,
        seed: a.seed,
        robots: a.only,
        duration_s: a.duration_s,
        team_size: a.team_size,
        start: a
            .start_ns
            .map(proto::Stamp)
            .unwrap_or_else(|| SystemClock.now()),
        repeat: a.repeat,
        status_rate_hz: 5.0,
        prefix: a.prefix,
        net: NetConfig {
            connect: a.connect,
            ..NetConfig::default()
        },
    };
    let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
    tokio::spawn(async move {
        shutdown_signal().await;
        let _ = stop_tx.send(true);
    });
    let n = simrobots::run_on(cfg, pitch, stop_rx).await?;
    println!("published {n} observations");
    Ok(())
}

pub async fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Serve(a) => serve_cmd(a).await,
        Command::Demo(a) => crate::demo::run(a).await,
        Command::SimRobots(a) => sim_robots_cmd(a).await,
        Command::Simulate(a) => crate::replay_cmd::simulate(a),
        Command::Replay(a) if a.realtime => crate::replay_cmd::realtime(a).await,
        Command::Replay(a) => crate::replay_cmd::offline(a),
    }
}

#[cfg(test)]
mod tests;
