//! `demo`: the whole system on this machine: the fusion server with simulated MiRos (real
//! agent pipelines in `sim_agent` processes rendering their cameras, or modelled
//! observations with `--light`) and the coach's page. Each match plays for `--duration-s`
//! (default 120 s) with `--team-size` robots (default 4), then the next seed.

#[path = "demo/agents.rs"]
mod agents;

use anyhow::{Context, Result};
use clap::Parser;
use fusion_server::{Clock, SystemClock};
use fusion_server::{
    ServeArgs, as_match_log, bind_http, finish_log, serve_config, shutdown_signal, start_log,
};
use proto::net::NetConfig;

use proto::Pitch;
use std::sync::Arc;
use std::time::Duration;
use tools::sim_args::MatchArgs;
use tools::sim_robots::{self, SimRobotsConfig};

/// Each match's length without `--duration-s`, seconds.
const MATCH_S: f64 = 120.0;
/// Robots on the pitch without `--team-size`.
const TEAM_SIZE: usize = 4;

#[derive(Debug, Clone, Parser)]
#[command(
    about = "The whole system on this machine: the server, simulated MiRos and the coach's page",
    // The demo's own defaults, not the simulator's.
    mut_arg("team_size", |a| a.help("Robots on the pitch (default 4)")),
    mut_arg("duration_s", |a| a.help("Each match's length, seconds (default 120; then the next seed)"))
)]
struct DemoArgs {
    #[command(flatten)]
    serve: ServeArgs,
    /// The match the robots play (a new seed after each one). The pitch flags are the
    /// server's (under "Pitch").
    #[command(flatten)]
    sim: MatchArgs,
    /// Stop after this many seconds (default: run until Ctrl-C).
    #[arg(long)]
    for_s: Option<f64>,
    /// Robots report modelled observations instead of running the real perception on
    /// rendered camera frames (much lighter: no rendering, no image processing).
    #[arg(long)]
    light: bool,
    /// Camera frames per second of each agent (both cameras).
    #[arg(long, default_value_t = 10.0)]
    camera_hz: f64,
    /// Camera views each agent publishes per second and camera (0: none).
    #[arg(long, default_value_t = 2.0)]
    view_hz: f64,
}

/// Prints a one-line summary every few seconds until `stop`.
async fn report_progress(
    live: fusion_server::Shared,
    mut stop: tokio::sync::watch::Receiver<bool>,
) {
    let mut tick = tokio::time::interval(Duration::from_secs(5));
    tick.tick().await;
    loop {
        tokio::select! {
            _ = tick.tick() => {}
            _ = stop.wait_for(|s| *s) => return,
        }
        let line = live.with_engine(|e| {
            let now = live.clock.now();
            let online = e.robots(now).iter().filter(|r| r.online).count();
            let ball = e.ball_state(now).map(|b| {
                format!(
                    "{:?} at ({:+.2}, {:+.2}) m, {:.2} m/s",
                    b.status,
                    b.position_m[0],
                    b.position_m[1],
                    b.velocity_mps[0].hypot(b.velocity_mps[1])
                )
            });
            format!(
                "{online} robots online, {} observations fused, ball {}",
                e.counters().observations_accepted,
                ball.unwrap_or_else(|| "not seen yet".into())
            )
        });
        tracing::info!("{line}");
    }
}

/// The MiRo pitch's ground, whatever the wall restitution (a nominal value: the simulated
/// walls bounce with their own).
fn on_miro_ground(pitch: &Pitch) -> bool {
    let miro = Pitch::default();
    Pitch {
        wall_restitution: miro.wall_restitution,
        ..pitch.clone()
    } == miro
}

fn main() -> Result<()> {
    let args = DemoArgs::parse();
    robot_agent::cli::init_logging();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?;
    rt.block_on(run(args))
}

