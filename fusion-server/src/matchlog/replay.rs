//! Offline replay of a match log: the recorded observations and statuses go through the same
//! engine at the times they were received, the states are recomputed at the times they were
//! published (or at a fixed rate when the log has none) and compared with the recorded ones.
//! States may also be asked for at chosen times, or on a grid through a chosen stamp and on
//! past the end of the log ([`ReplayOptions`]). Channels replay does not know (a simulator's
//! ground truth, say) are copied through and counted.
//!
//! A state at time T is the engine's estimate at T after every message received at or
//! before T: what the live server would have published at T.

use crate::engine::{Engine, EngineConfig};
use crate::estimator::FusionCounters;
use crate::matchlog::read::LogMessage;
use crate::scene::{self, Scene};
use proto::{BallState, KeySpace, ModelParams, Stamp};
use std::collections::BTreeMap;

mod seek;
mod states_csv;
mod summary;
mod times;

pub use seek::{Seeker, is_input, is_view, views_before};
pub use states_csv::StatesCsv;
pub use summary::{ReplayOutputs, summary_json, summary_text};
use times::Schedule;
pub use times::TimeArg;

/// Where a replay's messages go: a new match log, a file of states, or nowhere.
pub trait ReplaySink {
    fn write(&mut self, topic: &str, schema: &str, log_time: Stamp, payload: &[u8]);

    /// A state asked for at `at` (`None`: no estimate yet), before it is written: at the
    /// asked times or on the grid, or, when nothing else is asked, at the recorded states.
    fn state(&mut self, _at: Stamp, _state: Option<&BallState>) {}

    /// Whether it keeps what is written (when not, states are not even encoded for it).
    fn writes(&self) -> bool {
        true
    }
}

impl ReplaySink for () {
    fn write(&mut self, _: &str, _: &str, _: Stamp, _: &[u8]) {}

    fn writes(&self) -> bool {
        false
    }
}

impl<S: ReplaySink> ReplaySink for Option<S> {
    fn write(&mut self, topic: &str, schema: &str, log_time: Stamp, payload: &[u8]) {
        if let Some(s) = self {
            s.write(topic, schema, log_time, payload);
        }
    }

    fn state(&mut self, at: Stamp, state: Option<&BallState>) {
        if let Some(s) = self {
            s.state(at, state);
        }
    }

    fn writes(&self) -> bool {
        self.as_ref().is_some_and(|s| s.writes())
    }
}

/// Both sinks, the first then the second.
impl<A: ReplaySink, B: ReplaySink> ReplaySink for (A, B) {
    fn write(&mut self, topic: &str, schema: &str, log_time: Stamp, payload: &[u8]) {
        self.0.write(topic, schema, log_time, payload);
        self.1.write(topic, schema, log_time, payload);
    }

    fn state(&mut self, at: Stamp, state: Option<&BallState>) {
        self.0.state(at, state);
        self.1.state(at, state);
    }

    fn writes(&self) -> bool {
        self.0.writes() || self.1.writes()
    }
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
    /// States computed with an estimate (and written to the new log, when there is one).
    pub states_written: u64,
    /// Times a state was asked for (or recorded) when there was no estimate yet.
    pub states_without_estimate: u64,
    /// The fusion core's own counts (reordered and replayed observations, observations
    /// beyond a wall, ...).
    pub fusion: FusionCounters,
    /// What the filter had learned by the last message.
    pub model: Option<ModelParams>,
    /// Where the ball turns at each wall (in the order of `WallSide::ALL`), outside
    /// (positive) or inside where the pitch puts it, and the bounces that measured it.
    pub wall_offsets_m: [f64; 4],
    pub wall_bounces: [u32; 4],
    /// Messages with topics or schemas replay does not know (copied through).
    pub other: u64,
    /// Match time covered, from the first to the last message.
    pub span_s: f64,
    /// Scene messages written ([`ReplayOptions::scene`]).
    pub scene_written: u64,
    /// Scene messages of the log left out (drawn anew when the scene is asked for).
    pub scene_replaced: u64,
}

/// Replay options. The states are computed at every recorded state (and compared), and:
/// at the `at` times when there are any; else on the grid when the log holds no states or
/// when `align` or `until` is given.
#[derive(Debug, Clone)]
pub struct ReplayOptions {
    pub engine: EngineConfig,
    pub prefix: String,
    /// Rate of the grid of states.
    pub state_rate_hz: f64,
    /// States at exactly these times (the grid is then not used).
    pub at: Vec<TimeArg>,
    /// The grid goes through this time (default: the first message); it starts at the
    /// first message.
    pub align: Option<TimeArg>,
    /// The grid ends here (included), past the last message if need be (default: at the
    /// last message).
    pub until: Option<TimeArg>,
    /// Draw the match as a Foxglove scene ([`crate::scene`]) beside the states, every
    /// [`scene::SCENE_PERIOD_S`] of match time. A log's own scene is never copied.
    pub scene: bool,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions {
            engine: EngineConfig::default(),
            prefix: proto::DEFAULT_PREFIX.into(),
            state_rate_hz: 30.0,
            at: Vec::new(),
            align: None,
            until: None,
            scene: false,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error("bad key prefix: {0}")]
    Prefix(#[from] proto::KeyError),
}

/// Where a replay writes: the sink, the scene (when drawn) and the report.
struct Out<'s> {
    sink: &'s mut dyn ReplaySink,
    scene: Option<Scene>,
    report: ReplayReport,
}

