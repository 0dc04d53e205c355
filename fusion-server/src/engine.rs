//! The server's state machine around the fusion core: decodes and validates what arrives,
//! feeds the core, keeps the roster of robots, answers queries and counts everything.
//! Like the core it never reads a clock and does no I/O: the shell passes time and bytes in.

use crate::estimator::{Fusion, FusionConfig, Ingest, ViewReport};
use crate::query::{BallQuery, QueryError, QueryReply};
use proto::{
    BallState, DecodeError, Intercept, Observation, Pitch, Pose2, RobotStatus, Stamp, VERSION,
    Validate, ValidationContext, ValidationError,
};
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};
use thiserror::Error;

mod admission;
mod clock_offset;
mod recent;
pub use admission::{AdmissionConfig, RateBuckets, SWEEP_EVERY_S, TokenBucket};
pub use clock_offset::{ClockCheck, ClockJump, OffsetWindow, common_floor_s};
pub use recent::{RecentObs, RecentObservations};

/// Why an inbound message was not used.
#[derive(Debug, Error)]
pub enum Rejection {
    #[error("{0}")]
    Decode(#[from] DecodeError),
    #[error("{0}")]
    Invalid(#[from] ValidationError),
    #[error("robot {0:?} is not on the roster")]
    UnknownRobot(String),
    #[error("payload robot_id {payload:?} does not match the key's robot {key:?}")]
    KeyMismatch { key: String, payload: String },
    #[error("the fusion core refused it: {0}")]
    Core(&'static str),
    #[error("robot {0:?} would be more than {MAX_ROBOTS} robots")]
    TooManyRobots(String),
    #[error("the key's robot chunk {0:?} is not a valid robot id")]
    BadKey(String),
    #[error("payload of {bytes} bytes exceeds the limit of {limit} bytes")]
    TooLarge { bytes: usize, limit: usize },
    #[error("robot {0:?} sends faster than its rate limit")]
    RateLimited(String),
}

/// Distinct robots the server keeps track of (without a roster, a flood of made-up ids
/// must not grow its state; robots gone quiet are forgotten, see [`AdmissionConfig`]).
pub const MAX_ROBOTS: usize = 256;

impl Rejection {
    /// A short stable label for counting rejections by reason.
    pub fn reason(&self) -> &'static str {
        match self {
            Rejection::Decode(DecodeError::Json(_)) => "not_json",
            Rejection::Decode(DecodeError::Version { .. }) => "version",
            Rejection::Decode(DecodeError::MissingVersion) => "no_version",
            Rejection::Invalid(e) => e.reason(),
            Rejection::UnknownRobot(_) => "unknown_robot",
            Rejection::KeyMismatch { .. } => "key_mismatch",
            Rejection::Core(r) => r,
            Rejection::TooManyRobots(_) => "too_many_robots",
            Rejection::BadKey(_) => "key_robot_id",
            Rejection::TooLarge { .. } => "too_large",
            Rejection::RateLimited(_) => "rate_limited",
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct EngineConfig {
    pub fusion: FusionConfig,
    /// When set, only these robots are accepted.
    pub roster: Option<BTreeSet<String>>,
    /// Robot top speed for intercepts when the query does not give one.
    pub robot_speed_mps: f64,
    /// Largest accepted |capture stamp − receiver clock|.
    pub max_clock_skew_s: f64,
    /// Largest accepted distance of a reported position outside the pitch.
    pub max_outside_m: f64,
    /// Largest observation payload, checked before it is parsed.
    pub max_observation_bytes: usize,
    /// Largest status payload, checked before it is parsed.
    pub max_status_bytes: usize,
    /// Per-robot rate limit and the expiry of robots gone quiet.
    pub admission: AdmissionConfig,
    /// How the robots' clock offsets are estimated and judged.
    pub clock: ClockCheck,
}

/// Default cap on an observation's payload (the protocol's example is under 300 bytes).
pub const DEFAULT_MAX_OBSERVATION_BYTES: usize = 4096;
/// Default cap on a status payload: the largest status [`proto::Validate`] accepts, every
/// number at full precision, fits (tested).
pub const DEFAULT_MAX_STATUS_BYTES: usize = 24 * 1024;

impl Default for EngineConfig {
    fn default() -> Self {
        EngineConfig {
            fusion: FusionConfig::default(),
            roster: None,
            robot_speed_mps: 0.4,
            max_clock_skew_s: 10.0,
            max_outside_m: 1.0,
            max_observation_bytes: DEFAULT_MAX_OBSERVATION_BYTES,
            max_status_bytes: DEFAULT_MAX_STATUS_BYTES,
            admission: AdmissionConfig::default(),
            clock: ClockCheck::default(),
        }
    }
}

/// Messages per second, exponentially averaged over about `RATE_TAU_S`.
const RATE_TAU_S: f64 = 2.0;

#[derive(Debug, Clone, Default)]
struct Rate {
    per_s: f64,
    at: Option<Stamp>,
}

impl Rate {
    fn decayed(&self, now: Stamp) -> f64 {
        match self.at {
            Some(at) => self.per_s * (-now.secs_since(at).max(0.0) / RATE_TAU_S).exp(),
            None => 0.0,
        }
    }
    fn hit(&mut self, now: Stamp) {
        self.per_s = self.decayed(now) + 1.0 / RATE_TAU_S;
        self.at = Some(now.max(self.at.unwrap_or(now)));
    }
}

#[derive(Debug, Clone)]
struct RobotEntry {
    /// Last accepted message or liveliness change (receiver clock): what expiry looks at.
    last_heard: Stamp,
    bucket: TokenBucket,
    online: bool,
    /// When `online` last changed (receiver clock).
    since: Option<Stamp>,
    status: Option<RobotStatus>,
    status_received: Option<Stamp>,
    last_obs_received: Option<Stamp>,
    accepted: u64,
    /// Its statuses accepted (with `accepted`, how established it is).
    statuses: u64,
    rejected: u64,
    rate: Rate,
    /// Arrival minus capture of its accepted observations, exponentially averaged.
    latency_s: Option<f64>,
    /// The same lags, the recent ones, for the clock offset.
    lags: OffsetWindow,
    /// Seconds added to its stamps before they reach the core (its clock's correction).
    correction_s: f64,
    /// Camera footprints of its statuses the core refused.
    footprints_refused: u64,
}

impl RobotEntry {
    fn new(now: Stamp, burst: f64) -> Self {
        RobotEntry {
            last_heard: now,
            bucket: TokenBucket::full(burst),
            online: false,
            since: None,
            status: None,
            status_received: None,
            last_obs_received: None,
            accepted: 0,
            statuses: 0,
            rejected: 0,
            rate: Rate::default(),
            latency_s: None,
            lags: OffsetWindow::default(),
            correction_s: 0.0,
            footprints_refused: 0,
        }
    }
}

/// Weight of the newest observation in a robot's average latency.
const LATENCY_WEIGHT: f64 = 0.1;

/// One robot as the server sees it, for the HTTP API and the live stream.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RobotView {
    pub robot_id: String,
    pub online: bool,
    /// Seconds since `online` last changed.
    pub since_s: Option<f64>,
    /// Seconds since its last observation arrived.
    pub last_obs_age_s: Option<f64>,
    pub obs_rate_hz: f64,
    pub observations_accepted: u64,
    pub observations_rejected: u64,
    /// Factor the fusion applies to the covariances this robot reports (1 = honest).
    pub covariance_scale: Option<f64>,
    /// Share of its observations that the other robots did not confirm.
    pub outlier_rate: Option<f64>,
    /// Seconds from capture to arrival of its accepted observations, averaged over about
    /// the last ten (`null` until one arrives).
    pub latency_s: Option<f64>,
    /// Estimated server clock minus robot clock, seconds: the smallest arrival − capture
    /// of its last [`OFFSET_WINDOW`] accepted observations less the latency floor
    /// (`null` until one arrives). Positive: the robot's clock is behind.
    pub clock_offset_s: Option<f64>,
    /// True when `clock_offset_s` exceeds the warning threshold either way.
    pub clock_suspect: bool,
    /// Seconds the server adds to its stamps before fusing them: its clock offset once
    /// estimated from enough observations and beyond the dead band, bounded; 0 otherwise.
    pub clock_correction_s: f64,
    /// Jumps of its clock caught (the offset estimate restarted).
    pub clock_jumps: u64,
    /// Camera footprints of its statuses refused (not a polygon, the whole pitch, ...).
    pub footprints_refused: u64,
    /// Pose from its latest status, else from its latest observation.
    pub pose: Option<Pose2>,
    pub status: Option<RobotStatus>,
}

/// Counts of what arrived and what became of it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EngineCounters {
    pub observations_accepted: u64,
    pub statuses_accepted: u64,
    /// Accepted observations whose stamps were corrected for their robot's clock.
    pub observations_clock_corrected: u64,
    /// Robot clock jumps caught.
    pub clock_jumps: u64,
    /// Robots not yet established forgotten to make room for a newcomer, the table being
    /// full (see [`AdmissionConfig::established_messages`]).
    pub robots_evicted: u64,
    /// Notable events not kept because [`MAX_EVENTS`] were waiting.
    pub events_dropped: u64,
    /// (message kind, reason) → count.
    pub rejected: BTreeMap<(&'static str, &'static str), u64>,
}

/// The fusion server's pure state.
#[derive(Debug, Clone)]
pub struct Engine {
    cfg: EngineConfig,
    fusion: Fusion,
    robots: BTreeMap<String, RobotEntry>,
    counters: EngineCounters,
    recent: RecentObservations,
    /// When the table was last swept for robots gone quiet.
    swept: Option<Stamp>,
    /// The robots' common least latency and when it was worked out (receiver clock).
    clock_floor: Option<(Stamp, f64)>,
    /// Notable events for the shell to log, oldest first.
    events: Vec<EngineEvent>,
}

/// Something an operator should read in the log; the shell drains them
/// ([`Engine::take_events`]).
#[derive(Debug, Clone, PartialEq)]
pub enum EngineEvent {
    /// A robot's stamps are now corrected by `correction_s` (0: no longer corrected).
    ClockCorrected {
        robot: String,
        correction_s: f64,
        offset_s: f64,
    },
    /// A robot's clock jumped; its offset estimate restarted.
    ClockJumped { robot: String, jump: ClockJump },
    /// A camera footprint of a robot's status was refused; `count` refused so far (told
    /// at the 1st, 2nd, 4th, 8th, ... so a robot that always sends bad ones is not a flood).
    FootprintRefused {
        robot: String,
        reason: String,
        count: u64,
    },
}

impl std::fmt::Display for EngineEvent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            EngineEvent::ClockCorrected {
                robot,
                correction_s,
                offset_s,
            } if *correction_s == 0.0 => write!(
                f,
                "robot {robot:?}: stamps no longer corrected (clock offset {:+.1} ms)",
                offset_s * 1e3
            ),
            EngineEvent::ClockCorrected {
                robot,
                correction_s,
                offset_s,
            } => write!(
                f,
                "robot {robot:?}: stamps corrected by {:+.1} ms (estimated clock offset {:+.1} ms)",
                correction_s * 1e3,
                offset_s * 1e3
            ),
            EngineEvent::ClockJumped { robot, jump } => {
                let way = match jump {
                    ClockJump::Ahead => "ahead",
                    ClockJump::Back => "back",
                };
                write!(
                    f,
                    "robot {robot:?}: clock jumped {way}; its offset is estimated afresh"
                )
            }
            EngineEvent::FootprintRefused {
                robot,
                reason,
                count,
            } => write!(
                f,
                "robot {robot:?}: camera footprint refused ({reason}); {count} so far, its frames tell nothing of what they do not see"
            ),
        }
    }
}

