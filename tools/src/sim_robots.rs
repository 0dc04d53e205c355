//! Simulated MiRos on the network: each robot of a simulated match gets its own Zenoh
//! session and liveliness token and publishes its observations when they would arrive,
//! and its status at a few hertz, in real time. The demo runs them as tasks; tests run them
//! as separate processes.
//!
//! A status carries each camera's floor footprint around the robot's pose of its time,
//! from the simulator's own camera geometry ([`sim::camera_footprints`]): the floor where
//! the modelled detector reports the ball (its field of view and range, less what other
//! robots' bodies hide) at every frame from the previous status to the next. The server
//! takes a ball that a footprint holds and the frames did not report as evidence that it is
//! not there, so a footprint claims no more than the detector covers while it is in use.

use anyhow::{Context, Result};
use fusion_server::{Clock, SystemClock};
use proto::net::NetConfig;
use proto::{HeadJoints, KeySpace, Observation, Pitch, Pose2, RobotStatus, Stamp};
use sim::{RobotTrack, SimConfig, SimRun};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::watch;

#[derive(Debug, Clone)]
pub struct SimRobotsConfig {
    pub scenario: String,
    pub seed: u64,
    /// Robots to publish for; empty = every observer of the scenario.
    pub robots: Vec<String>,
    /// Overrides the scenario's length.
    pub duration_s: Option<f64>,
    /// Robots in a `match` (default: five).
    pub team_size: Option<usize>,
    /// Run t = 0 at this stamp (shared by every process of one match).
    pub start: Stamp,
    /// After the match, play the next seed, and so on, until stopped.
    pub repeat: bool,
    pub status_rate_hz: f64,
    /// Statuses carry each camera's floor footprint (off: the server gets no negative
    /// information from these robots).
    pub footprints: bool,
    pub prefix: String,
    pub net: NetConfig,
    /// A secured network's keys folder (`fusion-server keys`): robot `{id}` joins with
    /// the certificate in `robot-{id}`.
    pub keys: Option<std::path::PathBuf>,
}

/// Runs the match at `start` on the MiRo pitch (deterministic: every process computes the
/// same one).
pub fn simulate(
    scenario: &str,
    seed: u64,
    start: Stamp,
    duration_s: Option<f64>,
    team_size: Option<usize>,
) -> Result<SimRun> {
    simulate_on(
        &Pitch::default(),
        scenario,
        seed,
        start,
        duration_s,
        team_size,
    )
}

/// [`simulate`] on `pitch`: its size, walls and ball. (The simulated walls bounce with the
/// run's own drawn restitution; the pitch's is the nominal value recorded with the run.)
pub fn simulate_on(
    pitch: &Pitch,
    scenario: &str,
    seed: u64,
    start: Stamp,
    duration_s: Option<f64>,
    team_size: Option<usize>,
) -> Result<SimRun> {
    let cfg = SimConfig {
        start,
        duration_s,
        team_size,
        pitch: pitch.clone(),
        ..SimConfig::default()
    };
    sim::run_scenario(scenario, seed, &cfg).with_context(|| format!("simulating {scenario}"))
}

/// The robots a config publishes for, in the run's order.
pub fn chosen_robots(run: &SimRun, wanted: &[String]) -> Result<Vec<String>> {
    let observers: Vec<String> = run
        .robots
        .iter()
        .filter(|r| r.observer)
        .map(|r| r.id.clone())
        .collect();
    if wanted.is_empty() {
        return Ok(observers);
    }
    for w in wanted {
        anyhow::ensure!(
            observers.contains(w),
            "scenario {} has no observing robot {w:?} (it has {})",
            run.scenario,
            observers.join(", ")
        );
    }
    Ok(wanted.to_vec())
}

/// The frames a second a robot's cameras captured in the run (the slow-robot scenarios'
/// fewer than the model's rate).
fn frame_rate_hz(run: &SimRun, track: &RobotTrack) -> f64 {
    if run.duration_s > 0.0 && track.frames > 0 {
        track.frames as f64 / run.duration_s
    } else {
        sim::model::FRAME_RATE_HZ
    }
}