/// The state at `at`, handed to the sink when `asked`, written and counted (with the scene
/// when due); its payload.
fn emit_state(
    engine: &Engine,
    keys: &KeySpace,
    at: Stamp,
    (asked, compared): (bool, bool),
    out: &mut Out,
) -> Option<Vec<u8>> {
    let state = engine.ball_state(at);
    let (sink, report) = (&mut *out.sink, &mut out.report);
    if asked {
        sink.state(at, state.as_ref());
    }
    if let Some(scene) = &mut out.scene {
        for r in scene.tick(engine, at, state.as_ref()) {
            sink.write(r.topic, r.schema, r.log_time, &r.payload);
            report.scene_written += 1;
        }
    }
    let Some(state) = state else {
        report.states_without_estimate += 1;
        return None;
    };
    report.states_written += 1;
    if !(compared || sink.writes()) {
        // Nobody reads it: the encoding (most of a state's cost) is skipped.
        return None;
    }
    let payload = proto::encode(&state);
    sink.write(&keys.ball_state(), "BallState", at, &payload);
    Some(payload)
}

/// The times asked for beyond the recorded states.
fn schedule(opts: &ReplayOptions, messages: &[LogMessage], has_states: bool) -> Schedule {
    let (Some(first), Some(last)) = (messages.first(), messages.last()) else {
        return Schedule::None;
    };
    let (first, last) = (first.log_time, last.log_time);
    if !opts.at.is_empty() {
        Schedule::at(&opts.at, first)
    } else if !has_states || opts.align.is_some() || opts.until.is_some() {
        Schedule::grid(opts.state_rate_hz, opts.align, opts.until, first, last)
    } else {
        Schedule::None
    }
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
    let mut out = Out {
        sink,
        scene: opts.scene.then(Scene::new),
        report: ReplayReport {
            messages: messages.len(),
            ..ReplayReport::default()
        },
    };
    let has_states = messages.iter().any(|m| m.schema_name == "BallState");
    let mut times = schedule(opts, messages, has_states);
    let (first, last) = (messages.first(), messages.last());
    if let (Some(a), Some(b)) = (first, last) {
        out.report.span_s = b.log_time.secs_since(a.log_time).max(0.0);
    }
    for (i, m) in messages.iter().enumerate() {
        if i % 4096 == 0 {
            progress(i, messages.len());
        }
        let at = m.log_time;
        while let Some(t) = times.next_before(Some(at)) {
            emit_state(&engine, &keys, t, (true, false), &mut out);
        }
        let robot = keys.robot_id_of(&m.topic);
        // A log holds no liveliness tokens: a robot is online from its first input on (as
        // in a replay played as if live, whose player declares its token then).
        if let Some(id) = robot
            && seek::is_input(m)
            && !engine.is_online(id)
        {
            engine.liveliness(id, true, at).ok();
        }
        match m.schema_name.as_str() {
            "Observation" => {
                out.report.observations += 1;
                if engine.observation(robot, &m.data, at).is_ok() {
                    out.report.observations_accepted += 1;
                }
                for e in engine.take_events() {
                    tracing::info!("{e}");
                }
                out.sink.write(&m.topic, &m.schema_name, at, &m.data);
            }
            "RobotStatus" => {
                out.report.statuses += 1;
                let _ = engine.status(robot, &m.data, at);
                out.sink.write(&m.topic, &m.schema_name, at, &m.data);
            }
            "BallState" => {
                out.report.states_recorded += 1;
                let asked = times.asks_nothing();
                let now = emit_state(&engine, &keys, at, (asked, true), &mut out);
                let report = &mut out.report;
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
            // The log's own scene: drawn anew (when asked), never copied beside a new one.
            name if scene::is_scene_schema(name) => out.report.scene_replaced += 1,
            _ => {
                out.report.other += 1;
                out.sink.write(&m.topic, &m.schema_name, at, &m.data);
            }
        }
    }
    // Due at or after the last message: the ball coasting on, stopping, lost.
    while let Some(t) = times.next_before(None) {
        emit_state(&engine, &keys, t, (true, false), &mut out);
    }
    progress(messages.len(), messages.len());
    let mut report = out.report;
    report.rejected = engine.counters().rejected.clone();
    report.fusion = engine.fusion().counters();
    report.model = last
        .and_then(|m| engine.ball_state(m.log_time))
        .map(|s| s.model);
    let surface = engine.fusion().tracker().surface();
    report.wall_offsets_m = surface.wall_offsets_m();
    report.wall_bounces = surface.wall_samples();
    Ok(report)
}

#[cfg(test)]
mod tests;