/// Events kept for the shell at most; past this they are counted and dropped.
pub const MAX_EVENTS: usize = 256;
/// The robots' common latency floor is worked out again at most this often.
const FLOOR_EVERY_S: f64 = 0.25;

impl Engine {
    pub fn new(cfg: EngineConfig) -> Self {
        Engine {
            fusion: Fusion::new(cfg.fusion.clone()),
            cfg,
            robots: BTreeMap::new(),
            counters: EngineCounters::default(),
            recent: RecentObservations::default(),
            swept: None,
            clock_floor: None,
            events: Vec::new(),
        }
    }

    /// The notable events since the last call, oldest first.
    pub fn take_events(&mut self) -> Vec<EngineEvent> {
        std::mem::take(&mut self.events)
    }

    fn event(&mut self, e: EngineEvent) {
        if self.events.len() >= MAX_EVENTS {
            self.counters.events_dropped += 1;
        } else {
            self.events.push(e);
        }
    }

    /// The robots' common least latency (see [`clock_offset`]), as of `now`.
    fn clock_floor_s(&mut self, now: Stamp) -> f64 {
        if let Some((at, floor)) = self.clock_floor
            && now.secs_since(at).abs() < FLOOR_EVERY_S
        {
            return floor;
        }
        let floor = self.fresh_clock_floor_s();
        self.clock_floor = Some((now, floor));
        floor
    }

