//! The ground-truth channels of a match log: how a simulated run's truth is written next to
//! its observations, and how the run is rebuilt from a log so that a replay can be scored
//! exactly like the evaluation.
//!
//! Each message is JSON (`serde_json`), described by the JSON Schema [`truth_schemas`]
//! names in [`TruthMessage::schema_name`]. The channels:
//!
//! | topic | message | log time |
//! |---|---|---|
//! | [`RUN_TOPIC`] | [`RunInfo`], once | the run's start |
//! | [`BALL_TOPIC`] | [`TruthSample`], every truth tick | start + `t_s` |
//! | [`ROBOTS_TOPIC`] | [`RobotPoses`], every truth tick | start + `t_s` |
//! | [`EVENTS_TOPIC`] | [`BallEvent`] | start + its `t_s` |
//! | [`KINDS_TOPIC`] | [`ObsLabel`], one per observation | the observation's arrival |
//!
//! The observations themselves travel on their own channel as `proto::Observation`,
//! logged at their arrival; [`TruthLogBuilder::finish`] takes them back with those stamps.

use crate::SimRun;
use crate::types::{BallEvent, Delivery, ObsKind, RobotTrack, SimStats, TrueParams, TruthSample};
use proto::{Camera, Observation, Pitch, Pose2, Stamp};
use schemars::{JsonSchema, Schema, schema_for};
use serde::{Deserialize, Serialize, de::DeserializeOwned};
use std::collections::HashMap;
use thiserror::Error;

/// Topic of the run's description ([`RunInfo`]).
pub const RUN_TOPIC: &str = "sim/run";
/// Topic of the true ball ([`TruthSample`]).
pub const BALL_TOPIC: &str = "sim/truth/ball";
/// Topic of the true robot poses ([`RobotPoses`]).
pub const ROBOTS_TOPIC: &str = "sim/truth/robots";
/// Topic of what happened to the ball ([`BallEvent`]).
pub const EVENTS_TOPIC: &str = "sim/truth/events";
/// Topic of what each observation really was ([`ObsLabel`]).
pub const KINDS_TOPIC: &str = "sim/truth/obs_kind";
/// Every ground-truth topic.
pub const TOPICS: [&str; 5] = [
    RUN_TOPIC,
    BALL_TOPIC,
    ROBOTS_TOPIC,
    EVENTS_TOPIC,
    KINDS_TOPIC,
];

const RUN_SCHEMA: &str = "RunInfo";
const BALL_SCHEMA: &str = "TruthSample";
const ROBOTS_SCHEMA: &str = "RobotPoses";
const EVENTS_SCHEMA: &str = "BallEvent";
const KINDS_SCHEMA: &str = "ObsLabel";

/// One robot of a run, without its path (which travels as `RobotPoses`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RobotInfo {
    pub id: String,
    /// Whether the robot reports observations.
    pub observer: bool,
    /// Factor on the covariance this robot reports: 1 (honest), 0.25 or 4 (misreporting).
    pub cov_scale: f64,
    /// Offset of this robot's clock from true time (added to its capture stamps).
    pub clock_offset_s: f64,
    /// Capture instants this robot had, whether or not it saw anything.
    pub frames: u64,
    /// When its perception stalled: from and to, seconds. Absent in logs from before they
    /// were kept.
    #[serde(default)]
    pub stalls: Vec<[f64; 2]>,
}

/// The phantom ball of a run: the robot that reported it and where it was.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PhantomSpot {
    pub robot_id: String,
    pub position_m: [f64; 2],
}

/// What a simulated run was: its scenario, seed, clock, pitch, physical parameters,
/// counters and robots. Logged once, on `sim/run`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RunInfo {
    pub scenario: String,
    pub seed: u64,
    /// Epoch of t = 0.
    pub start: Stamp,
    pub duration_s: f64,
    pub pitch: Pitch,
    pub params: TrueParams,
    pub stats: SimStats,
    pub phantom: Option<PhantomSpot>,
    /// Every robot, observer or not, in the run's order.
    pub robots: Vec<RobotInfo>,
}

/// One robot's true pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RobotPose {
    pub id: String,
    pub pose: Pose2,
}

/// The true poses of the robots at one truth tick (`t_s` seconds after the run's start).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RobotPoses {
    pub t_s: f64,
    pub robots: Vec<RobotPose>,
}

/// What one observation, named by robot, sequence number and camera, really was.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ObsLabel {
    pub robot_id: String,
    pub seq: u64,
    pub camera: Camera,
    pub kind: ObsKind,
}

/// One ground-truth message, ready to be written to a log.
#[derive(Debug, Clone, PartialEq)]
pub struct TruthMessage {
    pub topic: &'static str,
    /// Name of the message's schema in [`truth_schemas`].
    pub schema_name: &'static str,
    pub log_time: Stamp,
    /// The message as JSON.
    pub json: Vec<u8>,
}

