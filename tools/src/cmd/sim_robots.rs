//! `sim_robots`: simulated MiRos only. Each robot of a simulated match gets its own Zenoh
//! session and liveliness token and publishes its modelled observations when they would
//! arrive, and its status (with each camera's floor footprint) at 5 Hz, in real time, to a
//! server (or a router) at `--connect`.

use crate::sim_args::MatchArgs;
use crate::sim_robots::{self, SimRobotsConfig};
use anyhow::Result;
use clap::Parser;
use fusion_server::PitchFlags;
use fusion_server::shutdown_signal;
use fusion_server::{Clock, SystemClock};
use proto::net::NetConfig;

#[derive(Debug, Parser)]
#[command(about = "Simulated MiRos: publish a simulated match's observations in real time")]
struct Args {
    /// Zenoh endpoint of the server (or a router).
    #[arg(long, required = true)]
    connect: Vec<String>,
    /// Zenoh mode: peer, or client (through a zenohd router).
    #[arg(long, default_value = "peer")]
    mode: String,
    /// A secured network's keys folder (`fusion-server keys`): robot {id} joins with the
    /// certificate in DIR/robot-{id}, over tls/ endpoints.
    #[arg(long, value_name = "DIR")]
    keys: Option<std::path::PathBuf>,
    #[command(flatten)]
    sim: MatchArgs,
    /// Play only these robots (comma-separated ids); default every observer.
    #[arg(long, value_delimiter = ',')]
    only: Vec<String>,
    /// Play the next seed after each match, until stopped.
    #[arg(long)]
    repeat: bool,
    /// Statuses without camera footprints: the server then takes no negative information
    /// (what the cameras looked at and did not see) from these robots.
    #[arg(long)]
    no_footprints: bool,
    #[arg(long, default_value = proto::DEFAULT_PREFIX)]
    prefix: String,
    /// The simulated pitch (give the server the same).
    #[command(flatten)]
    pitch: PitchFlags,
}

pub fn main() -> Result<()> {
    let a = Args::parse();
    robot_agent::cli::init_logging();
    tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?
        .block_on(run(a))
}

async fn run(a: Args) -> Result<()> {
    let pitch = a.pitch.over(&proto::Pitch::default())?;
    let cfg = SimRobotsConfig {
        start: a.sim.start_or(SystemClock.now()),
        scenario: a.sim.scenario,
        seed: a.sim.seed,
        robots: a.only,
        duration_s: a.sim.duration_s,
        team_size: a.sim.team_size,
        repeat: a.repeat,
        status_rate_hz: 5.0,
        footprints: !a.no_footprints,
        prefix: a.prefix,
        net: NetConfig {
            mode: a.mode,
            connect: a.connect,
            ..NetConfig::default()
        },
        keys: a.keys,
    };
    let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
    tokio::spawn(async move {
        shutdown_signal().await;
        let _ = stop_tx.send(true);
    });
    let n = sim_robots::run_on(cfg, pitch, stop_rx).await?;
    println!("published {n} observations");
    Ok(())
}