    fn fresh_clock_floor_s(&self) -> f64 {
        let check = &self.cfg.clock;
        common_floor_s(
            self.robots
                .values()
                .filter(|r| r.lags.confident(check))
                .filter_map(|r| r.lags.min_lag_s()),
            check,
        )
    }

    /// Takes the lag of an observation of `robot_id` (validated, so it has an entry) and
    /// returns the correction for its stamp.
    fn clock_correction(&mut self, robot_id: &str, lag_s: f64, received: Stamp) -> f64 {
        let check = self.cfg.clock.clone();
        let entry = self.entry_at(robot_id, received);
        let was_confident = entry.lags.confident(&check);
        let jump = entry.lags.push(received, lag_s, &check);
        if jump.is_some() || entry.lags.confident(&check) != was_confident {
            // The robots in the floor changed: it is worked out again at once.
            self.clock_floor = None;
        }
        let floor = self.clock_floor_s(received);
        let entry = self.entry_at(robot_id, received);
        let before = entry.correction_s;
        let now = entry.lags.correction_s(floor, &check);
        // Small changes of a correction in force are applied without a log line.
        let changed = (now == 0.0) != (before == 0.0) || (now - before).abs() > check.deadband_s;
        entry.correction_s = now;
        let offset_s = entry.lags.offset_s(floor).unwrap_or(0.0);
        if let Some(jump) = jump {
            self.counters.clock_jumps += 1;
            self.event(EngineEvent::ClockJumped {
                robot: robot_id.to_string(),
                jump,
            });
        }
        if changed {
            self.event(EngineEvent::ClockCorrected {
                robot: robot_id.to_string(),
                correction_s: now,
                offset_s,
            });
        }
        now
    }