/// Instants a footprint is checked at, a second: twice the cameras' frame rate.
const FOOTPRINT_SAMPLES_HZ: f64 = 2.0 * sim::model::FRAME_RATE_HZ;

/// Each camera's footprint of `track`'s robot at match time `t_s`: the floor where its
/// camera reports the ball at every instant within `window_s` either side (the frames a
/// status speaks for since the previous one, and those it is used for until the next),
/// among the other robots' bodies.
fn footprints_of(
    run: &SimRun,
    track: &RobotTrack,
    t_s: f64,
    window_s: f64,
) -> Vec<proto::CameraFootprint> {
    let n = (window_s.max(0.0) * FOOTPRINT_SAMPLES_HZ).ceil() as usize;
    // The status's own instant first: the polygon is drawn around its camera.
    let times: Vec<f64> = std::iter::once(t_s)
        .chain((1..=n).flat_map(|k| {
            let dt_s = window_s * k as f64 / n as f64;
            [t_s - dt_s, t_s + dt_s]
        }))
        .collect();
    let others: Vec<Vec<Pose2>> = times
        .iter()
        .map(|t| {
            run.robots
                .iter()
                .filter(|r| r.id != track.id)
                .map(|r| r.pose_at(*t))
                .collect()
        })
        .collect();
    let moments: Vec<sim::Moment<'_>> = times
        .iter()
        .zip(&others)
        .map(|(t, others)| sim::Moment {
            pose: track.pose_at(*t),
            others,
        })
        .collect();
    sim::camera_footprints(&moments)
}

/// How the simulated robots report their status.
#[derive(Debug, Clone, Copy, PartialEq)]
struct StatusPlan {
    /// Time between statuses.
    interval_s: f64,
    /// Statuses carry each camera's footprint.
    footprints: bool,
}

impl StatusPlan {
    fn new(status_rate_hz: f64, footprints: bool) -> Self {
        StatusPlan {
            interval_s: 1.0 / status_rate_hz.max(0.1),
            footprints,
        }
    }

    /// `track`'s status at match time `t_s`, stamped `stamp`: its true pose, its frame
    /// rate and, with footprints, each camera's footprint over an interval either side
    /// ([`footprints_of`]). None when its perception stalled since the previous status's
    /// time: like an agent whose statuses follow its frames, a stalled robot says nothing,
    /// and no status speaks for frames that were never processed. (No camera counters:
    /// [`ModelledPerception`] adds them.)
    fn status(
        &self,
        run: &SimRun,
        track: &RobotTrack,
        t_s: f64,
        stamp: Stamp,
    ) -> Option<RobotStatus> {
        if track.stalled_within(t_s - self.interval_s, t_s) {
            return None;
        }
        let footprints = if self.footprints {
            footprints_of(run, track, t_s, self.interval_s)
        } else {
            Vec::new()
        };
        Some(RobotStatus {
            version: proto::VERSION,
            robot_id: track.id.clone(),
            stamp,
            pose: track.pose_at(t_s),
            pose_covariance: [4e-4, 0.0, 0.0, 0.0, 4e-4, 0.0, 0.0, 0.0, 1e-3],
            head: HeadJoints::default(),
            fps: frame_rate_hz(run, track),
            timings: Vec::new(),
            footprints,
            cameras: Vec::new(),
        })
    }
}

/// Wall-clock instant of a stamp, on the system clock.
fn instant_of(at: Stamp, now_stamp: Stamp, now: Instant) -> Instant {
    let dt_s = at.secs_since(now_stamp);
    if dt_s <= 0.0 {
        now
    } else {
        now + Duration::from_secs_f64(dt_s)
    }
}

/// One robot's share of a run: its observations by arrival, and the run (its own track
/// and the other robots' bodies, for its statuses).
#[derive(Debug)]
struct RobotPlan {
    id: String,
    deliveries: Vec<(Stamp, Observation)>,
    run: Arc<SimRun>,
    statuses: StatusPlan,
}

