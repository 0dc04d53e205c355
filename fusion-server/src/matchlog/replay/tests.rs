use super::*;
use crate::matchlog::record::test_support::{T0_NS, logged_observation};
use proto::Observation;

const T0: Stamp = Stamp(T0_NS);

/// An observation of `robot` captured 20 ms before `log_s`, as logged at `log_s`.
fn obs_message(robot: &str, seq: u64, log_s: f64, position_m: [f64; 2]) -> LogMessage {
    logged_observation(robot, seq, T0.offset_secs(log_s), 0.02, position_m)
}

/// Half a second of a ball rolling along x, seen by two robots at 50 Hz each.
fn rolling_ball() -> Vec<LogMessage> {
    (0..50)
        .map(|i| {
            let t_s = 0.01 * i as f64;
            let robot = if i % 2 == 0 { "r1" } else { "r2" };
            obs_message(robot, i, t_s, [0.5 * t_s, 0.2])
        })
        .collect()
}

/// Every state handed to the sink, and every state written.
#[derive(Debug, Default)]
struct Capture {
    asked: Vec<(Stamp, Option<BallState>)>,
    written: Vec<(Stamp, Vec<u8>)>,
}

impl ReplaySink for Capture {
    fn write(&mut self, _: &str, schema: &str, log_time: Stamp, payload: &[u8]) {
        if schema == "BallState" {
            self.written.push((log_time, payload.to_vec()));
        }
    }

    fn state(&mut self, at: Stamp, state: Option<&BallState>) {
        self.asked.push((at, state.cloned()));
    }
}

fn run(messages: &[LogMessage], opts: &ReplayOptions) -> (ReplayReport, Capture) {
    let mut sink = Capture::default();
    match replay(messages, opts, &mut sink, &mut |_, _| {}) {
        Ok(report) => (report, sink),
        Err(e) => panic!("replay failed: {e}"),
    }
}

#[test]
fn states_come_at_exactly_the_asked_times_also_after_the_log() {
    let at = vec![
        TimeArg::AfterFirst { secs: 2.0 },
        TimeArg::AfterFirst { secs: 0.25 },
        TimeArg::Stamp(T0.offset_secs(0.4)),
        TimeArg::AfterFirst { secs: 0.25 },
    ];
    let opts = ReplayOptions {
        at,
        ..ReplayOptions::default()
    };
    let (report, sink) = run(&rolling_ball(), &opts);
    let want: Vec<Stamp> = [0.25, 0.4, 2.0]
        .iter()
        .map(|s| T0.offset_secs(*s))
        .collect();
    let asked: Vec<Stamp> = sink.asked.iter().map(|(t, _)| *t).collect();
    assert_eq!(asked, want, "sorted, each once, the grid off");
    let written: Vec<Stamp> = sink.written.iter().map(|(t, _)| *t).collect();
    assert_eq!(written, want);
    assert_eq!(report.states_written, 3);
    for (t, state) in &sink.asked {
        let s = state.as_ref().expect("an estimate");
        // The core's time axis is f64 seconds: tens of nanoseconds.
        assert!(s.stamp.secs_since(*t).abs() < 1e-6, "{t:?}: {:?}", s.stamp);
    }
    // 1.5 s after the last sighting the ball is predicted on, rolling out to its stop.
    let after = sink.asked[2].1.as_ref().expect("the last state");
    assert_eq!(after.status, proto::BallStatus::Coasting);
    assert!(after.position_m[0] > 0.3, "{:?}", after.position_m);
}

#[test]
fn a_grid_through_a_stamp_runs_on_to_until() {
    let opts = ReplayOptions {
        state_rate_hz: 10.0,
        align: Some(TimeArg::Stamp(T0.offset_secs(0.005))),
        until: Some(TimeArg::AfterFirst { secs: 1.0 }),
        ..ReplayOptions::default()
    };
    let (report, sink) = run(&rolling_ball(), &opts);
    let want: Vec<Stamp> = (0..10)
        .map(|k| T0.offset_secs(0.005).offset_secs(0.1 * k as f64))
        .collect();
    let asked: Vec<Stamp> = sink.asked.iter().map(|(t, _)| *t).collect();
    assert_eq!(asked, want);
    // The first one comes before the ball is found (one sighting so far).
    assert!(sink.asked[0].1.is_none());
    assert_eq!(report.states_without_estimate, 1);
    assert_eq!(report.states_written, 9);
}

#[test]
fn without_recorded_states_the_grid_starts_at_the_first_message_and_ends_with_the_log() {
    let opts = ReplayOptions {
        state_rate_hz: 20.0,
        ..ReplayOptions::default()
    };
    let (_, sink) = run(&rolling_ball(), &opts);
    let asked: Vec<Stamp> = sink.asked.iter().map(|(t, _)| *t).collect();
    let want: Vec<Stamp> = (0..10).map(|k| T0.offset_secs(0.05 * k as f64)).collect();
    assert_eq!(asked, want, "the last message is at 0.49 s");
}