    pub fn config(&self) -> &EngineConfig {
        &self.cfg
    }

    pub fn pitch(&self) -> &Pitch {
        &self.cfg.fusion.pitch
    }

    pub fn fusion(&self) -> &Fusion {
        &self.fusion
    }

    pub fn counters(&self) -> &EngineCounters {
        &self.counters
    }

    fn context(&self, now: Stamp) -> ValidationContext {
        ValidationContext {
            pitch: self.cfg.fusion.pitch.clone(),
            now,
            max_clock_skew_s: self.cfg.max_clock_skew_s,
            max_outside_m: self.cfg.max_outside_m,
        }
    }

    /// `key_robot` is the key's robot chunk as it came (`None` only for callers without a
    /// key, such as a replay): a chunk that is not a valid id is refused, never skipped.
    fn check_robot(&self, key_robot: Option<&str>, robot_id: &str) -> Result<(), Rejection> {
        if let Some(key) = key_robot
            && !proto::is_valid_id(key)
        {
            return Err(Rejection::BadKey(key.to_string()));
        }
        if let Some(key) = key_robot
            && key != robot_id
        {
            return Err(Rejection::KeyMismatch {
                key: key.to_string(),
                payload: robot_id.to_string(),
            });
        }
        match &self.cfg.roster {
            Some(r) if !r.contains(robot_id) => Err(Rejection::UnknownRobot(robot_id.into())),
            _ => Ok(()),
        }
    }

    /// Room for `robot_id` in the table at `now`. When the table is full, robots gone quiet
    /// are forgotten first; then the least established one that is not: fewest accepted
    /// messages, without a liveliness token before with one, the longest unheard. A robot
    /// that has sent [`AdmissionConfig::established_messages`] keeps its place, so a burst
    /// of made-up ids takes room only from each other, never from robots that are fusing.
    fn make_room(&mut self, robot_id: &str, now: Stamp) -> Result<(), Rejection> {
        if self.robots.contains_key(robot_id) || self.robots.len() < MAX_ROBOTS {
            return Ok(());
        }
        let expiry_s = self.cfg.admission.robot_expiry_s;
        self.robots
            .retain(|_, r| now.secs_since(r.last_heard) <= expiry_s);
        if self.robots.len() < MAX_ROBOTS {
            return Ok(());
        }
        let established = self.cfg.admission.established_messages;
        let victim = self
            .robots
            .iter()
            .filter(|(_, r)| r.accepted + r.statuses < established)
            .min_by_key(|(_, r)| (r.accepted + r.statuses, r.online, r.last_heard))
            .map(|(id, _)| id.clone());
        match victim {
            Some(id) => {
                self.robots.remove(&id);
                self.counters.robots_evicted += 1;
                Ok(())
            }
            None => Err(Rejection::TooManyRobots(robot_id.into())),
        }
    }

