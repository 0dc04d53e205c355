//! Offline replay of a match log: the recorded observations and statuses go through the same
//! engine at the times they were received, the states are recomputed at the times they were
//! published (or at a fixed rate when the log has none) and compared with the recorded ones,
//! and when the log carries the simulator's ground truth the result is scored the way the
//! evaluation scores it.

use crate::engine::{Engine, EngineConfig};
use crate::mcap_read::LogMessage;
use crate::scoring::run_fusion;
use proto::{KeySpace, Stamp};
use sim::score::{Summary, score, tick_count};
use sim::truth_log::{TruthLogBuilder, TruthLogError};
use sim::{Delivery, ObsKind};
use std::collections::BTreeMap;

/// Where a replay's messages go: a new match log, or nowhere.
pub trait ReplaySink {
    fn write(&mut self, topic: &str, schema: &str, log_time: Stamp, payload: &[u8]);
}

impl ReplaySink for () {
    fn write(&mut self, _: &str, _: &str, _: Stamp, _: &[u8]) {}
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReplayReport {
    pub messages: usize,
    pub observations: u64,
    pub observations_accepted: u64,
    pub statuses: u64,
    /// (kind, reason) → count, as the live server would have counted them.
    pub rejected: BTreeMap<(&'static str, &'static str), u64>,
    /// States in the log.
    pub states_recorded: u64,
    /// Recorded states whose recomputation is byte-for-byte the same.
    pub states_identical: u64,
    /// The first recorded state that differed: its log time and both payloads.
    pub first_difference: Option<(Stamp, String, String)>,
    /// States written to the new log.
    pub states_written: u64,
    /// Messages with topics or schemas replay does not know (copied through).
    pub other: u64,
    /// Match time covered, from the first to the last message.
    pub span_s: f64,
    /// The evaluation's figures, when the log carries ground truth.
    pub accuracy: Option<Summary>,
}

/// Replay options.
#[derive(Debug, Clone)]
pub struct ReplayOptions {
    pub engine: EngineConfig,
    pub prefix: String,
    /// State rate used when the log holds no recorded states.
    pub state_rate_hz: f64,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions {
            engine: EngineConfig::default(),
            prefix: proto::DEFAULT_PREFIX.into(),
            state_rate_hz: 30.0,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error("bad key prefix: {0}")]
    Prefix(#[from] proto::KeyError),
    #[error("ground truth in the log: {0}")]
    Truth(#[from] TruthLogError),
}

fn emit_state(
    engine: &Engine,
    keys: &KeySpace,
    at: Stamp,
    sink: &mut dyn ReplaySink,
) -> Option<Vec<u8>> {
    let state = engine.ball_state(at)?;
    let payload = proto::encode(&state);
    sink.write(&keys.ball_state(), "BallState", at, &payload);
    Some(payload)
}

/// Replays `messages` (in log order); `progress(done, total)` is called now and then.
pub fn replay(
    messages: &[LogMessage],
    opts: &ReplayOptions,
    sink: &mut dyn ReplaySink,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<ReplayReport, ReplayError> {
    let keys = KeySpace::new(&opts.prefix)?;
    let mut engine = Engine::new(opts.engine.clone());
    let mut report = ReplayReport {
        messages: messages.len(),
        ..ReplayReport::default()
    };
    let has_states = messages.iter().any(|m| m.schema_name == "BallState");
    let has_truth = messages
        .iter()
        .any(|m| m.topic == sim::truth_log::RUN_TOPIC);
    let tick_s = 1.0 / opts.state_rate_hz.max(1e-3);
    let mut next_tick: Option<Stamp> = None;
    let mut truth = TruthLogBuilder::new();
    let mut arrivals: Vec<(Stamp, proto::Observation)> = Vec::new();
    let (first, last) = (messages.first(), messages.last());
    if let (Some(a), Some(b)) = (first, last) {
        report.span_s = b.log_time.secs_since(a.log_time).max(0.0);
    }
    for (i, m) in messages.iter().enumerate() {
        if i % 4096 == 0 {
            progress(i, messages.len());
        }
        let at = m.log_time;
        if !has_states {
            let mut t = *next_tick.get_or_insert(at);
            while t < at {
                if emit_state(&engine, &keys, t, sink).is_some() {
                    report.states_written += 1;
                }
                t = t.offset_secs(tick_s);
            }
            next_tick = Some(t);
        }
        let robot = keys.robot_id_of(&m.topic);
        match m.schema_name.as_str() {
            "Observation" => {
                report.observations += 1;
                // Decoded once: kept for scoring (when the log has ground truth) and fused.
                let accepted = match proto::decode::<proto::Observation>(&m.data) {
                    Ok(o) => {
                        if has_truth {
                            arrivals.push((at, o.clone()));
                        }
                        engine.observation_decoded(robot, o, at).is_ok()
                    }
                    Err(_) => engine.observation(robot, &m.data, at).is_ok(),
                };
                if accepted {
                    report.observations_accepted += 1;
                }
                sink.write(&m.topic, &m.schema_name, at, &m.data);
            }
            "RobotStatus" => {
                report.statuses += 1;
                let _ = engine.status(robot, &m.data, at);
                sink.write(&m.topic, &m.schema_name, at, &m.data);
            }
            "BallState" => {
                report.states_recorded += 1;
                let now = emit_state(&engine, &keys, at, sink);
                if now.is_some() {
                    report.states_written += 1;
                }
                if now.as_deref() == Some(m.data.as_slice()) {
                    report.states_identical += 1;
                } else if report.first_difference.is_none() {
                    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
                    report.first_difference = Some((
                        at,
                        text(&m.data),
                        now.as_deref()
                            .map(text)
                            .unwrap_or_else(|| "no state".into()),
                    ));
                }
            }
            _ if sim::truth_log::TOPICS.contains(&m.topic.as_str()) => {
                truth.push(&m.topic, &m.data)?;
                sink.write(&m.topic, &m.schema_name, at, &m.data);
            }
            _ => {
                report.other += 1;
                sink.write(&m.topic, &m.schema_name, at, &m.data);
            }
        }
    }
    progress(messages.len(), messages.len());
    report.rejected = engine.counters().rejected.clone();
    if truth.has_run() {
        let run = truth.finish(arrivals)?;
        // The configured fusion, on the run's pitch.
        let mut cfg = opts.engine.fusion.clone();
        cfg.set_pitch(run.pitch.clone());
        let records = run_fusion(&run, cfg.clone(), |_| true);
        let without = run
            .phantom
            .as_ref()
            .map(|_| run_fusion(&run, cfg.clone(), |d: &Delivery| d.kind != ObsKind::Phantom));
        let samples = score(
            &run,
            &records,
            tick_count(run.duration_s),
            without.as_deref(),
        );
        report.accuracy = Some(Summary::of(&samples));
    }
    Ok(report)
}
