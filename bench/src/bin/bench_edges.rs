//! `bench_edges`: a `fusion-server` process at its edges, each against the server's target:
//!
//! 1. a burst of 300 made-up robot ids in 0.3 s on an open network, then five honest
//!    robots (a liveliness token each, 2 cameras × 30 Hz) for 1 s: the share of their
//!    observations accepted;
//! 2. the server under `ulimit -n 256` with 300 idle connections to its HTTP port: whether
//!    and how fast `/api/state` answers, and whether a new robot's observations are
//!    accepted;
//! 3. 1 000 concurrent `GET /api/state`, a connection each: answered, p50, p99;
//! 4. 200 live-stream viewers for 10 s: the frames a second each gets, the server's memory.
//!
//! Prints a markdown table; `--json FILE` keeps the figures, `--doc FILE` rewrites the
//! `bench-edges` section of docs/benchmarks.md.

use anyhow::{Context, Result};
use bench::edges::{Burst, EdgesReport, FdLimit, Gets, Viewers, concurrent_gets};
use bench::load::{ServerProcess, connect, http_get, observation, pose_of};
use bench::load_report::proc_status_kb;
use clap::Parser;
use fusion_server::{Clock, SystemClock};
use futures_util::StreamExt;
use proto::KeySpace;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use tools::progress::Progress;

#[derive(Debug, Parser)]
struct Args {
    /// Concurrent `GET /api/state`.
    #[arg(long, default_value_t = 1000)]
    gets: usize,
    /// Live-stream viewers.
    #[arg(long, default_value_t = 200)]
    viewers: usize,
    /// How long the viewers watch, seconds.
    #[arg(long, default_value_t = 10.0)]
    viewers_s: f64,
    /// The server binary [default: `fusion-server` beside this one].
    #[arg(long)]
    server: Option<PathBuf>,
    #[arg(long)]
    json: Option<PathBuf>,
    #[arg(long)]
    doc: Option<PathBuf>,
}

