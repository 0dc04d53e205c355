//! The robots' camera views under a real match: a `fusion-server` process recording a
//! match log, `sim_agent` processes (the robot agent's own loop on a simulated match's
//! rendered cameras) publishing their observations and, at `--view-hz`, their camera views,
//! and a client of the page's view stream. Measured: the server's CPU time, each view's
//! delay from its capture to the page's stream, the views received, and the match log's
//! size per minute.

use crate::load::ServerProcess;
use crate::load_report::proc_cpu_s;
use anyhow::{Context, Result};
use futures_util::StreamExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use tokio_tungstenite::tungstenite::Message;

/// One run's settings.
#[derive(Debug, Clone)]
pub struct ViewsConfig {
    pub robots: usize,
    /// Views per second per camera of each agent (0: none).
    pub view_hz: f64,
    /// Camera frames per second of each agent, both cameras together.
    pub camera_hz: f64,
    /// Measured seconds (after the agents have warmed up).
    pub seconds: f64,
    pub seed: u64,
}

/// What one run measured.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ViewsReport {
    pub robots: usize,
    pub view_hz: f64,
    pub seconds: f64,
    /// The server process's CPU time over the measured seconds, as a share of one core.
    pub server_cpu_share: f64,
    /// Views the stream client received, and their delay from capture (s): median, p95.
    pub views: usize,
    pub delay_median_s: Option<f64>,
    pub delay_p95_s: Option<f64>,
    /// The match log's bytes per minute over the whole run.
    pub log_mb_per_min: f64,
}

/// Agents of one match, killed when dropped.
struct Agents(Vec<Child>);

impl Drop for Agents {
    fn drop(&mut self) {
        for c in &mut self.0 {
            c.kill().ok();
            c.wait().ok();
        }
    }
}

fn spawn_agents(agent_bin: &Path, endpoint: &str, cfg: &ViewsConfig) -> Result<Agents> {
    let start = fusion_server::SystemClock;
    let start_ns = fusion_server::Clock::now(&start)
        .offset_secs(1.0)
        .0
        .to_string();
    let mut children = Vec::new();
    for r in 1..=cfg.robots {
        let child = Command::new(agent_bin)
            .args(["--robot-id", &format!("miro{r}"), "--repeat"])
            .args(["--scenario", "match", "--seed", &cfg.seed.to_string()])
            .args(["--team-size", &cfg.robots.to_string()])
            .args(["--start-ns", &start_ns])
            .args(["--camera-hz", &cfg.camera_hz.to_string()])
            .args(["--view-hz", &cfg.view_hz.to_string()])
            .args(["--connect", endpoint])
            .args(["--parent-pid", &std::process::id().to_string()])
            .env("RUST_LOG", "warn,zenoh=error")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .spawn()
            .with_context(|| format!("starting {}", agent_bin.display()))?;
        children.push(child);
    }
    Ok(Agents(children))
}

fn quantile(v: &[f64], q: f64) -> Option<f64> {
    proto::stats::quantile(v, q)
}

fn dir_bytes(dir: &Path) -> u64 {
    std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| e.metadata().ok())
        .map(|m| m.len())
        .sum()
}

/// One run: the server (recording into `log_dir`), the agents, the stream client.
pub async fn run(
    server_bin: &Path,
    agent_bin: &Path,
    log_dir: &Path,
    cfg: &ViewsConfig,
    warmup_s: f64,
) -> Result<ViewsReport> {
    std::fs::create_dir_all(log_dir)?;
    let extra = vec!["--record".to_string(), log_dir.display().to_string()];
    let mut server = ServerProcess::start_args(server_bin, None, None, &extra)?;
    let began = Instant::now();
    let agents = spawn_agents(agent_bin, &server.endpoint, cfg)?;
    let url = format!("ws://{}/api/views/stream", server.http_addr);
    let (mut ws, _) = tokio_tungstenite::connect_async(url)
        .await
        .context("the view stream")?;
    // The stream is read (and what comes dropped) while the agents warm up: views left
    // unread in the socket would arrive late at once when the measuring starts.
    let warm = Instant::now() + Duration::from_secs_f64(warmup_s);
    while let Ok(next) =
        tokio::time::timeout(warm.saturating_duration_since(Instant::now()), ws.next()).await
    {
        anyhow::ensure!(matches!(next, Some(Ok(_))), "the view stream closed");
    }
    let pid = server.pid();
    let cpu0 = proc_cpu_s(pid).unwrap_or(0.0);
    let t0 = Instant::now();
    let mut delays = Vec::new();
    let until = t0 + Duration::from_secs_f64(cfg.seconds);
    loop {
        let left = until.saturating_duration_since(Instant::now());
        if left.is_zero() {
            break;
        }
        match tokio::time::timeout(left, ws.next()).await {
            Ok(Some(Ok(Message::Text(t)))) => {
                let now = fusion_server::Clock::now(&fusion_server::SystemClock);
                if let Ok(v) = serde_json::from_str::<proto::CameraView>(&t) {
                    delays.push(now.secs_since(v.stamp));
                }
            }
            Ok(Some(Ok(_))) => {}
            Ok(_) => anyhow::bail!("the view stream closed"),
            Err(_) => break,
        }
    }
    let measured_s = t0.elapsed().as_secs_f64();
    let cpu1 = proc_cpu_s(pid).unwrap_or(cpu0);
    drop(agents);
    server.stop(Duration::from_secs(20))?;
    let whole_min = began.elapsed().as_secs_f64() / 60.0;
    Ok(ViewsReport {
        robots: cfg.robots,
        view_hz: cfg.view_hz,
        seconds: measured_s,
        server_cpu_share: (cpu1 - cpu0) / measured_s,
        views: delays.len(),
        delay_median_s: quantile(&delays, 0.5),
        delay_p95_s: quantile(&delays, 0.95),
        log_mb_per_min: dir_bytes(log_dir) as f64 / 1e6 / whole_min,
    })
}

/// The markdown table of runs.
pub fn table(runs: &[ViewsReport]) -> String {
    let ms = |s: Option<f64>| s.map_or("–".to_string(), |s| format!("{:.0}", s * 1e3));
    let mut out = String::from(
        "| robots | views a second per camera | server CPU (share of one core) | views received | capture → page, median / p95 ms | match log, MB a minute |\n|---|---|---|---|---|---|\n",
    );
    for r in runs {
        out.push_str(&format!(
            "| {} | {} | {:.1} % | {} | {} / {} | {:.2} |\n",
            r.robots,
            r.view_hz,
            r.server_cpu_share * 100.0,
            r.views,
            ms(r.delay_median_s),
            ms(r.delay_p95_s),
            r.log_mb_per_min
        ));
    }
    out
}

/// A fresh folder for a run's log.
pub fn log_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rf-bench-views-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}