impl RobotPlan {
    /// The status at match time `t_s`, stamped `stamp` (none while stalled).
    fn status(&self, t_s: f64, stamp: Stamp) -> Option<RobotStatus> {
        let track = self.run.robot(&self.id)?;
        self.statuses.status(&self.run, track, t_s, stamp)
    }
}

fn plans(run: &Arc<SimRun>, ids: &[String], statuses: StatusPlan) -> Vec<RobotPlan> {
    ids.iter()
        .filter(|id| run.robot(id).is_some())
        .map(|id| {
            let deliveries = run
                .deliveries
                .iter()
                .filter(|d| &d.obs.robot_id == id)
                .map(|d| (d.arrival, d.obs.clone()))
                .collect();
            RobotPlan {
                id: id.clone(),
                deliveries,
                run: run.clone(),
                statuses,
            }
        })
        .collect()
}

/// Publishes one robot's plan in real time until it ends or `stop` turns true.
async fn play_robot(
    session: &zenoh::Session,
    keys: &KeySpace,
    plan: RobotPlan,
    run_start: Stamp,
    stop: &mut watch::Receiver<bool>,
) -> Result<u64> {
    let obs_pub = session
        .declare_publisher(keys.robot_obs(&plan.id)?)
        .express(true)
        .await
        .map_err(|e| anyhow::anyhow!("obs publisher: {e}"))?;
    let status_pub = session
        .declare_publisher(keys.robot_status(&plan.id)?)
        .await
        .map_err(|e| anyhow::anyhow!("status publisher: {e}"))?;
    let clock = SystemClock;
    let status_dt_s = plan.statuses.interval_s;
    let end = plan.deliveries.last().map(|(a, _)| *a).unwrap_or(run_start);
    let mut next_status = run_start;
    let mut sent = 0;
    let mut perception = ModelledPerception::default();
    let fps = plan
        .run
        .robot(&plan.id)
        .map_or(sim::model::FRAME_RATE_HZ, |t| frame_rate_hz(&plan.run, t));
    let mut obs = plan.deliveries.iter().peekable();
    loop {
        let next_obs = obs.peek().map(|(a, _)| *a);
        let (due, is_status) = match next_obs {
            Some(a) if a <= next_status => (a, false),
            _ if next_status <= end => (next_status, true),
            _ => break,
        };
        let now_stamp = clock.now();
        let wake = instant_of(due, now_stamp, Instant::now());
        tokio::select! {
            _ = tokio::time::sleep_until(wake.into()) => {}
            _ = stop.wait_for(|s| *s) => break,
        }
        if is_status {
            let t_s = due.secs_since(run_start);
            if let Some(mut s) = plan.status(t_s, due) {
                s.cameras = perception.report(t_s, fps);
                let _ = status_pub.put(proto::encode(&s)).await;
            }
            next_status = next_status.offset_secs(status_dt_s);
        } else if let Some((_, o)) = obs.next()
            && obs_pub.put(proto::encode(o)).await.is_ok()
        {
            perception.published(o.camera);
            sent += 1;
        }
    }
    Ok(sent)
}

/// A simulated robot's camera counters: its cameras run at the model's frame rate, and each
/// modelled sighting it publishes is one candidate and one ball (the model has no
/// candidates it rejects, and no pipeline whose time it could report: `detector_ms` is 0).
#[derive(Debug, Clone, Default, PartialEq)]
struct ModelledPerception {
    balls: [u64; 2],
    /// At the last report: its time, and the balls then.
    last: Option<(f64, [u64; 2])>,
}

impl ModelledPerception {
    fn published(&mut self, camera: proto::Camera) {
        self.balls[usize::from(camera == proto::Camera::Right)] += 1;
    }

