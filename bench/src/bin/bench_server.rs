//! `bench_server`: the fusion server's benchmarks on this machine, in one run.
//!
//! 1. raw Zenoh loopback throughput (the ceiling): one session publishes, another counts;
//! 2. sustained observations per second through Zenoh into the server, without loss;
//! 3. latency from an observation's publish to the first published state that includes
//!    it, at 2 000 observations/s (states published on update);
//! 4. offline replay speed of a 10-minute 5-robot match log;
//! 5. resident memory of a server process fed by 20 simulated robots.
//!
//! Prints a markdown table; `--json FILE` keeps the numbers, `--doc FILE` rewrites the
//! generated section of docs/benchmarks.md.

use anyhow::{Context, Result};
use bench::load_report::{proc_cpu_s, proc_status_kb};
use bench::server_bench::*;
use clap::Parser;
use fusion_server::ServeConfig;
use fusion_server::{Clock, SystemClock};
use proto::net::{NetConfig, free_loopback_port};
use proto::{Camera, Observation, Pose2, Stamp};
use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

#[derive(Debug, Parser)]
struct Args {
    /// Observations for the throughput runs.
    #[arg(long, default_value_t = 200_000)]
    messages: u64,
    /// Seconds of the latency run at 2 000 observations/s.
    #[arg(long, default_value_t = 10.0)]
    latency_s: f64,
    /// Seconds of the 20-robot memory run.
    #[arg(long, default_value_t = 30.0)]
    memory_s: f64,
    /// Match length of the replay run, seconds.
    #[arg(long, default_value_t = 600.0)]
    replay_match_s: f64,
    #[arg(long)]
    json: Option<PathBuf>,
    #[arg(long)]
    doc: Option<PathBuf>,
    /// Internal: run only a server (the memory run's child process).
    #[arg(long, hide = true)]
    child_serve: Option<String>,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?;
    if let Some(endpoint) = &args.child_serve {
        return rt.block_on(child_server(endpoint));
    }
    rt.block_on(run(args))
}

/// A plain server, as `fusion-server serve` runs it (the memory run measures this process).
async fn child_server(endpoint: &str) -> Result<()> {
    let cfg = ServeConfig {
        net: NetConfig::listening(endpoint),
        ..ServeConfig::default()
    };
    let live = fusion_server::shared(&cfg, Arc::new(SystemClock), None)?;
    let http = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let stop = async {
        let mut line = String::new();
        // The parent closes stdin to stop the child.
        let _ = tokio::task::spawn_blocking(move || std::io::stdin().read_line(&mut line)).await;
    };
    fusion_server::serve(cfg, live, http, stop).await
}

fn observation(robot: usize, seq: u64, stamp: Stamp, t_s: f64) -> Observation {
    // A ball rolling slowly around a circle, seen with 2 cm noise-free reports.
    let a = 0.3 * t_s;
    Observation {
        version: proto::VERSION,
        robot_id: format!("bench{robot}"),
        seq,
        camera: if seq.is_multiple_of(2) {
            Camera::Left
        } else {
            Camera::Right
        },
        stamp,
        position_m: [0.8 * a.cos(), 0.6 * a.sin()],
        covariance_m2: [4e-4, 0.0, 0.0, 4e-4],
        confidence: 0.9,
        robot_pose: Pose2 {
            x_m: -1.5 + 0.1 * robot as f64,
            y_m: 0.0,
            theta_rad: 0.0,
        },
        pixel: None,
    }
}

async fn start_server(
    cfg: ServeConfig,
) -> Result<(
    fusion_server::Shared,
    tokio::sync::watch::Sender<bool>,
    tokio::task::JoinHandle<Result<()>>,
)> {
    let live = fusion_server::shared(&cfg, Arc::new(SystemClock), None)?;
    let http = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let (tx, mut rx) = tokio::sync::watch::channel(false);
    let task = tokio::spawn(fusion_server::serve(cfg, live.clone(), http, async move {
        let _ = rx.wait_for(|s| *s).await;
    }));
    Ok((live, tx, task))
}