async fn run(a: DemoArgs) -> Result<()> {
    let (mut cfg, rec) = serve_config(&a.serve)?;
    anyhow::ensure!(
        !cfg.net.is_secured(),
        "the demo's simulated robots have no certificates: run it without --tls (a secured \
         network with simulated robots: `sim_robots --keys`, docs/operations.md 4.6)"
    );
    if cfg.net.listen.is_empty() {
        cfg.net.listen = vec!["tcp/127.0.0.1:7447".into()];
    }
    let endpoint = cfg.net.listen[0].clone();
    let pitch = cfg.engine.fusion.pitch.clone();
    let agent_bin = if a.light {
        None
    } else {
        agents::agent_binary()
    };
    anyhow::ensure!(
        agent_bin.is_none() || on_miro_ground(&pitch),
        "the robot agents render the MiRo pitch: a pitch of another size, other walls or \
         another ball needs --light"
    );
    let http = bind_http(&cfg.http).await?;
    let url = format!("http://{}/", http.local_addr()?);
    let log = start_log(rec)?;
    let live = fusion_server::shared(&cfg, Arc::new(SystemClock), as_match_log(&log))?;
    let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
    let (server_stop_tx, mut server_stop) = tokio::sync::watch::channel(false);
    let server = tokio::spawn(fusion_server::serve(
        cfg.clone(),
        live.clone(),
        http,
        async move {
            let _ = server_stop.wait_for(|s| *s).await;
        },
    ));
    let start = a.sim.start_or(SystemClock.now().offset_secs(1.0));
    let match_s = a.sim.duration_s.unwrap_or(MATCH_S);
    let team_size = a.sim.team_size.unwrap_or(TEAM_SIZE);
    let (scenario, seed) = (a.sim.scenario.clone(), a.sim.seed);
    if !a.light && agent_bin.is_none() {
        println!(
            "No sim_agent binary next to this one: the robots report modelled observations \
             (build it with `cargo build --release -p tools --bins` to run real perception)."
        );
    }
    let (sims, mut agents) = match agent_bin {
        Some(binary) => {
            let run = sim_robots::simulate(&scenario, seed, start, Some(match_s), Some(team_size))?;
            let ids = sim_robots::chosen_robots(&run, &[])?;
            let agents_cfg = agents::AgentsConfig {
                binary,
                scenario: scenario.clone(),
                seed,
                team_size,
                match_s,
                start,
                camera_hz: a.camera_hz,
                view_hz: a.view_hz,
                endpoint: endpoint.clone(),
                prefix: cfg.prefix.clone(),
            };
            let agents = agents::Agents::spawn(&agents_cfg, &ids)?;
            println!(
                "Demo running: {} agent processes render their cameras of `{}` at {} Hz, find the ball and publish over Zenoh at {endpoint}.",
                ids.len(),
                scenario,
                a.camera_hz
            );
            (None, Some(agents))
        }
        None => {
            let robots = SimRobotsConfig {
                scenario: scenario.clone(),
                seed,
                robots: Vec::new(),
                duration_s: Some(match_s),
                team_size: Some(team_size),
                start,
                repeat: true,
                status_rate_hz: 5.0,
                footprints: true,
                prefix: cfg.prefix.clone(),
                net: NetConfig::connecting(&endpoint),
                keys: None,
            };
            println!(
                "Demo running: simulated MiRos playing `{}` publish modelled observations over Zenoh at {endpoint}.",
                scenario
            );
            (
                Some(tokio::spawn(sim_robots::run_on(
                    robots,
                    pitch,
                    stop_rx.clone(),
                ))),
                None,
            )
        }
    };
    tokio::spawn(report_progress(live.clone(), stop_rx.clone()));
    if let Some(agents) = agents.as_mut() {
        for (id, status) in agents.exited() {
            tracing::warn!("robot agent {id} exited: {status}");
        }
    }
    println!(
        "Open {url} (API: {url}api/state, live stream: {url}api/stream, metrics: {url}metrics). Ctrl-C stops."
    );
    match a.for_s {
        Some(s) => {
            tokio::select! {
                _ = tokio::time::sleep(Duration::from_secs_f64(s.max(0.0))) => {}
                _ = shutdown_signal() => {}
            }
        }
        None => shutdown_signal().await,
    }
    // Robots leave first, so the server sees them go.
    let _ = stop_tx.send(true);
    if let Some(mut agents) = agents {
        for (id, status) in agents.exited() {
            tracing::warn!("robot agent {id} had exited: {status}");
        }
        agents.stop();
    }
    let published = match sims {
        Some(s) => s.await.context("simulated robots")??,
        None => 0,
    };
    let _ = server_stop_tx.send(true);
    server.await.context("server")??;
    finish_log(log)?;
    let fused = live.with_engine(|e| e.counters().observations_accepted);
    if published > 0 {
        println!("Demo stopped: {published} observations published, {fused} fused.");
    } else {
        println!("Demo stopped: {fused} observations fused.");
    }
    Ok(())
}
