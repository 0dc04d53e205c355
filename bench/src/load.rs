//! The load test: a `fusion-server` process fed by many simulated robots at once. Each
//! robot has its own Zenoh session and liveliness token and publishes every camera's
//! observation of a ball rolling round an ellipse at a fixed rate, each captured
//! `capture_delay_s` before it is sent. The server's `/metrics` says what became of them;
//! `/proc` says what the process cost.

use crate::load_report::{LoadReport, Metrics, proc_cpu_s, proc_status_kb};
use anyhow::{Context, Result};
use fusion_server::{Clock, SystemClock};
use proto::net::{NetConfig, free_loopback_port};
use proto::{Camera, KeySpace, Observation, Pose2, Stamp};
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::time::{Duration, Instant};
use tools::progress::Progress;

#[derive(Debug, Clone)]
pub struct LoadConfig {
    pub robots: usize,
    /// Cameras per robot, each publishing at `hz`.
    pub cameras: usize,
    pub hz: f64,
    pub seconds: f64,
    /// Robots sharing one Zenoh session (1: a session each, as on the real robots).
    pub robots_per_session: usize,
    /// Capture to send, seconds.
    pub capture_delay_s: f64,
    /// Longest wait after the last send for the server to account for everything.
    pub drain_s: f64,
    /// Robots wait for room in Zenoh's send queue instead of dropping (the agent drops,
    /// Zenoh's default): with it, a loss can only be the server's.
    pub block: bool,
    /// A secured network: TLS with mutual authentication, every robot with its own
    /// certificate, the server with the roster's access-control list.
    pub tls: bool,
}

impl Default for LoadConfig {
    fn default() -> Self {
        LoadConfig {
            robots: 100,
            cameras: 2,
            hz: 30.0,
            seconds: 60.0,
            robots_per_session: 1,
            capture_delay_s: 0.04,
            drain_s: 5.0,
            block: false,
            tls: false,
        }
    }
}

/// The ball's path: an ellipse of 1.2 m by 0.8 m half-axes round the centre spot, about
/// 1 m/s.
pub fn ball_at(t_s: f64) -> [f64; 2] {
    let a = 0.9 * t_s;
    [1.2 * a.cos(), 0.8 * a.sin()]
}

/// Robot `index` of `n`: spread over the pitch on a grid, facing the centre.
pub fn pose_of(index: usize, n: usize) -> Pose2 {
    let cols = (n as f64).sqrt().ceil().max(1.0) as usize;
    let rows = n.div_ceil(cols);
    let (c, r) = (index % cols, index / cols);
    let x_m = -1.7 + 3.4 * (c as f64 + 0.5) / cols as f64;
    let y_m = -1.1 + 2.2 * (r as f64 + 0.5) / rows.max(1) as f64;
    Pose2 {
        x_m,
        y_m,
        theta_rad: (-y_m).atan2(-x_m),
    }
}

/// One robot's observation number `seq`, from camera `camera`, captured at `stamp`.
pub fn observation(
    robot_id: &str,
    pose: Pose2,
    seq: u64,
    camera: usize,
    stamp: Stamp,
    t_s: f64,
) -> Observation {
    Observation {
        version: proto::VERSION,
        robot_id: robot_id.to_owned(),
        seq,
        camera: if camera.is_multiple_of(2) {
            Camera::Left
        } else {
            Camera::Right
        },
        stamp,
        position_m: ball_at(t_s),
        covariance_m2: [4e-4, 0.0, 0.0, 4e-4],
        confidence: 0.9,
        robot_pose: pose,
        pixel: None,
    }
}

/// A `fusion-server serve` child process, killed when dropped.
#[derive(Debug)]
pub struct ServerProcess {
    child: Child,
    pub endpoint: String,
    pub http_addr: String,
}

impl ServerProcess {
    /// Starts `bin serve` listening on a free loopback Zenoh port (scouting stays off, its
    /// default) and an OS-chosen HTTP port; waits for the address it prints. With `keys`,
    /// the network is secured: TLS from the keys' server folder, and their roster.
    pub fn start(bin: &Path, keys: Option<&Keys>) -> Result<ServerProcess> {
        ServerProcess::start_with(bin, keys, None)
    }