    /// The entry of `robot_id` (made if new), heard of at `now`; call [`Self::make_room`] first.
    fn entry_at(&mut self, robot_id: &str, now: Stamp) -> &mut RobotEntry {
        let burst = self.cfg.admission.rate_burst;
        let entry = self
            .robots
            .entry(robot_id.to_string())
            .or_insert_with(|| RobotEntry::new(now, burst));
        entry.last_heard = entry.last_heard.max(now);
        entry
    }

    /// Forgets robots whose token is gone and that were not heard of for the expiry time
    /// (at most once a [`SWEEP_EVERY_S`]).
    fn sweep(&mut self, now: Stamp) {
        if self
            .swept
            .is_some_and(|s| now.secs_since(s) < SWEEP_EVERY_S)
        {
            return;
        }
        self.swept = Some(now);
        let expiry_s = self.cfg.admission.robot_expiry_s;
        self.robots
            .retain(|_, r| r.online || now.secs_since(r.last_heard) <= expiry_s);
    }

    /// Takes a token from the bucket of a robot already known by the key's id; unknown
    /// robots are judged once they are admitted.
    fn check_rate(&mut self, key_robot: Option<&str>, now: Stamp) -> Result<(), Rejection> {
        let a = &self.cfg.admission;
        let (rate_hz, burst) = (a.rate_limit_hz, a.rate_burst);
        let Some((id, r)) = key_robot.and_then(|k| self.robots.get_mut(k).map(|r| (k, r))) else {
            return Ok(());
        };
        if r.bucket.take(now, rate_hz, burst) {
            Ok(())
        } else {
            Err(Rejection::RateLimited(id.to_string()))
        }
    }

    fn reject(&mut self, kind: &'static str, robot: Option<&str>, e: Rejection) -> Rejection {
        *self
            .counters
            .rejected
            .entry((kind, e.reason()))
            .or_default() += 1;
        // Only robots that may exist get an entry: a flood of made-up ids must not grow it.
        if let Some(entry) = robot.and_then(|r| self.robots.get_mut(r)) {
            entry.rejected += 1;
        }
        e
    }

    /// An observation's payload, received at `received` on the key of robot `key_robot`.
    pub fn observation(
        &mut self,
        key_robot: Option<&str>,
        payload: &[u8],
        received: Stamp,
    ) -> Result<(Observation, Ingest), Rejection> {
        if payload.len() > self.cfg.max_observation_bytes {
            let e = Rejection::TooLarge {
                bytes: payload.len(),
                limit: self.cfg.max_observation_bytes,
            };
            return Err(self.reject("observation", key_robot, e));
        }
        self.sweep(received);
        if let Err(e) = self.check_rate(key_robot, received) {
            return Err(self.reject("observation", key_robot, e));
        }
        let obs: Observation = match proto::decode(payload) {
            Ok(o) => o,
            Err(e) => return Err(self.reject("observation", key_robot, e.into())),
        };
        self.observation_decoded(key_robot, obs, received)
    }

    /// An already decoded observation (replay, in-process publishers).
    pub fn observation_decoded(
        &mut self,
        key_robot: Option<&str>,
        obs: Observation,
        received: Stamp,
    ) -> Result<(Observation, Ingest), Rejection> {
        let checked = self
            .check_robot(key_robot, &obs.robot_id)
            .and_then(|()| Ok(obs.validate(&self.context(received))?))
            .and_then(|()| self.make_room(&obs.robot_id, received));
        if let Err(e) = checked {
            self.recent.push(&obs, received, Some(e.reason()));
            return Err(self.reject("observation", Some(&obs.robot_id), e));
        }
        let lag_s = received.secs_since(obs.stamp);
        let correction_s = self.clock_correction(&obs.robot_id, lag_s, received);
        let outcome = if correction_s == 0.0 {
            self.fusion.ingest(&obs, received)
        } else {
            let corrected = Observation {
                stamp: obs.stamp.offset_secs(correction_s),
                ..obs.clone()
            };
            self.fusion.ingest(&corrected, received)
        };
        let refused = match outcome {
            Ingest::TooLate { .. } => Some("too_late"),
            Ingest::Duplicate => Some("duplicate"),
            Ingest::Rejected => Some("unusable"),
            Ingest::FromTheFuture { .. } => Some("future"),
            Ingest::Applied | Ingest::Reordered { .. } => None,
        };
        if let Some(r) = refused {
            self.recent.push(&obs, received, Some(r));
            return Err(self.reject("observation", Some(&obs.robot_id), Rejection::Core(r)));
        }
        self.counters.observations_accepted += 1;
        if correction_s != 0.0 {
            self.counters.observations_clock_corrected += 1;
        }
        let entry = self.entry_at(&obs.robot_id, received);
        entry.accepted += 1;
        entry.last_obs_received = Some(received);
        entry.rate.hit(received);
        entry.latency_s = Some(match entry.latency_s {
            Some(l) => l + LATENCY_WEIGHT * (lag_s - l),
            None => lag_s,
        });
        self.recent.push(&obs, received, None);
        Ok((obs, outcome))
    }

