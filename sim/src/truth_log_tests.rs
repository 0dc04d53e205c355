//! Ground truth through a log and back: the rebuilt run equals the original field by field
//! and scores the same.

use crate::score::{HORIZONS_S, TickRecord, score, tick_count, tick_times_s};
use crate::truth_log::{
    BALL_TOPIC, KINDS_TOPIC, ROBOTS_TOPIC, RUN_TOPIC, RobotPose, RobotPoses, TOPICS,
    TruthLogBuilder, TruthLogError, truth_messages, truth_schemas,
};
use crate::{BallEvent, ObsKind, SimConfig, SimRun, run_scenario};
use proto::{Observation, Pose2, Stamp};

fn short_run(name: &str) -> SimRun {
    let cfg = SimConfig {
        duration_s: Some(10.0),
        ..SimConfig::default()
    };
    run_scenario(name, 1, &cfg).unwrap_or_else(|e| panic!("{e}"))
}

/// The observations as a log holds them: encoded, decoded, with their arrival stamps, and
/// in reverse order (the builder restores the simulator's order).
fn logged_observations(run: &SimRun) -> Vec<(Stamp, Observation)> {
    run.deliveries
        .iter()
        .rev()
        .map(|d| {
            let obs = proto::decode(&proto::encode(&d.obs)).unwrap_or_else(|e| panic!("{e}"));
            (d.arrival, obs)
        })
        .collect()
}