    /// As [`ServerProcess::start`], under `ulimit -n open_files` when given (through
    /// `/bin/sh`, which then becomes the server: the same process).
    pub fn start_with(
        bin: &Path,
        keys: Option<&Keys>,
        open_files: Option<u32>,
    ) -> Result<ServerProcess> {
        ServerProcess::start_args(bin, keys, open_files, &[])
    }

    /// As [`ServerProcess::start_with`], with more `serve` flags.
    pub fn start_args(
        bin: &Path,
        keys: Option<&Keys>,
        open_files: Option<u32>,
        extra: &[String],
    ) -> Result<ServerProcess> {
        let port = free_loopback_port()?;
        let (endpoint, security) = match keys {
            Some(k) => (
                format!("tls/127.0.0.1:{port}"),
                vec![
                    "--tls".to_string(),
                    k.server_dir().display().to_string(),
                    "--roster".into(),
                    k.robots.join(","),
                ],
            ),
            None => (format!("tcp/127.0.0.1:{port}"), vec!["--open".to_string()]),
        };
        let mut command = match open_files {
            Some(n) => {
                let mut c = Command::new("/bin/sh");
                c.args(["-c", &format!("ulimit -n {n} && exec \"$0\" \"$@\"")])
                    .arg(bin);
                c
            }
            None => Command::new(bin),
        };
        let mut child = command
            .arg("serve")
            .args(&security)
            .args(["--listen", &endpoint, "--http", "127.0.0.1:0"])
            .args(extra)
            .env("RUST_LOG", "warn,zenoh=error")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .with_context(|| format!("starting {}", bin.display()))?;
        let out = child.stdout.take().context("the server's stdout")?;
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                if let Some(a) = line.strip_prefix("http://") {
                    // Only the first send matters; later lines are drained and dropped.
                    tx.send(a.trim_end_matches('/').to_string()).ok();
                }
            }
        });
        let mut server = ServerProcess {
            child,
            endpoint,
            http_addr: String::new(),
        };
        server.http_addr = rx
            .recv_timeout(Duration::from_secs(30))
            .context("the server printed no HTTP address")?;
        Ok(server)
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    pub fn metrics(&self) -> Result<Metrics> {
        Ok(Metrics::parse(&http_get(&self.http_addr, "/metrics")?))
    }

    /// SIGTERM, then SIGKILL if it has not exited within `timeout`.
    pub fn stop(&mut self, timeout: Duration) -> Result<()> {
        Command::new("kill")
            .args(["-TERM", &self.pid().to_string()])
            .status()
            .context("kill -TERM")?;
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            if self.child.try_wait()?.is_some() {
                return Ok(());
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        self.child.kill()?;
        self.child.wait()?;
        anyhow::bail!("the server ignored SIGTERM for {timeout:?}")
    }
}

impl Drop for ServerProcess {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            self.child.kill().ok();
            self.child.wait().ok();
        }
    }
}

/// GET `path` from `addr`: the body of a 200 answer.
pub fn http_get(addr: &str, path: &str) -> Result<String> {
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .timeout_global(Some(Duration::from_secs(10)))
        .build()
        .into();
    let mut answer = agent
        .get(format!("http://{addr}{path}"))
        .call()
        .with_context(|| format!("GET {path} from {addr}"))?;
    Ok(answer.body_mut().read_to_string()?)
}

/// The certificates of a secured load test, in a folder removed when dropped.
#[derive(Debug)]
pub struct Keys {
    dir: std::path::PathBuf,
    pub robots: Vec<String>,
}

impl Keys {
    /// An authority, the server's folder and one folder per robot id.
    pub fn issue(robots: Vec<String>) -> Result<Keys> {
        use fusion_server::{Authority, Validity};
        use fusion_server::{robot_common_name, server_common_name};
        let dir = std::env::temp_dir().join(format!("rf-load-keys-{}", std::process::id()));
        let validity = Validity::starting(jiff::Timestamp::now(), 2)?;
        let ca = Authority::new("load test authority", validity)?;
        let write = |sub: &Path, node: &fusion_server::Issued| {
            fusion_server::write_node_dir(sub, &ca.issued.cert_pem, node)
        };
        let keys = Keys { dir, robots };
        let hosts = ["127.0.0.1".to_string()];
        write(
            &keys.server_dir(),
            &ca.issue(&server_common_name("load"), &hosts, validity)?,
        )?;
        for id in &keys.robots {
            write(
                &keys.robot_dir(id),
                &ca.issue(&robot_common_name(id), &[], validity)?,
            )?;
        }
        Ok(keys)
    }