    /// A status payload.
    pub fn status(
        &mut self,
        key_robot: Option<&str>,
        payload: &[u8],
        received: Stamp,
    ) -> Result<RobotStatus, Rejection> {
        if payload.len() > self.cfg.max_status_bytes {
            let e = Rejection::TooLarge {
                bytes: payload.len(),
                limit: self.cfg.max_status_bytes,
            };
            return Err(self.reject("status", key_robot, e));
        }
        self.sweep(received);
        if let Err(e) = self.check_rate(key_robot, received) {
            return Err(self.reject("status", key_robot, e));
        }
        let status: RobotStatus = match proto::decode(payload) {
            Ok(s) => s,
            Err(e) => return Err(self.reject("status", key_robot, e.into())),
        };
        let checked = self
            .check_robot(key_robot, &status.robot_id)
            .and_then(|()| Ok(status.validate(&self.context(received))?))
            .and_then(|()| self.make_room(&status.robot_id, received));
        if let Err(e) = checked {
            return Err(self.reject("status", Some(&status.robot_id), e));
        }
        self.counters.statuses_accepted += 1;
        let entry = self.entry_at(&status.robot_id, received);
        entry.statuses += 1;
        let correction_s = entry.correction_s;
        let since = entry
            .status
            .as_ref()
            .filter(|prev| prev.stamp < status.stamp)
            .map(|prev| prev.stamp.offset_secs(correction_s));
        entry.status = Some(status.clone());
        entry.status_received = Some(received);
        // What its cameras looked at, on the fusion's clock (corrected as its observations
        // are).
        let report = ViewReport {
            robot: &status.robot_id,
            stamp: status.stamp.offset_secs(correction_s),
            pose: status.pose,
            footprints: &status.footprints,
            fps: status.fps,
            since,
        };
        let refused = self.fusion.footprints(&report, received);
        for e in refused {
            let entry = self.entry_at(&status.robot_id, received);
            entry.footprints_refused += 1;
            let count = entry.footprints_refused;
            if count.is_power_of_two() {
                self.event(EngineEvent::FootprintRefused {
                    robot: status.robot_id.clone(),
                    reason: e.to_string(),
                    count,
                });
            }
        }
        Ok(status)
    }

    /// A robot's liveliness token appeared (`alive`) or went away.
    pub fn liveliness(&mut self, robot_id: &str, alive: bool, at: Stamp) -> Result<(), Rejection> {
        if !proto::is_valid_id(robot_id) {
            let e = Rejection::Invalid(ValidationError::BadRobotId(robot_id.into()));
            return Err(self.reject("liveliness", None, e));
        }
        self.sweep(at);
        self.check_robot(None, robot_id)
            .and_then(|()| self.make_room(robot_id, at))
            .map_err(|e| self.reject("liveliness", None, e))?;
        let entry = self.entry_at(robot_id, at);
        if entry.online != alive || entry.since.is_none() {
            entry.online = alive;
            entry.since = Some(at);
        }
        Ok(())
    }

    /// The ball estimate at `at`, with its prediction; `None` before any ball was seen.
    pub fn ball_state(&self, at: Stamp) -> Option<BallState> {
        self.fusion.ball_state(at)
    }

    /// Pose from its latest status, else from its latest observation.
    fn robot_pose(&self, robot_id: &str) -> Option<Pose2> {
        let status = self.robots.get(robot_id).and_then(|r| r.status.as_ref());
        status.map(|s| s.pose).or_else(|| {
            self.fusion
                .robots()
                .iter()
                .find(|t| &*t.robot == robot_id)
                .map(|t| t.pose)
        })
    }