/// Writes the run's truth as messages and reads it back.
fn through_log(run: &SimRun) -> SimRun {
    let mut builder = TruthLogBuilder::new();
    let messages = truth_messages(run);
    assert!(messages.windows(2).all(|w| w[0].log_time <= w[1].log_time));
    assert_eq!(messages[0].topic, RUN_TOPIC);
    for m in &messages {
        assert!(TOPICS.contains(&m.topic));
        builder
            .push(m.topic, &m.json)
            .unwrap_or_else(|e| panic!("{e}"));
    }
    assert!(builder.has_run());
    builder
        .finish(logged_observations(run))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// The truth shifted by `dx_m` along x, with the true stop point and the next bounce 20 ms
/// late: a method that is close but not exact.
fn shifted_truth(run: &SimRun, dx_m: f64) -> Vec<TickRecord> {
    let shift = |p: [f64; 2]| [p[0] + dx_m, p[1]];
    tick_times_s(run.duration_s)
        .map(|t_s| {
            let truth = run.truth_at(t_s);
            let stop = run.events.iter().find_map(|e| match e {
                BallEvent::Stopped {
                    t_s: ts,
                    position_m,
                } if *ts > t_s => Some((*ts, shift(*position_m))),
                _ => None,
            });
            let first_bounce_t_s = run.events.iter().find_map(|e| match e {
                BallEvent::WallBounce { t_s: tb, .. } if *tb > t_s => Some(tb + 0.02),
                _ => None,
            });
            TickRecord {
                t_s,
                position: shift(truth.position_m),
                velocity: truth.velocity_mps,
                predicted: HORIZONS_S
                    .iter()
                    .map(|h| shift(run.truth_at(t_s + h).position_m))
                    .collect(),
                stop,
                first_bounce_t_s,
            }
        })
        .collect()
}

fn assert_same_run(a: &SimRun, b: &SimRun) {
    assert_eq!(a.scenario, b.scenario);
    assert_eq!(a.seed, b.seed);
    assert_eq!(a.start, b.start);
    assert_eq!(a.duration_s.to_bits(), b.duration_s.to_bits());
    assert_eq!(a.pitch, b.pitch);
    assert_eq!(a.truth, b.truth);
    assert_eq!(a.robots, b.robots);
    assert_eq!(a.deliveries.len(), b.deliveries.len());
    for (x, y) in a.deliveries.iter().zip(&b.deliveries) {
        assert_eq!(x, y);
    }
    assert_eq!(a.events, b.events);
    assert_eq!(a.params, b.params);
    assert_eq!(a.stats, b.stats);
    assert_eq!(a.phantom, b.phantom);
    assert_eq!(a, b);
}

#[test]
fn a_run_survives_the_log_and_scores_the_same() {
    for name in ["team-rally", "phantom"] {
        let run = short_run(name);
        let kinds = |k: ObsKind| run.deliveries.iter().filter(|d| d.kind == k).count();
        assert!(
            kinds(ObsKind::FalsePositive) + kinds(ObsKind::Phantom) > 0,
            "{name}"
        );
        let rebuilt = through_log(&run);
        assert_same_run(&run, &rebuilt);

        let with = shifted_truth(&run, 0.01);
        let without = shifted_truth(&run, 0.005);
        let n = tick_count(run.duration_s);
        let original = score(&run, &with, n, Some(&without));
        let replayed = score(&rebuilt, &with, n, Some(&without));
        assert_eq!(original, replayed, "{name}");
        assert_eq!(original.ticks, n);
        assert!(!original.bounce_time_err_s.is_empty(), "{name}");
        assert!(!original.stop_err_m.is_empty(), "{name}");
        assert!(original.bounce_horizon_err_m.iter().any(|v| !v.is_empty()));
        if name == "phantom" {
            assert!(kinds(ObsKind::Phantom) > 0);
            assert!(!original.phantom_pull_m.is_empty());
        }
    }
}

#[test]
fn schemas_name_every_message_and_events_are_tagged() {
    let run = short_run("team-rally");
    let schemas = truth_schemas();
    for m in truth_messages(&run) {
        assert!(
            schemas.iter().any(|(n, _)| *n == m.schema_name),
            "{}",
            m.schema_name
        );
    }
    for (name, schema) in &schemas {
        let title = schema.get("title").and_then(|t| t.as_str());
        assert_eq!(title, Some(*name));
    }
    let event = truth_messages(&run)
        .into_iter()
        .find(|m| m.schema_name == "BallEvent")
        .unwrap_or_else(|| panic!("no events"));
    let json = String::from_utf8(event.json).unwrap_or_default();
    assert!(json.starts_with("{\"type\":\"kick\""), "{json}");
}

#[test]
fn bad_logs_are_errors_not_panics() {
    let run = short_run("team-rally");
    let mut b = TruthLogBuilder::new();
    assert!(matches!(
        b.push("sim/other", b"{}"),
        Err(TruthLogError::UnknownTopic(_))
    ));
    for bad in [&b"not json"[..], b"{\"t_s\": 1.0}", b"{}"] {
        assert!(matches!(
            b.push(BALL_TOPIC, bad),
            Err(TruthLogError::Json {
                topic: BALL_TOPIC,
                ..
            })
        ));
    }
    assert!(!b.has_run());
    assert!(matches!(
        b.finish(Vec::new()),
        Err(TruthLogError::MissingRun)
    ));

    let messages = truth_messages(&run);
    let mut b = TruthLogBuilder::new();
    assert!(b.push(RUN_TOPIC, &messages[0].json).is_ok());
    assert!(matches!(
        b.push(RUN_TOPIC, &messages[0].json),
        Err(TruthLogError::DuplicateRun)
    ));

    let mut b = TruthLogBuilder::new();
    assert!(b.push(RUN_TOPIC, &messages[0].json).is_ok());
    let stranger = RobotPoses {
        t_s: 0.0,
        robots: vec![RobotPose {
            id: "nobody".into(),
            pose: Pose2::default(),
        }],
    };
    let json = serde_json::to_vec(&stranger).unwrap_or_default();
    assert!(b.push(ROBOTS_TOPIC, &json).is_ok());
    assert!(matches!(
        b.finish(Vec::new()),
        Err(TruthLogError::UnknownRobot { .. })
    ));
}

#[test]
fn unlabelled_observations_count_as_the_ball() {
    let run = short_run("phantom");
    let mut b = TruthLogBuilder::new();
    for m in truth_messages(&run)
        .iter()
        .filter(|m| m.topic != KINDS_TOPIC)
    {
        b.push(m.topic, &m.json).unwrap_or_else(|e| panic!("{e}"));
    }
    let rebuilt = b
        .finish(logged_observations(&run))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(rebuilt.deliveries.len(), run.deliveries.len());
    assert!(rebuilt.deliveries.iter().all(|d| d.kind == ObsKind::Ball));
}