async fn connect(endpoint: &str) -> Result<zenoh::Session> {
    let s = NetConfig::connecting(endpoint).open().await?;
    // Wait for the link, so the first messages are not published into the void.
    let deadline = Instant::now() + Duration::from_secs(10);
    while s.info().peers_zid().await.next().is_none() {
        anyhow::ensure!(Instant::now() < deadline, "no peer at {endpoint}");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    Ok(s)
}

async fn publisher(s: &zenoh::Session, key: String) -> Result<zenoh::pubsub::Publisher<'static>> {
    s.declare_publisher(key)
        .congestion_control(zenoh::qos::CongestionControl::Block)
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))
}

/// Raw Zenoh: N payloads of an observation's size from one session to another.
async fn raw_zenoh(n: u64) -> Result<Throughput> {
    let endpoint = format!("tcp/127.0.0.1:{}", free_loopback_port()?);
    let rx = NetConfig::listening(&endpoint).open().await?;
    let got = Arc::new(AtomicU64::new(0));
    let g = got.clone();
    let _sub = rx
        .declare_subscriber("bench/raw")
        .callback(move |s| {
            let bytes = s.payload().to_bytes();
            if !bytes.is_empty() {
                g.fetch_add(1, Ordering::Relaxed);
            }
        })
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let tx = connect(&endpoint).await?;
    let publ = publisher(&tx, "bench/raw".into()).await?;
    tokio::time::sleep(Duration::from_millis(200)).await;
    let payload = proto::encode(&observation(0, 0, SystemClock.now(), 0.0));
    let t0 = Instant::now();
    for _ in 0..n {
        publ.put(payload.clone())
            .await
            .map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    let deadline = Instant::now() + Duration::from_secs(60);
    while got.load(Ordering::Relaxed) < n && Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
    let secs = t0.elapsed().as_secs_f64();
    let received = got.load(Ordering::Relaxed);
    let _ = tx.close().await;
    let _ = rx.close().await;
    Ok(Throughput {
        sent: n,
        received,
        secs,
        payload_bytes: payload.len(),
        reordered: 0,
        clock_corrected: 0,
    })
}

/// The most observations a second the throughput run sends from one robot: far above the
/// per-robot limit, which is raised to it for that run (and said so in the table).
pub const THROUGHPUT_LIMIT_HZ: f64 = 1e9;

/// The throughput run's sender keeps at most this many observations ahead of the server
/// (a quarter of its intake queue): it measures how fast the server takes them in
/// without loss, not how fast a queue overflows.
pub const THROUGHPUT_WINDOW: u64 = 4096;

/// N observations from 10 robots through Zenoh into a server, as fast as it takes them in
/// (the sender waits while [`THROUGHPUT_WINDOW`] are not yet handled).
async fn server_throughput(n: u64) -> Result<Throughput> {
    let endpoint = format!("tcp/127.0.0.1:{}", free_loopback_port()?);
    let mut cfg = ServeConfig {
        net: NetConfig::listening(&endpoint),
        ..ServeConfig::default()
    };
    // The server's own speed, not its limiter's: ten robots each far above 200/s.
    cfg.engine.admission.rate_limit_hz = THROUGHPUT_LIMIT_HZ;
    cfg.engine.admission.rate_burst = THROUGHPUT_LIMIT_HZ;
    let (live, stop, task) = start_server(cfg).await?;
    let tx = connect(&endpoint).await?;
    let robots = 10;
    let mut pubs = Vec::new();
    for r in 0..robots {
        pubs.push(publisher(&tx, format!("rf/robots/bench{r}/obs")).await?);
    }
    tokio::time::sleep(Duration::from_millis(200)).await;
    let handled = |live: &fusion_server::Shared| {
        live.with_engine(|e| {
            e.counters().observations_accepted + e.counters().rejected.values().sum::<u64>()
        })
    };
    // Each observation is stamped when it is published, captured 50 ms earlier.
    let start = SystemClock.now();
    let t0 = Instant::now();
    let deadline = t0 + Duration::from_secs(120);
    for k in 0..n {
        if k % 256 == 0 {
            while k.saturating_sub(handled(&live)) > THROUGHPUT_WINDOW {
                anyhow::ensure!(Instant::now() < deadline, "the server stopped taking in");
                tokio::time::sleep(Duration::from_micros(200)).await;
            }
        }
        let stamp = SystemClock.now().offset_secs(-0.05);
        let o = observation(
            (k % robots) as usize,
            k / robots,
            stamp,
            stamp.secs_since(start),
        );
        pubs[(k % robots) as usize]
            .put(proto::encode(&o))
            .await
            .map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    while handled(&live) < n && Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
    let secs = t0.elapsed().as_secs_f64();
    let (accepted, reordered, clock_corrected) = live.with_engine(|e| {
        (
            e.counters().observations_accepted,
            e.fusion().counters().reordered,
            e.counters().observations_clock_corrected,
        )
    });
    let rejected = live.with_engine(|e| e.counters().rejected.clone());
    if !rejected.is_empty() {
        eprintln!("      rejected: {rejected:?}");
    }
    let _ = tx.close().await;
    let _ = stop.send(true);
    task.await??;
    Ok(Throughput {
        sent: n,
        received: accepted,
        secs,
        payload_bytes: 0,
        reordered,
        clock_corrected,
    })
}

/// Publishes `rate_hz` messages a second for `seconds`; `make(k)` gives the k-th message's
/// publisher (an index into `pubs`), payload and tag. Returns, per message, the instant
/// just before its `put` and its tag.
async fn paced(
    pubs: &[zenoh::pubsub::Publisher<'_>],
    rate_hz: f64,
    seconds: f64,
    mut make: impl FnMut(u64) -> (usize, Vec<u8>, u64),
) -> Result<Vec<(Instant, u64)>> {
    let n = (rate_hz * seconds) as u64;
    let period = Duration::from_secs_f64(1.0 / rate_hz);
    let mut sent = Vec::with_capacity(n as usize);
    let t0 = Instant::now();
    for k in 0..n {
        let due = t0 + period * k as u32;
        if due > Instant::now() {
            tokio::time::sleep_until(due.into()).await;
        }
        let (index, payload, tag) = make(k);
        let at = Instant::now();
        pubs[index]
            .put(payload)
            .await
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        sent.push((at, tag));
    }
    Ok(sent)
}

/// Robots sharing the latency run's observations, each well under the per-robot limit.
pub const LATENCY_ROBOTS: usize = 20;

/// Publish → state latency at `rate_hz` for `seconds` from [`LATENCY_ROBOTS`] robots in
/// turn (each under the per-robot limit), states published on update.
async fn latency(rate_hz: f64, seconds: f64) -> Result<Latency> {
    let endpoint = format!("tcp/127.0.0.1:{}", free_loopback_port()?);
    let cfg = ServeConfig {
        net: NetConfig::listening(&endpoint),
        publish_on_update: true,
        ..ServeConfig::default()
    };
    let (live, stop, task) = start_server(cfg).await?;
    let tx = connect(&endpoint).await?;
    // Arrival times are taken in the subscriber's callback, on Zenoh's receiving thread.
    let (seen_tx, seen_rx) = std::sync::mpsc::channel::<(Instant, u64)>();
    let _states = tx
        .declare_subscriber("rf/ball/state")
        .callback(move |s| {
            let at = Instant::now();
            if let Ok(b) = proto::decode::<proto::BallState>(&s.payload().to_bytes())
                && let Some(seen) = b.last_seen
            {
                let _ = seen_tx.send((at, seen.0));
            }
        })
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut pubs = Vec::new();
    for r in 0..LATENCY_ROBOTS {
        pubs.push(
            tx.declare_publisher(format!("rf/robots/bench{r}/obs"))
                .express(true)
                .await
                .map_err(|e| anyhow::anyhow!("{e}"))?,
        );
    }
    tokio::time::sleep(Duration::from_millis(300)).await;
    let start = SystemClock.now();
    let sent = paced(&pubs, rate_hz, seconds, |k| {
        let stamp = SystemClock.now();
        let robot = k as usize % LATENCY_ROBOTS;
        let o = observation(
            robot,
            k / LATENCY_ROBOTS as u64,
            stamp,
            stamp.secs_since(start),
        );
        (robot, proto::encode(&o), stamp.0)
    })
    .await?;
    let refused = live.with_engine(|e| e.counters().rejected.clone());
    if !refused.is_empty() {
        eprintln!("      refused in the latency run: {refused:?}");
    }
    tokio::time::sleep(Duration::from_millis(300)).await;
    let _ = tx.close().await;
    let _ = stop.send(true);
    task.await??;
    let inside = live.stats.latency();
    eprintln!(
        "      inside the server (arrival to publication): p50 ≤ {:?} s, p99 ≤ {:?} s",
        inside.quantile_bound(0.5),
        inside.quantile_bound(0.99)
    );
    let mut seen: VecDeque<(Instant, u64)> = seen_rx.try_iter().collect();
    // Each observation's latency: the first state at or after its publication whose newest
    // included capture is at least its own.
    let mut lat_s = Vec::with_capacity(sent.len());
    for (at, stamp) in &sent {
        // The state carries capture times through f64 seconds: allow a microsecond.
        while seen.front().is_some_and(|(_, s)| *s + 1_000 < *stamp) {
            seen.pop_front();
        }
        if let Some((t, _)) = seen.front() {
            lat_s.push(t.saturating_duration_since(*at).as_secs_f64());
        }
    }
    Ok(Latency::of(rate_hz, sent.len(), lat_s))
}

/// The per-robot limit at work: one robot floods as fast as it can for `seconds` while
/// another sends 100 observations a second; how many of each the server accepts.
async fn limiter(seconds: f64) -> Result<Limiter> {
    let endpoint = format!("tcp/127.0.0.1:{}", free_loopback_port()?);
    let cfg = ServeConfig {
        net: NetConfig::listening(&endpoint),
        ..ServeConfig::default()
    };
    let limit_hz = cfg.engine.admission.rate_limit_hz;
    let burst = cfg.engine.admission.rate_burst;
    let (live, stop, task) = start_server(cfg).await?;
    let tx = connect(&endpoint).await?;
    let flood = publisher(&tx, "rf/robots/bench0/obs".into()).await?;
    let honest = publisher(&tx, "rf/robots/bench1/obs".into()).await?;
    tokio::time::sleep(Duration::from_millis(200)).await;
    let start = SystemClock.now();
    let t0 = Instant::now();
    let honest_task = async {
        let n = (100.0 * seconds) as u64;
        for k in 0..n {
            let stamp = SystemClock.now();
            let o = observation(1, k, stamp, stamp.secs_since(start));
            honest
                .put(proto::encode(&o))
                .await
                .map_err(|e| anyhow::anyhow!("{e}"))?;
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
        Ok::<u64, anyhow::Error>(n)
    };
    let flood_task = async {
        let mut k = 0;
        while t0.elapsed().as_secs_f64() < seconds {
            let stamp = SystemClock.now();
            let o = observation(0, k, stamp, stamp.secs_since(start));
            flood
                .put(proto::encode(&o))
                .await
                .map_err(|e| anyhow::anyhow!("{e}"))?;
            k += 1;
            if k % 64 == 0 {
                tokio::task::yield_now().await;
            }
        }
        Ok::<u64, anyhow::Error>(k)
    };
    let (honest_sent, flood_sent) = tokio::try_join!(honest_task, flood_task)?;
    let secs = t0.elapsed().as_secs_f64();
    let handled = |live: &fusion_server::Shared| {
        live.with_engine(|e| {
            e.robots(SystemClock.now())
                .iter()
                .map(|r| r.observations_accepted + r.observations_rejected)
                .sum::<u64>()
        })
    };
    let deadline = Instant::now() + Duration::from_secs(30);
    while handled(&live) < honest_sent + flood_sent && Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let (flood_accepted, honest_accepted, rate_limited) = live.with_engine(|e| {
        let robots = e.robots(SystemClock.now());
        let accepted = |id: &str| {
            robots
                .iter()
                .find(|r| r.robot_id == id)
                .map_or(0, |r| r.observations_accepted)
        };
        let limited = e
            .counters()
            .rejected
            .get(&("observation", "rate_limited"))
            .copied()
            .unwrap_or(0);
        (accepted("bench0"), accepted("bench1"), limited)
    });
    let _ = tx.close().await;
    let _ = stop.send(true);
    task.await??;
    Ok(Limiter {
        seconds: secs,
        limit_hz,
        burst,
        flood_sent,
        flood_accepted,
        rate_limited,
        honest_sent,
        honest_accepted,
    })
}

/// The same pattern without a server: a message to another session, whose callback
/// publishes a reply at once (express both ways), at `rate_hz` for `seconds`.
async fn raw_echo_latency(rate_hz: f64, seconds: f64) -> Result<Latency> {
    use zenoh::Wait;
    let endpoint = format!("tcp/127.0.0.1:{}", free_loopback_port()?);
    let echo = NetConfig::listening(&endpoint).open().await?;
    let pong = echo
        .declare_publisher("bench/pong")
        .express(true)
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let _ping_sub = echo
        .declare_subscriber("bench/ping")
        .callback(move |s| {
            let _ = pong.put(s.payload().to_bytes().to_vec()).wait();
        })
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let tx = connect(&endpoint).await?;
    let (seen_tx, seen_rx) = std::sync::mpsc::channel::<(Instant, u64)>();
    let _pong_sub = tx
        .declare_subscriber("bench/pong")
        .callback(move |s| {
            let at = Instant::now();
            let b = s.payload().to_bytes();
            if let Some(seq) = b.get(..8).and_then(|x| <[u8; 8]>::try_from(x).ok()) {
                let _ = seen_tx.send((at, u64::from_le_bytes(seq)));
            }
        })
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let ping = tx
        .declare_publisher("bench/ping")
        .express(true)
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let sent = paced(std::slice::from_ref(&ping), rate_hz, seconds, |k| {
        let mut payload = k.to_le_bytes().to_vec();
        payload.resize(230, b' ');
        (0, payload, k)
    })
    .await?;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let got: std::collections::HashMap<u64, Instant> =
        seen_rx.try_iter().map(|(t, k)| (k, t)).collect();
    let lat_s = sent
        .iter()
        .filter_map(|(at, k)| {
            got.get(k)
                .map(|t| t.saturating_duration_since(*at).as_secs_f64())
        })
        .collect();
    let _ = tx.close().await;
    let _ = echo.close().await;
    Ok(Latency::of(rate_hz, sent.len(), lat_s))
}

/// A simulated match written as a log, then replayed offline, timed.
fn replay_speed(match_s: f64) -> Result<ReplaySpeed> {
    use fusion_server::RecorderSink;
    use fusion_server::{ReplayOptions, replay};
    use tools::sim_log::{run_of_log, score_run, truth_schemas, write_simulated};
    let run = tools::sim_robots::simulate(
        "match",
        0,
        sim::SimConfig::default().start,
        Some(match_s),
        None,
    )?;
    let dir = std::env::temp_dir().join(format!("rf-bench-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let log_of = |prefix: &str, keep: &dyn Fn(&str) -> bool| -> Result<Vec<PathBuf>> {
        let mut cfg = fusion_server::RecorderConfig::new(&dir);
        cfg.file_prefix = prefix.into();
        let mut sink = Filter {
            inner: RecorderSink::with_schemas(cfg, run.start, truth_schemas())?,
            keep,
        };
        write_simulated(&run, &proto::KeySpace::default(), &mut sink)?;
        Ok(sink.inner.finish()?.files)
    };
    // What the robots sent (a log of observations), and the same with ground truth.
    let obs_files = log_of("observations", &|schema| schema == "Observation")?;
    let truth_files = log_of("truth", &|_| true)?;
    let opts = ReplayOptions::default();

    let t0 = Instant::now();
    let log = fusion_server::read_logs(&obs_files)?;
    let read_s = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let fused = replay(&log.messages, &opts, &mut (), &mut |_, _| {})?;
    let fuse_s = t0.elapsed().as_secs_f64();
    // With --out: the re-fused log written too.
    let mut out_cfg = fusion_server::RecorderConfig::new(&dir);
    out_cfg.file_prefix = "replayed".into();
    let t0 = Instant::now();
    let mut out = RecorderSink::create(out_cfg, run.start)?;
    replay(&log.messages, &opts, &mut out, &mut |_, _| {})?;
    out.finish()?;
    let write_s = t0.elapsed().as_secs_f64();
    // The ground-truth log: every message, the run rebuilt and scored.
    let t0 = Instant::now();
    let truth_log = fusion_server::read_logs(&truth_files)?;
    replay(&truth_log.messages, &opts, &mut (), &mut |_, _| {})?;
    let scored = run_of_log(&truth_log.messages)?.map(|run| score_run(&run, &opts.engine.fusion));
    let full_s = t0.elapsed().as_secs_f64();
    let _ = std::fs::remove_dir_all(&dir);
    anyhow::ensure!(scored.is_some(), "the simulated log carries ground truth");
    Ok(ReplaySpeed {
        match_s: run.duration_s,
        robots: run.observer_ids().len(),
        observations: fused.observations,
        states: fused.states_written,
        read_s,
        fuse_s,
        write_s,
        full_s,
        messages: truth_log.messages.len(),
    })
}

/// Passes on only the messages whose schema `keep` accepts.
struct Filter<'a, S> {
    inner: S,
    keep: &'a dyn Fn(&str) -> bool,
}

impl<S: fusion_server::ReplaySink> fusion_server::ReplaySink for Filter<'_, S> {
    fn write(&mut self, topic: &str, schema: &str, log_time: Stamp, payload: &[u8]) {
        if (self.keep)(schema) {
            self.inner.write(topic, schema, log_time, payload);
        }
    }
}

/// A server process fed by `robots` simulated robots for `seconds`.
async fn memory(robots: usize, seconds: f64) -> Result<Memory> {
    let endpoint = format!("tcp/127.0.0.1:{}", free_loopback_port()?);
    let exe = std::env::current_exe()?;
    let mut child = std::process::Command::new(exe)
        .args(["--child-serve", &endpoint])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .context("starting the server process")?;
    let pid = child.id();
    tokio::time::sleep(Duration::from_millis(500)).await;
    let rss_idle_kb = proc_status_kb(pid, "VmRSS:").unwrap_or(0);
    let cfg = tools::sim_robots::SimRobotsConfig {
        scenario: "match".into(),
        seed: 5,
        robots: Vec::new(),
        duration_s: Some(seconds),
        team_size: Some(robots),
        start: SystemClock.now().offset_secs(1.0),
        repeat: false,
        status_rate_hz: 5.0,
        footprints: true,
        prefix: proto::DEFAULT_PREFIX.into(),
        net: NetConfig::connecting(&endpoint),
        keys: None,
    };
    let cpu0 = proc_cpu_s(pid).unwrap_or(0.0);
    let (_stop_tx, stop_rx) = tokio::sync::watch::channel(false);
    let t0 = Instant::now();
    let published = tools::sim_robots::run(cfg, stop_rx).await?;
    let wall_s = t0.elapsed().as_secs_f64();
    let cpu_s = proc_cpu_s(pid).unwrap_or(0.0) - cpu0;
    let rss_kb = proc_status_kb(pid, "VmRSS:").unwrap_or(0);
    let hwm_kb = proc_status_kb(pid, "VmHWM:").unwrap_or(0);
    drop(child.stdin.take());
    let _ = child.wait();
    Ok(Memory {
        robots,
        seconds,
        published,
        rss_idle_kb,
        rss_kb,
        hwm_kb,
        cpu_share: cpu_s / wall_s.max(1e-9),
    })
}

async fn run(args: Args) -> Result<()> {
    // The bar shows the stage running; each `inc` counts the one before as done.
    let stages = tools::progress::Progress::new(5, "benchmark stages");
    stages.message(format!(
        "raw Zenoh loopback throughput ({} messages)",
        args.messages
    ));
    let raw = raw_zenoh(args.messages).await?;
    stages.inc(format!(
        "server throughput ({} observations)",
        args.messages
    ));
    let server = server_throughput(args.messages).await?;
    stages.inc(format!(
        "latency at 2000 observations/s for {} s",
        args.latency_s
    ));
    let raw_latency = raw_echo_latency(2000.0, args.latency_s).await?;
    let lat = latency(2000.0, args.latency_s).await?;
    let limited = limiter(2.0).await?;
    stages.inc(format!(
        "offline replay of a {} s match",
        args.replay_match_s
    ));
    let replay = replay_speed(args.replay_match_s)?;
    stages.inc(format!("memory with 20 robots for {} s", args.memory_s));
    let mem = memory(20, args.memory_s).await?;
    stages.inc("done");
    stages.finish();
    let report = Report {
        raw,
        server,
        raw_latency,
        latency: lat,
        limiter: limited,
        throughput_limit_hz: THROUGHPUT_LIMIT_HZ,
        throughput_window: THROUGHPUT_WINDOW,
        latency_robots: LATENCY_ROBOTS,
        replay,
        memory: mem,
        cores: std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(0),
    };
    let table = report.markdown();
    println!("{table}");
    if let Some(p) = &args.json {
        eval::report::write_json(p, &report)?;
    }
    if let Some(p) = &args.doc {
        eval::report::rewrite_section(p, &table)?;
    }
    Ok(())
}
