//! Seeking in a match log: the engine as it stood at a chosen time, re-fused from the
//! nearest earlier snapshot (or the start) through the same pure engine. Time is the log's.

use crate::engine::{Engine, EngineConfig};
use crate::matchlog::read::LogMessage;
use proto::{KeySpace, Stamp};

/// Match time between two snapshots the seeker keeps.
pub const SNAPSHOT_EVERY_S: f64 = 20.0;

/// Whether a live server is fed this message (observations and statuses; recorded states
/// and ground truth are not re-sent).
pub fn is_input(m: &LogMessage) -> bool {
    matches!(m.schema_name.as_str(), "Observation" | "RobotStatus")
}

/// Whether a live server is shown this message as it replays: a camera view (the page
/// shows it; the fusion does not use it).
pub fn is_view(m: &LogMessage) -> bool {
    m.schema_name == crate::camera_views::images::VIEW_SCHEMA
}

/// The newest view of each camera logged before message `end`, in log order.
pub fn views_before(messages: &[LogMessage], end: usize) -> Vec<&LogMessage> {
    let mut newest: std::collections::BTreeMap<&str, usize> = Default::default();
    for (i, m) in messages[..end.min(messages.len())].iter().enumerate() {
        if is_view(m) {
            newest.insert(m.topic.as_str(), i);
        }
    }
    let mut idx: Vec<usize> = newest.into_values().collect();
    idx.sort_unstable();
    idx.into_iter().map(|i| &messages[i]).collect()
}

/// Feeds one input message to the engine, received at its log time (rejections are counted
/// by the engine, as live). A log holds no liveliness tokens: a robot comes online with its
/// first message and stays so, as when the log is played back as if live (whose player
/// declares each robot's token when it first appears).
pub fn feed(engine: &mut Engine, keys: &KeySpace, m: &LogMessage) {
    let robot = keys.robot_id_of(&m.topic);
    if !is_input(m) {
        return;
    }
    if let Some(id) = robot
        && !engine.is_online(id)
    {
        engine.liveliness(id, true, m.log_time).ok();
    }
    match m.schema_name.as_str() {
        "Observation" => {
            engine.observation(robot, &m.data, m.log_time).ok();
        }
        "RobotStatus" => {
            engine.status(robot, &m.data, m.log_time).ok();
        }
        _ => {}
    }
}

/// Re-fuses a log up to any time, remembering snapshots on the way so that later seeks
/// start near their target.
#[derive(Debug, Clone)]
pub struct Seeker {
    cfg: EngineConfig,
    keys: KeySpace,
    /// (index of the first message not fed, the engine after the ones before), by index.
    snapshots: Vec<(usize, Engine)>,
}

impl Seeker {
    pub fn new(cfg: EngineConfig, keys: KeySpace) -> Self {
        Seeker {
            cfg,
            keys,
            snapshots: Vec::new(),
        }
    }

    /// The engine after every input message logged at or before `at`, and the index of the
    /// first message after `at`.
    pub fn engine_at(&mut self, messages: &[LogMessage], at: Stamp) -> (Engine, usize) {
        let end = messages.partition_point(|m| m.log_time <= at);
        let (mut next, mut engine) = match self.snapshots.iter().rev().find(|(i, _)| *i <= end) {
            Some((i, e)) => (*i, e.clone()),
            None => (0, Engine::new(self.cfg.clone())),
        };
        let mut last_snapshot_at = messages.get(next).map(|m| m.log_time);
        while next < end {
            let m = &messages[next];
            if last_snapshot_at.is_some_and(|s| m.log_time.secs_since(s) >= SNAPSHOT_EVERY_S) {
                self.remember(next, &engine);
                last_snapshot_at = Some(m.log_time);
            }
            feed(&mut engine, &self.keys, m);
            next += 1;
        }
        (engine, end)
    }

    fn remember(&mut self, index: usize, engine: &Engine) {
        if let Err(pos) = self.snapshots.binary_search_by_key(&index, |(i, _)| *i) {
            self.snapshots.insert(pos, (index, engine.clone()));
        }
    }

    /// Snapshots kept so far.
    #[cfg(test)]
    pub fn snapshots(&self) -> usize {
        self.snapshots.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::matchlog::record::test_support::T0_NS;
    use proto::{Camera, Observation, Pose2};

    /// `seconds` of one robot seeing a ball roll slowly along x at 10 Hz.
    fn log(seconds: f64) -> Vec<LogMessage> {
        (0..(seconds * 10.0) as u64)
            .map(|i| {
                let at = Stamp(T0_NS).offset_secs(i as f64 / 10.0);
                let obs = Observation {
                    version: proto::VERSION,
                    robot_id: "r1".into(),
                    seq: i,
                    camera: Camera::Left,
                    stamp: at.offset_secs(-0.02),
                    position_m: [-1.5 + 0.001 * i as f64, 0.1],
                    covariance_m2: [1e-4, 0.0, 0.0, 1e-4],
                    confidence: 0.9,
                    robot_pose: Pose2::default(),
                    pixel: None,
                };
                LogMessage {
                    topic: "rf/robots/r1/obs".into(),
                    schema_name: "Observation".into(),
                    log_time: at,
                    publish_time: at,
                    data: proto::encode(&obs),
                }
            })
            .collect()
    }

    #[test]
    fn a_seek_from_a_snapshot_equals_re_fusing_from_the_start() {
        let messages = log(70.0);
        let keys = KeySpace::default();
        let at = |t_s: f64| Stamp(T0_NS).offset_secs(t_s);
        let mut seeker = Seeker::new(EngineConfig::default(), keys.clone());
        let (late, index) = seeker.engine_at(&messages, at(65.0));
        assert_eq!(index, 651);
        assert_eq!(late.counters().observations_accepted, 651);
        assert_eq!(seeker.snapshots(), 3, "every {SNAPSHOT_EVERY_S} s");
        // Back to 45 s: from the snapshot at 40 s, the same engine as from the start.
        let (from_snapshot, index) = seeker.engine_at(&messages, at(45.05));
        assert_eq!(index, 451);
        let (fresh, _) = Seeker::new(EngineConfig::default(), keys).engine_at(&messages, at(45.05));
        assert_eq!(
            from_snapshot.ball_state(at(45.1)),
            fresh.ball_state(at(45.1))
        );
        assert_eq!(
            from_snapshot.counters().observations_accepted,
            fresh.counters().observations_accepted
        );
        // Before the first message: nothing fed.
        let (empty, index) = seeker.engine_at(&messages, at(-1.0));
        assert_eq!(index, 0);
        assert!(empty.ball_state(at(0.0)).is_none());
    }
}