/// Why a log's ground truth could not be read.
#[derive(Debug, Error)]
pub enum TruthLogError {
    #[error("{0:?} is not a ground-truth topic")]
    UnknownTopic(String),
    #[error("{topic}: payload is not valid JSON for this message: {source}")]
    Json {
        topic: &'static str,
        source: serde_json::Error,
    },
    #[error("the log has more than one {} message", RUN_TOPIC)]
    DuplicateRun,
    #[error("the log has ground truth but no {} message", RUN_TOPIC)]
    MissingRun,
    #[error("robot poses at t = {t_s} s name robot {id:?}, which the run does not list")]
    UnknownRobot { id: String, t_s: f64 },
}

/// The JSON Schema of every ground-truth message, named as in [`TruthMessage::schema_name`].
pub fn truth_schemas() -> Vec<(&'static str, Schema)> {
    vec![
        (RUN_SCHEMA, schema_for!(RunInfo)),
        (BALL_SCHEMA, schema_for!(TruthSample)),
        (ROBOTS_SCHEMA, schema_for!(RobotPoses)),
        (EVENTS_SCHEMA, schema_for!(BallEvent)),
        (KINDS_SCHEMA, schema_for!(ObsLabel)),
    ]
}

fn message<T: Serialize>(
    topic: &'static str,
    schema_name: &'static str,
    log_time: Stamp,
    msg: &T,
) -> TruthMessage {
    TruthMessage {
        topic,
        schema_name,
        log_time,
        // Serialising these plain structs cannot fail (no maps with non-string keys).
        json: serde_json::to_vec(msg).unwrap_or_default(),
    }
}

impl RunInfo {
    /// The description of `run`.
    pub fn of(run: &SimRun) -> Self {
        RunInfo {
            scenario: run.scenario.clone(),
            seed: run.seed,
            start: run.start,
            duration_s: run.duration_s,
            pitch: run.pitch.clone(),
            params: run.params,
            stats: run.stats,
            phantom: run.phantom.as_ref().map(|(id, spot)| PhantomSpot {
                robot_id: id.clone(),
                position_m: *spot,
            }),
            robots: run
                .robots
                .iter()
                .map(|r| RobotInfo {
                    id: r.id.clone(),
                    observer: r.observer,
                    cov_scale: r.cov_scale,
                    clock_offset_s: r.clock_offset_s,
                    frames: r.frames,
                    stalls: r.stalls.clone(),
                })
                .collect(),
        }
    }
}

/// The robots' poses grouped by time, robots in the run's order within a group.
fn robot_poses(run: &SimRun) -> Vec<RobotPoses> {
    let mut all: Vec<(f64, RobotPose)> = run
        .robots
        .iter()
        .flat_map(|r| {
            r.poses.iter().map(|(t_s, pose)| {
                let p = RobotPose {
                    id: r.id.clone(),
                    pose: *pose,
                };
                (*t_s, p)
            })
        })
        .collect();
    all.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut out: Vec<RobotPoses> = Vec::new();
    for (t_s, pose) in all {
        match out.last_mut() {
            Some(last) if last.t_s == t_s => last.robots.push(pose),
            _ => out.push(RobotPoses {
                t_s,
                robots: vec![pose],
            }),
        }
    }
    out
}

/// The ground truth of `run` as log messages, sorted by log time (messages with the same
/// log time in the order of the table in the module documentation).
pub fn truth_messages(run: &SimRun) -> Vec<TruthMessage> {
    let mut out = vec![message(RUN_TOPIC, RUN_SCHEMA, run.start, &RunInfo::of(run))];
    for s in &run.truth {
        out.push(message(BALL_TOPIC, BALL_SCHEMA, run.stamp_of(s.t_s), s));
    }
    for p in robot_poses(run) {
        out.push(message(
            ROBOTS_TOPIC,
            ROBOTS_SCHEMA,
            run.stamp_of(p.t_s),
            &p,
        ));
    }
    for e in &run.events {
        out.push(message(
            EVENTS_TOPIC,
            EVENTS_SCHEMA,
            run.stamp_of(e.t_s()),
            e,
        ));
    }
    for d in &run.deliveries {
        let label = ObsLabel {
            robot_id: d.obs.robot_id.clone(),
            seq: d.obs.seq,
            camera: d.obs.camera,
            kind: d.kind,
        };
        out.push(message(KINDS_TOPIC, KINDS_SCHEMA, d.arrival, &label));
    }
    // Stable: equal log times keep the order above.
    out.sort_by_key(|m| m.log_time);
    out
}