#[test]
fn recorded_states_are_still_compared_and_asked_ones_added() {
    // A log with states: the first replay's, at 20 Hz, recorded among the messages.
    let mut messages = rolling_ball();
    let first = ReplayOptions {
        state_rate_hz: 20.0,
        ..ReplayOptions::default()
    };
    let (_, sink) = run(&messages, &first);
    for (t, payload) in &sink.written {
        messages.push(LogMessage {
            topic: "rf/ball/state".into(),
            schema_name: "BallState".into(),
            log_time: *t,
            publish_time: *t,
            data: payload.clone(),
        });
    }
    messages.sort_by_key(|m| m.log_time);
    let recorded = sink.written.len() as u64;

    let (report, sink) = run(&messages, &ReplayOptions::default());
    assert_eq!(report.states_recorded, recorded);
    assert_eq!(report.states_identical, recorded);
    assert_eq!(sink.written.len() as u64, recorded, "no grid over them");
    assert_eq!(sink.asked.len() as u64, recorded, "they are the replay's");

    let asked = ReplayOptions {
        at: vec![TimeArg::AfterFirst { secs: 0.33 }],
        ..ReplayOptions::default()
    };
    let (report, sink) = run(&messages, &asked);
    assert_eq!(report.states_identical, recorded);
    assert_eq!(report.states_written, recorded + 1);
    assert_eq!(
        sink.written.len() as u64,
        recorded + 1,
        "all in the new log"
    );
    let handed: Vec<Stamp> = sink.asked.iter().map(|(t, _)| *t).collect();
    assert_eq!(handed, vec![T0.offset_secs(0.33)], "only the asked one");
}

#[test]
fn observations_beyond_a_wall_are_counted_and_shown() {
    let mut messages = rolling_ball();
    // 0.39 m beyond the x_max wall, near enough to the pitch to pass validation.
    messages.push(obs_message("r1", 99, 0.495, [2.3, 0.0]));
    let (report, _) = run(&messages, &ReplayOptions::default());
    assert_eq!(report.observations_accepted, 51);
    assert_eq!(report.fusion.outside_walls, 1);
    let json = summary_json(&report, 0.1, &ReplayOutputs::default());
    assert_eq!(json["observations_outside_walls"], 1);
    for key in [
        "observations_reordered",
        "observations_replayed",
        "observations_held",
        "kicks_inferred",
        "bounces_seen",
        "walls",
        "states_without_estimate",
        "model",
    ] {
        assert!(json.get(key).is_some(), "{key} in {json}");
    }
    let text = summary_text(&report, 0.1);
    assert!(
        text.contains("  beyond a wall     1 accepted, ignored by the tracker"),
        "{text}"
    );

    // Without the x walls the same observation is fused.
    let mut open = ReplayOptions::default();
    open.engine.fusion.pitch.walls = vec![proto::WallSide::YMax, proto::WallSide::YMin];
    let (report, _) = run(&messages, &open);
    assert_eq!(report.fusion.outside_walls, 0);
}

#[test]
fn reordered_observations_are_in_the_summary() {
    let mut messages = rolling_ball();
    // Captured 0.1 s earlier than the last one before it: slotted in, later ones re-applied.
    let mut late = obs_message("r2", 77, 0.3, [0.1, 0.2]);
    let mut obs: Observation = proto::decode(&late.data).expect("decodes");
    obs.stamp = T0.offset_secs(0.2);
    late.data = proto::encode(&obs);
    messages.push(late);
    messages.sort_by_key(|m| m.log_time);
    let (report, _) = run(&messages, &ReplayOptions::default());
    assert_eq!(report.fusion.reordered, 1);
    assert!(report.fusion.replayed > 0, "{:?}", report.fusion);
    let json = summary_json(&report, 0.1, &ReplayOutputs::default());
    assert_eq!(json["observations_reordered"], 1);
    assert_eq!(json["observations_replayed"], report.fusion.replayed);
    assert!(summary_text(&report, 0.1).contains("out of order      1 slotted in"));
}

/// A replay whose sink keeps nothing (`replay --no-log`) skips encoding the states but
/// reports the same: the same states with an estimate, the same fusion.
#[test]
fn a_replay_nobody_reads_reports_the_same() {
    let opts = ReplayOptions::default();
    let (kept, sink) = run(&rolling_ball(), &opts);
    let unread = match replay(&rolling_ball(), &opts, &mut (), &mut |_, _| {}) {
        Ok(r) => r,
        Err(e) => panic!("replay failed: {e}"),
    };
    assert!(kept.states_written > 10, "{kept:?}");
    assert_eq!(kept.states_written, sink.written.len() as u64);
    assert_eq!(unread, kept);
}

/// Every scene update written.
#[derive(Debug, Default)]
struct Scenes(Vec<Vec<u8>>);

impl ReplaySink for Scenes {
    fn write(&mut self, topic: &str, _: &str, _: Stamp, payload: &[u8]) {
        if topic == crate::scene::SCENE_TOPIC {
            self.0.push(payload.to_vec());
        }
    }
}

#[test]
fn a_replayed_log_draws_its_robots_online_and_its_scene_ten_times_a_second() {
    use foxglove::Decode;
    let opts = ReplayOptions {
        scene: true,
        ..ReplayOptions::default()
    };
    let mut scenes = Scenes::default();
    let report = replay(&rolling_ball(), &opts, &mut scenes, &mut |_, _| {}).expect("replay");
    // Half a second of states at 30 Hz: an update every 0.1 s, not every fourth state.
    assert!(scenes.0.len() >= 5, "{} updates", scenes.0.len());
    assert_eq!(report.scene_written as usize, scenes.0.len() * 2 + 1);
    let last = foxglove::messages::SceneUpdate::decode(scenes.0[scenes.0.len() - 1].as_slice())
        .expect("a scene update");
    let labels: Vec<String> = last
        .entities
        .iter()
        .flat_map(|e| e.texts.iter().map(|t| t.text.clone()))
        .collect();
    for robot in ["r1", "r2"] {
        assert!(labels.iter().any(|l| l.starts_with(robot)), "{labels:?}");
    }
    assert!(
        labels.iter().all(|l| !l.contains("(offline)")),
        "robots that send are online: {labels:?}"
    );
}