    /// Every robot heard of, by id.
    pub fn robots(&self, now: Stamp) -> Vec<RobotView> {
        let trust = self.fusion.robots();
        let floor_s = self.fresh_clock_floor_s();
        self.robots
            .iter()
            .map(|(id, r)| {
                let t = trust.iter().find(|t| &*t.robot == id.as_str());
                let clock_offset_s = r.lags.offset_s(floor_s);
                RobotView {
                    robot_id: id.clone(),
                    online: r.online,
                    since_s: r.since.map(|s| now.secs_since(s)),
                    last_obs_age_s: r.last_obs_received.map(|s| now.secs_since(s)),
                    obs_rate_hz: r.rate.decayed(now),
                    observations_accepted: r.accepted,
                    observations_rejected: r.rejected,
                    covariance_scale: t.map(|t| t.covariance_scale),
                    outlier_rate: t.map(|t| t.outlier_rate),
                    latency_s: r.latency_s,
                    clock_offset_s,
                    clock_suspect: clock_offset_s.is_some_and(|o| o.abs() > self.cfg.clock.warn_s),
                    clock_correction_s: r.correction_s,
                    clock_jumps: r.lags.jumps(),
                    footprints_refused: r.footprints_refused,
                    pose: self.robot_pose(id),
                    status: r.status.clone(),
                }
            })
            .collect()
    }

    /// The observations received in the `window_s` seconds up to `now`, accepted or
    /// rejected (with the reason), oldest first.
    pub fn recent_observations(&self, now: Stamp, window_s: f64) -> Vec<RecentObs> {
        self.recent.within(now, window_s)
    }

    /// Counts a rejection decided outside the engine (an oversized query).
    pub fn count_rejection(&mut self, kind: &'static str, reason: &'static str) {
        *self.counters.rejected.entry((kind, reason)).or_default() += 1;
    }

    /// Counts `n` rejections decided before the engine saw the inputs, of `robot` when it
    /// is known (a made-up id gets no entry).
    pub fn count_rejections(
        &mut self,
        kind: &'static str,
        reason: &'static str,
        robot: Option<&str>,
        n: u64,
    ) {
        *self.counters.rejected.entry((kind, reason)).or_default() += n;
        if let Some(entry) = robot.and_then(|r| self.robots.get_mut(r)) {
            entry.rejected += n;
        }
    }

    /// Rejected inputs so far, by `kind/reason` (as the metrics label them).
    pub fn rejected_by_reason(&self) -> BTreeMap<String, u64> {
        self.counters
            .rejected
            .iter()
            .map(|((kind, reason), n)| (format!("{kind}/{reason}"), *n))
            .collect()
    }

    /// Whether robot `id` is online (its liveliness token is present).
    pub fn is_online(&self, id: &str) -> bool {
        self.robots.get(id).is_some_and(|r| r.online)
    }

    /// Robots whose liveliness token is present.
    pub fn online_robots(&self) -> Vec<String> {
        self.robots
            .iter()
            .filter(|(_, r)| r.online)
            .map(|(id, _)| id.clone())
            .collect()
    }

    /// Answers a prediction or intercept query at `at`.
    pub fn query(&self, q: &BallQuery, at: Stamp) -> Result<QueryReply, QueryError> {
        match q {
            BallQuery::Predict { horizon_s } => self
                .fusion
                .predict(at, *horizon_s)
                .map(QueryReply::Prediction)
                .ok_or(QueryError::NoEstimate),
            BallQuery::Intercept {
                robot_id,
                speed_mps,
            } => {
                let pose = self
                    .robot_pose(robot_id)
                    .ok_or_else(|| QueryError::UnknownRobot(robot_id.clone()))?;
                let speed = speed_mps.unwrap_or(self.cfg.robot_speed_mps);
                let s = self
                    .fusion
                    .intercept(at, [pose.x_m, pose.y_m], speed)
                    .ok_or(QueryError::NoEstimate)?;
                Ok(QueryReply::Intercept(Intercept {
                    version: VERSION,
                    robot_id: robot_id.clone(),
                    stamp: at,
                    reachable_in_motion: s.reachable_in_motion,
                    t_s: s.t_s,
                    point_m: s.point_m,
                    probability: s.probability,
                }))
            }
        }
    }
}

#[cfg(test)]
mod tests;
