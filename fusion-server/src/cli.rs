//! Command-line interface: subcommands and the flags they share.

use crate::clock::SystemClock;
use crate::matchlog::replay::TimeArg;
use crate::shell::args::{
    ServeArgs, as_match_log, bind_foxglove, bind_http, finish_log, serve_config, shutdown_signal,
    start_log,
};
use crate::shell::serve;
use anyhow::Result;
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;
use std::sync::Arc;

mod keys;
mod replay;

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
    /// Replay match logs: re-fuse offline (default), or serve them as if live.
    Replay(ReplayArgs),
    /// Make the certificates of a secured network: its authority, one folder per robot,
    /// server and router, and the routers' zenohd configurations.
    Keys(keys::KeysArgs),
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

async fn serve_cmd(a: ServeArgs) -> Result<()> {
    let (cfg, rec) = serve_config(&a)?;
    cfg.check_security()?;
    let http = bind_http(&cfg.http).await?;
    let foxglove = bind_foxglove(cfg.foxglove).await?;
    let log = start_log(rec)?;
    let live = serve::shared(&cfg, Arc::new(SystemClock), as_match_log(&log))?;
    println!("http://{}/", http.local_addr()?);
    println!("zenoh {}", cfg.net.listen.join(" "));
    if !cfg.net.connect.is_empty() {
        println!("zenoh connects to {}", cfg.net.connect.join(" "));
    }
    if cfg.net.is_secured() {
        println!("zenoh TLS with mutual authentication; access control from the roster");
    }
    if let Some(f) = &foxglove {
        println!("foxglove ws://{}", f.local_addr()?);
    }
    let served = serve::serve_all(cfg, live, http, foxglove, shutdown_signal()).await;
    finish_log(log)?;
    served
}

/// The `fusion-server` command line: parses the arguments, sets up logging (`RUST_LOG`,
/// Zenoh's own chatter held to errors) and runs the subcommand.
pub fn main() -> Result<()> {
    let args = Cli::parse();
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info,zenoh=error"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        // Colour codes only for a terminal: a log written to a file or the journal stays plain.
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?;
    rt.block_on(run(args))
}

async fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Serve(a) => serve_cmd(a).await,
        Command::Replay(a) if a.realtime => replay::realtime(a).await,
        Command::Replay(a) => replay::offline(a),
        Command::Keys(a) => keys::run(a),
    }
}

#[cfg(test)]
mod tests;