/// Rebuilds a [`SimRun`] from a log: feed it every ground-truth message ([`push`]), then
/// hand it the observations with their arrival stamps ([`finish`]).
///
/// [`push`]: TruthLogBuilder::push
/// [`finish`]: TruthLogBuilder::finish
#[derive(Debug, Default)]
pub struct TruthLogBuilder {
    run: Option<RunInfo>,
    truth: Vec<TruthSample>,
    poses: Vec<RobotPoses>,
    events: Vec<BallEvent>,
    /// Robot id → (seq, camera) → kind.
    kinds: HashMap<String, HashMap<(u64, Camera), ObsKind>>,
}

fn decode<T: DeserializeOwned>(topic: &'static str, json: &[u8]) -> Result<T, TruthLogError> {
    serde_json::from_slice(json).map_err(|source| TruthLogError::Json { topic, source })
}

impl TruthLogBuilder {
    /// A builder that has seen no message yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Decodes one message from a ground-truth topic (one of [`TOPICS`]) and keeps it.
    /// Messages may come in any order; a later label for the same observation replaces an
    /// earlier one.
    pub fn push(&mut self, topic: &str, json: &[u8]) -> Result<(), TruthLogError> {
        match topic {
            RUN_TOPIC => {
                let info = decode(RUN_TOPIC, json)?;
                if self.run.replace(info).is_some() {
                    return Err(TruthLogError::DuplicateRun);
                }
            }
            BALL_TOPIC => self.truth.push(decode(BALL_TOPIC, json)?),
            ROBOTS_TOPIC => self.poses.push(decode(ROBOTS_TOPIC, json)?),
            EVENTS_TOPIC => self.events.push(decode(EVENTS_TOPIC, json)?),
            KINDS_TOPIC => {
                let label: ObsLabel = decode(KINDS_TOPIC, json)?;
                self.kinds
                    .entry(label.robot_id)
                    .or_default()
                    .insert((label.seq, label.camera), label.kind);
            }
            other => return Err(TruthLogError::UnknownTopic(other.to_string())),
        }
        Ok(())
    }

    /// Whether the run's description ([`RUN_TOPIC`]) has been pushed.
    pub fn has_run(&self) -> bool {
        self.run.is_some()
    }

    /// The run: its truth, robot paths and events in time order, and `observations` (each
    /// with its arrival stamp) as deliveries in the simulator's order (arrival, capture
    /// stamp, robot id, seq), each of the kind its label gives ([`ObsKind::Ball`] when
    /// unlabelled).
    pub fn finish(self, observations: Vec<(Stamp, Observation)>) -> Result<SimRun, TruthLogError> {
        let info = self.run.ok_or(TruthLogError::MissingRun)?;
        let mut robots: Vec<RobotTrack> = info
            .robots
            .into_iter()
            .map(|r| RobotTrack {
                id: r.id,
                observer: r.observer,
                poses: Vec::new(),
                cov_scale: r.cov_scale,
                clock_offset_s: r.clock_offset_s,
                frames: r.frames,
                stalls: r.stalls,
            })
            .collect();
        let index: HashMap<String, usize> = robots
            .iter()
            .enumerate()
            .map(|(i, r)| (r.id.clone(), i))
            .collect();
        let mut poses = self.poses;
        poses.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
        for p in poses {
            for r in p.robots {
                let i = *index.get(&r.id).ok_or(TruthLogError::UnknownRobot {
                    id: r.id.clone(),
                    t_s: p.t_s,
                })?;
                robots[i].poses.push((p.t_s, r.pose));
            }
        }
        let mut truth = self.truth;
        truth.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
        let mut events = self.events;
        events.sort_by(|a, b| a.t_s().total_cmp(&b.t_s()));
        let kinds = self.kinds;
        let mut deliveries: Vec<Delivery> = observations
            .into_iter()
            .map(|(arrival, obs)| {
                let kind = kinds
                    .get(&obs.robot_id)
                    .and_then(|k| k.get(&(obs.seq, obs.camera)))
                    .copied()
                    .unwrap_or(ObsKind::Ball);
                Delivery { arrival, obs, kind }
            })
            .collect();
        deliveries.sort_by(|a, b| {
            (a.arrival, a.obs.stamp, &a.obs.robot_id, a.obs.seq).cmp(&(
                b.arrival,
                b.obs.stamp,
                &b.obs.robot_id,
                b.obs.seq,
            ))
        });
        Ok(SimRun {
            scenario: info.scenario,
            seed: info.seed,
            start: info.start,
            duration_s: info.duration_s,
            pitch: info.pitch,
            truth,
            robots,
            deliveries,
            events,
            params: info.params,
            stats: info.stats,
            phantom: info.phantom.map(|p| (p.robot_id, p.position_m)),
        })
    }
}