fn main() {
    let args = Args::parse();
    let result = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .map_err(anyhow::Error::from)
        .and_then(|rt| rt.block_on(run(args)));
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

async fn run(args: Args) -> Result<()> {
    let server = match args.server.clone() {
        Some(s) => s,
        None => std::env::current_exe()?
            .parent()
            .context("this binary's folder")?
            .join(format!("fusion-server{}", std::env::consts::EXE_SUFFIX)),
    };
    anyhow::ensure!(
        server.is_file(),
        "no server binary at {} (build it: cargo build --release -p fusion-server)",
        server.display()
    );
    let progress = Progress::new(4, "edge cases");
    progress.message("300 made-up robot ids, then 5 honest robots");
    let burst = burst(&server).await?;
    progress.inc("ulimit -n 256 and 300 idle connections");
    let fd_limit = fd_limit(&server).await?;
    progress.inc(format!("{} concurrent GET /api/state", args.gets));
    let gets = gets(&server, args.gets)?;
    progress.inc(format!(
        "{} live-stream viewers for {} s",
        args.viewers, args.viewers_s
    ));
    let viewers = viewers(&server, args.viewers, args.viewers_s).await?;
    progress.inc("done");
    progress.finish();
    let report = EdgesReport {
        cores: std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(0),
        burst,
        fd_limit,
        gets,
        viewers,
    };
    let mut command = "cargo run --release -p bench --bin bench_edges --".to_string();
    if args.gets != 1000 {
        command.push_str(&format!(" --gets {}", args.gets));
    }
    if args.viewers != 200 || args.viewers_s != 10.0 {
        command.push_str(&format!(
            " --viewers {} --viewers-s {}",
            args.viewers, args.viewers_s
        ));
    }
    if let Some(p) = &args.doc {
        command.push_str(&format!(" --doc {}", p.display()));
    }
    let table = report.markdown(&command);
    println!("{table}");
    if let Some(p) = &args.json {
        eval::report::write_json(p, &report)?;
    }
    if let Some(p) = &args.doc {
        eval::report::rewrite_section_between(
            p,
            "<!-- bench-edges:begin -->",
            "<!-- bench-edges:end -->",
            &table,
        )?;
    }
    Ok(())
}

/// Each of `ids`, with its own session and liveliness token, publishes 2 cameras × 30 Hz
/// for one second; returns how many were sent.
async fn honest_second(endpoint: &str, ids: &[String]) -> Result<u64> {
    let keys = KeySpace::default();
    let mut robots = Vec::new();
    for id in ids {
        let session = connect(endpoint, None).await?;
        let token = session
            .liveliness()
            .declare_token(keys.robot_liveliness(id)?)
            .await
            .map_err(|e| anyhow::anyhow!("liveliness token: {e}"))?;
        let publ = session
            .declare_publisher(keys.robot_obs(id)?)
            .congestion_control(zenoh::qos::CongestionControl::Block)
            .await
            .map_err(|e| anyhow::anyhow!("observation publisher: {e}"))?;
        robots.push((session, token, publ));
    }
    let start = SystemClock.now();
    let t0 = Instant::now();
    let mut sent = 0;
    for k in 0..60u64 {
        tokio::time::sleep_until((t0 + Duration::from_secs_f64(k as f64 / 60.0)).into()).await;
        for (r, (_, _, publ)) in robots.iter().enumerate() {
            let stamp = SystemClock.now().offset_secs(-0.04);
            let o = observation(
                &ids[r],
                pose_of(r, ids.len()),
                k,
                (k % 2) as usize,
                stamp,
                stamp.secs_since(start),
            );
            publ.put(proto::encode(&o))
                .await
                .map_err(|e| anyhow::anyhow!("{e}"))?;
            sent += 1;
        }
    }
    // What arrived is fused within this (the states run at 30 Hz).
    tokio::time::sleep(Duration::from_millis(300)).await;
    for (session, token, publ) in robots {
        drop((token, publ));
        session.close().await.ok();
    }
    Ok(sent)
}

/// Accepted observations of the robots whose id starts with `prefix`, from `/api/robots`.
fn accepted_of(server: &ServerProcess, prefix: &str) -> Result<u64> {
    let robots: serde_json::Value =
        serde_json::from_str(&http_get(&server.http_addr, "/api/robots")?)?;
    Ok(robots
        .as_array()
        .context("/api/robots is a list")?
        .iter()
        .filter(|r| {
            r["robot_id"]
                .as_str()
                .is_some_and(|id| id.starts_with(prefix))
        })
        .filter_map(|r| r["observations_accepted"].as_u64())
        .sum())
}

async fn burst(bin: &Path) -> Result<Burst> {
    let server = ServerProcess::start(bin, None)?;
    let (made_up_ids, burst_s) = (300, 0.3);
    let attacker = connect(&server.endpoint, None).await?;
    let keys = KeySpace::default();
    let t0 = Instant::now();
    for k in 0..made_up_ids {
        let id = format!("madeup{k:03}");
        let due = t0 + Duration::from_secs_f64(burst_s * k as f64 / made_up_ids as f64);
        tokio::time::sleep_until(due.into()).await;
        let o = observation(&id, pose_of(k, made_up_ids), 0, 0, SystemClock.now(), 0.0);
        attacker
            .put(keys.robot_obs(&id)?, proto::encode(&o))
            .congestion_control(zenoh::qos::CongestionControl::Block)
            .await
            .map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    let ids: Vec<String> = (0..5).map(|r| format!("honest{r}")).collect();
    let honest_sent = honest_second(&server.endpoint, &ids).await?;
    let honest_accepted = accepted_of(&server, "honest")?;
    let too_many_robots = server
        .metrics()?
        .rejected
        .get("observation/too_many_robots")
        .copied()
        .unwrap_or(0);
    attacker.close().await.ok();
    Ok(Burst {
        made_up_ids,
        burst_s,
        honest_robots: ids.len(),
        honest_sent,
        honest_accepted,
        too_many_robots,
    })
}

async fn fd_limit(bin: &Path) -> Result<FdLimit> {
    let open_files = 256;
    let server = ServerProcess::start_with(bin, None, Some(open_files))?;
    let idle_tried = 300;
    let idle: Vec<std::net::TcpStream> = (0..idle_tried)
        .filter_map(|_| std::net::TcpStream::connect(&server.http_addr).ok())
        .collect();
    // Idle for more than a second: the server makes room for what comes next.
    tokio::time::sleep(Duration::from_millis(1500)).await;
    let asked = Instant::now();
    let state = http_get(&server.http_addr, "/api/state");
    let state_s = state.is_ok().then(|| asked.elapsed().as_secs_f64());
    let robot_sent = honest_second(&server.endpoint, &["newcomer".to_string()]).await?;
    let robot_accepted = accepted_of(&server, "newcomer")?;
    let idle_evicted = metric(&server, "rf_http_idle_evicted_total")?;
    let idle_connected = idle.len();
    drop(idle);
    Ok(FdLimit {
        open_files,
        idle_tried,
        idle_connected,
        state_answered: state.is_ok(),
        state_s,
        robot_sent,
        robot_accepted,
        idle_evicted,
    })
}

/// One sample of the server's `/metrics` by name (0 when absent).
fn metric(server: &ServerProcess, name: &str) -> Result<u64> {
    let text = http_get(&server.http_addr, "/metrics")?;
    Ok(text
        .lines()
        .find_map(|l| l.strip_prefix(name)?.strip_prefix(' ')?.parse::<f64>().ok())
        .unwrap_or(0.0) as u64)
}

fn gets(bin: &Path, n: usize) -> Result<Gets> {
    let server = ServerProcess::start(bin, None)?;
    Ok(concurrent_gets(&server.http_addr, n)?)
}

async fn viewers(bin: &Path, n: usize, seconds: f64) -> Result<Viewers> {
    let server = ServerProcess::start(bin, None)?;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let rss_before_kb = proc_status_kb(server.pid(), "VmRSS:").unwrap_or(0);
    let mut sockets = Vec::new();
    for _ in 0..n {
        let (ws, _) =
            tokio_tungstenite::connect_async(format!("ws://{}/api/stream", server.http_addr))
                .await
                .context("a viewer connects")?;
        sockets.push(ws);
    }
    let until = tokio::time::Instant::now() + Duration::from_secs_f64(seconds);
    let tasks: Vec<_> = sockets
        .into_iter()
        .map(|mut ws| {
            tokio::spawn(async move {
                let mut frames = 0u64;
                while let Ok(Some(Ok(m))) = tokio::time::timeout_at(until, ws.next()).await {
                    frames += u64::from(m.is_text());
                }
                frames
            })
        })
        .collect();
    // Counted while all are watching.
    tokio::time::sleep(Duration::from_secs_f64(seconds / 2.0)).await;
    let served = metric(&server, "rf_ws_clients")?;
    let mut rates = Vec::new();
    for t in tasks {
        rates.push(t.await? as f64 / seconds);
    }
    rates.sort_by(f64::total_cmp);
    Ok(Viewers {
        viewers: n,
        served,
        seconds,
        min_hz: rates.first().copied().unwrap_or(0.0),
        median_hz: rates.get(n / 2).copied().unwrap_or(0.0),
        rss_before_kb,
        rss_peak_kb: proc_status_kb(server.pid(), "VmHWM:").unwrap_or(0),
        frames_dropped: metric(&server, "rf_ws_frames_dropped_total")?,
    })
}