    /// Both cameras' counters at match time `t_s`, the rates over the time since the last
    /// report.
    fn report(&mut self, t_s: f64, frame_rate_hz: f64) -> Vec<proto::CameraPerception> {
        let (t0, before) = self.last.unwrap_or((0.0, [0, 0]));
        let dt_s = (t_s - t0).max(1e-6);
        self.last = Some((t_s, self.balls));
        [proto::Camera::Left, proto::Camera::Right]
            .into_iter()
            .enumerate()
            .map(|(i, camera)| {
                let new_balls = (self.balls[i] - before[i]) as f64;
                let frames = dt_s * frame_rate_hz;
                proto::CameraPerception {
                    camera,
                    frames: (t_s.max(0.0) * frame_rate_hz) as u64,
                    candidates: self.balls[i],
                    balls: self.balls[i],
                    rejections: Default::default(),
                    frames_per_s: frame_rate_hz,
                    candidates_per_frame: new_balls / frames.max(1.0),
                    balls_per_s: new_balls / dt_s,
                    detector_ms: 0.0,
                }
            })
            .collect()
    }
}

/// Runs the simulated robots until the match ends (or every match, with `repeat`, until
/// `stop`). Returns the observations published.
pub async fn run(cfg: SimRobotsConfig, stop: watch::Receiver<bool>) -> Result<u64> {
    run_on(cfg, Pitch::default(), stop).await
}

/// [`run`] with the matches simulated on `pitch`.
pub async fn run_on(
    cfg: SimRobotsConfig,
    pitch: Pitch,
    stop: watch::Receiver<bool>,
) -> Result<u64> {
    let keys = KeySpace::new(&cfg.prefix)?;
    let mut start = cfg.start;
    let mut seed = cfg.seed;
    let mut total = 0;
    // One session and liveliness token per robot, kept across matches.
    let first = simulate_on(
        &pitch,
        &cfg.scenario,
        seed,
        start,
        cfg.duration_s,
        cfg.team_size,
    )?;
    let ids = chosen_robots(&first, &cfg.robots)?;
    let mut sessions = Vec::new();
    for id in &ids {
        let mut net = cfg.net.clone();
        if let Some(keys) = &cfg.keys {
            net.tls = Some(proto::net::TlsFiles::in_dir(
                &keys.join(format!("robot-{id}")),
            ));
        }
        let session = net
            .open()
            .await
            .with_context(|| format!("opening robot {id}'s Zenoh session"))?;
        let token = session
            .liveliness()
            .declare_token(keys.robot_liveliness(id)?)
            .await
            .map_err(|e| anyhow::anyhow!("robot token: {e}"))?;
        sessions.push((session, token));
    }
    let mut run = Arc::new(first);
    loop {
        let mut tasks = tokio::task::JoinSet::new();
        let statuses = StatusPlan::new(cfg.status_rate_hz, cfg.footprints);
        for (plan, (session, _)) in plans(&run, &ids, statuses).into_iter().zip(&sessions) {
            let (session, keys, mut stop) = (session.clone(), keys.clone(), stop.clone());
            tasks.spawn(async move { play_robot(&session, &keys, plan, start, &mut stop).await });
        }
        // Simulate the next match while this one plays.
        let next_start = start.offset_secs(run.duration_s);
        let next = if cfg.repeat {
            let (scenario, d, n) = (cfg.scenario.clone(), cfg.duration_s, cfg.team_size);
            let pitch = pitch.clone();
            Some(tokio::task::spawn_blocking(move || {
                simulate_on(&pitch, &scenario, seed + 1, next_start, d, n)
            }))
        } else {
            None
        };
        while let Some(r) = tasks.join_next().await {
            total += r.context("robot task")??;
        }
        if *stop.borrow() {
            break;
        }
        match next {
            Some(n) => {
                run = Arc::new(n.await.context("simulation task")??);
                start = next_start;
                seed += 1;
                tracing::info!("next match: {} seed {seed}", cfg.scenario);
            }
            None => break,
        }
    }
    for (session, token) in sessions {
        let _ = token.undeclare().await;
        let _ = session.close().await;
    }
    Ok(total)
}

#[cfg(test)]
#[path = "sim_robots_tests.rs"]
mod tests;