    pub fn server_dir(&self) -> std::path::PathBuf {
        self.dir.join("server")
    }

    pub fn robot_dir(&self, id: &str) -> std::path::PathBuf {
        self.dir.join(format!("robot-{id}"))
    }
}

impl Drop for Keys {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The load test's robot ids.
fn robot_ids(n: usize) -> Vec<String> {
    (0..n).map(|r| format!("load{r:03}")).collect()
}

/// Opens a session to `endpoint` (with `tls`, that robot's certificate) and waits for its
/// link, so nothing is published into the void.
pub async fn connect(endpoint: &str, tls: Option<&Path>) -> Result<zenoh::Session> {
    let s = NetConfig {
        tls: tls.map(proto::net::TlsFiles::in_dir),
        ..NetConfig::connecting(endpoint)
    }
    .open()
    .await?;
    let deadline = Instant::now() + Duration::from_secs(10);
    while s.info().peers_zid().await.next().is_none() {
        anyhow::ensure!(Instant::now() < deadline, "no peer at {endpoint}");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    Ok(s)
}

/// What the robots did.
#[derive(Debug, Default)]
pub struct Sent {
    pub ok: AtomicU64,
    pub errors: AtomicU64,
}

/// One robot publishing its cameras' observations from `t0` for the configured time; its
/// robots are phase-shifted by `phase` so that the fleet does not send in lockstep.
async fn play_robot(
    publ: zenoh::pubsub::Publisher<'static>,
    id: String,
    pose: Pose2,
    cfg: LoadConfig,
    (t0, start, phase): (Instant, Stamp, Duration),
    sent: Arc<Sent>,
) {
    let per_s = cfg.hz * cfg.cameras as f64;
    let n = (per_s * cfg.seconds).round() as u64;
    for k in 0..n {
        let due = t0 + phase + Duration::from_secs_f64(k as f64 / per_s);
        tokio::time::sleep_until(due.into()).await;
        let stamp = SystemClock.now().offset_secs(-cfg.capture_delay_s);
        let camera = (k % cfg.cameras as u64) as usize;
        let o = observation(&id, pose, k, camera, stamp, stamp.secs_since(start));
        match publ.put(proto::encode(&o)).await {
            Ok(()) => sent.ok.fetch_add(1, Relaxed),
            Err(_) => sent.errors.fetch_add(1, Relaxed),
        };
    }
}

/// The robots' sessions, tokens and publishers, ready to publish.
struct Fleet {
    sessions: Vec<zenoh::Session>,
    tokens: Vec<zenoh::liveliness::LivelinessToken>,
    robots: Vec<(String, Pose2, zenoh::pubsub::Publisher<'static>)>,
}

async fn fleet(endpoint: &str, cfg: &LoadConfig, certs: Option<&Keys>) -> Result<Fleet> {
    let keys = KeySpace::default();
    let mut f = Fleet {
        sessions: Vec::new(),
        tokens: Vec::new(),
        robots: Vec::new(),
    };
    for (r, id) in robot_ids(cfg.robots).into_iter().enumerate() {
        if r % cfg.robots_per_session.max(1) == 0 {
            let tls = certs.map(|k| k.robot_dir(&id));
            f.sessions.push(connect(endpoint, tls.as_deref()).await?);
        }
        let session = f.sessions.last().context("a session")?;
        let token = session
            .liveliness()
            .declare_token(keys.robot_liveliness(&id)?)
            .await
            .map_err(|e| anyhow::anyhow!("liveliness token: {e}"))?;
        // As the robot agent publishes its observations.
        let publ = session
            .declare_publisher(keys.robot_obs(&id)?)
            .express(true)
            .congestion_control(if cfg.block {
                zenoh::qos::CongestionControl::Block
            } else {
                zenoh::qos::CongestionControl::Drop
            })
            .await
            .map_err(|e| anyhow::anyhow!("observation publisher: {e}"))?;
        f.tokens.push(token);
        f.robots.push((id, pose_of(r, cfg.robots), publ));
    }
    Ok(f)
}

/// Runs the load against a server process started from `server_bin`; `progress` shows
/// the seconds. The server is stopped before this returns.
pub async fn run(server_bin: &Path, cfg: &LoadConfig, progress: &Progress) -> Result<LoadReport> {
    anyhow::ensure!(
        !cfg.tls || cfg.robots_per_session <= 1,
        "with TLS every robot has its own certificate, so its own session"
    );
    let keys = if cfg.tls {
        progress.message(format!("issuing {} certificates", cfg.robots + 1));
        Some(Keys::issue(robot_ids(cfg.robots))?)
    } else {
        None
    };
    let mut server = ServerProcess::start(server_bin, keys.as_ref())?;
    let pid = server.pid();
    progress.message(format!("{} robots connecting", cfg.robots));
    let Fleet {
        sessions,
        tokens,
        robots,
    } = fleet(&server.endpoint, cfg, keys.as_ref()).await?;
    // Let the server see the tokens and settle before measuring its idle size.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let rss_idle_kb = proc_status_kb(pid, "VmRSS:").unwrap_or(0);
    let cpu0 = proc_cpu_s(pid).unwrap_or(0.0);
    let before = server.metrics()?;

    let sent = Arc::new(Sent::default());
    let t0 = Instant::now() + Duration::from_millis(100);
    let start = SystemClock.now();
    let period_s = 1.0 / (cfg.hz * cfg.cameras as f64);
    let mut tasks = tokio::task::JoinSet::new();
    let n = robots.len();
    for (r, (id, pose, publ)) in robots.into_iter().enumerate() {
        let phase = Duration::from_secs_f64(period_s * r as f64 / n as f64);
        tasks.spawn(play_robot(
            publ,
            id,
            pose,
            cfg.clone(),
            (t0, start, phase),
            sent.clone(),
        ));
    }

    // Once a second: the server's resident set and how far it has got.
    let mut rss_samples_kb = Vec::new();
    let mut states_each_s = Vec::new();
    let mut last_states = before.states_published;
    let mut intake_queued_max = 0;
    let mut mid = None;
    let mut tick =
        tokio::time::interval_at((t0 + Duration::from_secs(1)).into(), Duration::from_secs(1));
    let whole_s = cfg.seconds.ceil() as usize;
    while !tasks.is_empty() {
        tokio::select! {
            _ = tick.tick() => {
                let rss = proc_status_kb(pid, "VmRSS:").unwrap_or(0);
                rss_samples_kb.push(rss);
                let m = server.metrics()?;
                if rss_samples_kb.len() <= whole_s {
                    states_each_s.push(m.states_published.saturating_sub(last_states));
                }
                last_states = m.states_published;
                intake_queued_max = intake_queued_max.max(m.intake_queued);
                if rss_samples_kb.len() == whole_s / 2 {
                    mid = Some((rss, m.clone()));
                }
                progress.inc(format!(
                    "sent {}, accepted {}, rejected {}, server {:.1} MB",
                    sent.ok.load(Relaxed),
                    m.observations_accepted - before.observations_accepted,
                    m.rejected_total() - before.rejected_total(),
                    rss as f64 / 1024.0
                ));
            }
            done = tasks.join_next() => {
                if let Some(Err(e)) = done {
                    anyhow::bail!("a robot's task failed: {e}");
                }
            }
        }
    }
    let publish_s = t0.elapsed().as_secs_f64();
    let sent_ok = sent.ok.load(Relaxed);

    // Recovery: until the server has worked off every backlog: nothing more arriving
    // (Zenoh's own buffers emptied) and nothing waiting in its intake queue.
    progress.message("waiting for the server to work off its backlog");
    let stopped = Instant::now();
    let (mut last_received, mut changed_at) = (u64::MAX, stopped);
    let recovery_s = loop {
        let m = server.metrics()?;
        let now = Instant::now();
        if m.received != last_received {
            (last_received, changed_at) = (m.received, now);
        }
        if m.intake_queued == 0 && now.duration_since(changed_at) >= Duration::from_millis(50) {
            break Some(changed_at.duration_since(stopped).as_secs_f64());
        }
        if stopped.elapsed() > Duration::from_secs(10) {
            break None;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    };

    // Drain: until the server has accounted for everything sent, or `drain_s` passes.
    progress.message("draining");
    let deadline = Instant::now() + Duration::from_secs_f64(cfg.drain_s);
    let mut end = server.metrics()?;
    while end.received - before.received < sent_ok && Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(50)).await;
        end = server.metrics()?;
    }
    // A little longer, so the states that include the last observations are published.
    tokio::time::sleep(Duration::from_millis(200)).await;
    end = server.metrics()?;
    let rss_end_kb = proc_status_kb(pid, "VmRSS:").unwrap_or(0);
    let rss_peak_kb = proc_status_kb(pid, "VmHWM:").unwrap_or(0);
    let server_cpu_s = proc_cpu_s(pid).unwrap_or(0.0) - cpu0;
    drop(tokens);
    for s in sessions {
        s.close().await.ok();
    }
    if let Err(e) = server.stop(Duration::from_secs(10)) {
        // The figures are in; a slow exit is reported, not fatal.
        eprintln!("warning: {e:#}");
    }

    let (rss_mid_kb, mid_metrics) = mid.unwrap_or((rss_end_kb, before.clone()));
    let latency = end.latency_since(&before);
    let second_half = end.latency_since(&mid_metrics);
    let mut rejected = end.rejected.clone();
    for (k, n) in &before.rejected {
        if let Some(v) = rejected.get_mut(k) {
            *v -= n;
        }
    }
    rejected.retain(|_, n| *n > 0);
    let states = end.states_published - before.states_published;
    Ok(LoadReport {
        robots: cfg.robots,
        cameras: cfg.cameras,
        hz: cfg.hz,
        seconds: cfg.seconds,
        sessions: cfg.robots.div_ceil(cfg.robots_per_session.max(1)),
        tls: cfg.tls,
        publish_s,
        sent: sent_ok,
        put_errors: sent.errors.load(Relaxed),
        received: end.received - before.received,
        accepted: end.observations_accepted - before.observations_accepted,
        rejected,
        states_published: states,
        states_per_s: if states_each_s.is_empty() {
            states as f64 / publish_s.max(1e-9)
        } else {
            states_each_s.iter().sum::<u64>() as f64 / states_each_s.len() as f64
        },
        states_each_s,
        intake_queued_max,
        recovery_s,
        robots_tracked_mid: mid_metrics.robots_tracked,
        robots_tracked_end: end.robots_tracked,
        latency_p50_s: latency.latency_bound(0.5),
        latency_p99_s: latency.latency_bound(0.99),
        latency_mean_s: if latency.latency_count > 0 {
            Some(latency.latency_sum_s / latency.latency_count as f64)
        } else {
            None
        },
        latency_p99_second_half_s: second_half.latency_bound(0.99),
        latency_samples: latency.latency_count,
        rss_idle_kb,
        rss_peak_kb,
        rss_end_kb,
        rss_mid_kb,
        rss_growth_second_half_kb: rss_end_kb as i64 - rss_mid_kb as i64,
        rss_samples_kb,
        server_cpu_s,
        server_cpu_share: server_cpu_s / publish_s.max(1e-9),
        cores: std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(0),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::{Pitch, Validate, ValidationContext};

    #[test]
    fn every_robot_stands_on_the_pitch_and_sends_valid_observations() {
        let now = SystemClock.now();
        let ctx = ValidationContext::new(Pitch::default(), now);
        for n in [1, 10, 100] {
            for r in 0..n {
                let pose = pose_of(r, n);
                for t_s in [0.0, 1.0, 2.5, 7.0] {
                    let o = observation("load000", pose, 3, r, now, t_s);
                    assert!(
                        o.validate(&ctx).is_ok(),
                        "robot {r} of {n} at {t_s} s: {o:?}"
                    );
                }
            }
        }
    }
}
