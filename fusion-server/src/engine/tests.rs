use super::*;
use proto::test_support::observation;
use proto::{Camera, Observation, Pose2};
use std::collections::BTreeSet;

const T0: u64 = 1_800_000_000_000_000_000;

fn at(t_s: f64) -> Stamp {
    Stamp(T0).offset_secs(t_s)
}

fn obs(robot: &str, seq: u64, t_s: f64, x_m: f64) -> Observation {
    Observation {
        robot_pose: Pose2 {
            x_m: -1.0,
            y_m: 0.5,
            theta_rad: 0.0,
        },
        ..observation(robot, seq, at(t_s), [x_m, 0.2])
    }
}

fn feed(e: &mut Engine, robot: &str, n: u64) {
    for k in 0..n {
        let t = k as f64 / 15.0;
        let o = obs(robot, k, t, 0.3 * t);
        let r = e.observation(Some(robot), &proto::encode(&o), at(t + 0.05));
        assert!(r.is_ok(), "{r:?}");
    }
}

fn rejected(e: &Engine, reason: &str) -> u64 {
    e.counters()
        .rejected
        .iter()
        .filter(|((_, r), _)| *r == reason)
        .map(|(_, n)| n)
        .sum()
}

#[test]
fn good_observations_make_a_ball_state_and_a_robot() {
    let mut e = Engine::new(EngineConfig::default());
    feed(&mut e, "miro1", 30);
    assert_eq!(e.counters().observations_accepted, 30);
    let s = e.ball_state(at(2.0)).expect("a ball");
    assert!((s.position_m[0] - 0.6).abs() < 0.05, "{:?}", s.position_m);
    let robots = e.robots(at(2.0));
    assert_eq!(robots.len(), 1);
    assert_eq!(robots[0].observations_accepted, 30);
    assert!(robots[0].obs_rate_hz > 3.0, "{}", robots[0].obs_rate_hz);
}

#[test]
fn every_kind_of_bad_input_is_counted_and_good_input_keeps_flowing() {
    let mut e = Engine::new(EngineConfig {
        roster: Some(BTreeSet::from(["miro1".to_string()])),
        ..EngineConfig::default()
    });
    let now = at(0.1);
    let good = obs("miro1", 0, 0.0, 0.0);
    let mut wrong_version = serde_json::to_value(&good).expect("json");
    wrong_version["version"] = 7.into();
    let mut not_pd = good.clone();
    not_pd.covariance_m2 = [1e-4, 0.0, 0.0, -1e-4];
    let mut absurd = good.clone();
    absurd.stamp = Stamp(5);
    let stranger = obs("miro9", 0, 0.0, 0.0);
    let cases: Vec<(Vec<u8>, &str, &str)> = vec![
        (b"not json".to_vec(), "miro1", "not_json"),
        (b"{}".to_vec(), "miro1", "no_version"),
        (wrong_version.to_string().into_bytes(), "miro1", "version"),
        (proto::encode(&not_pd), "miro1", "covariance_not_pd"),
        (proto::encode(&absurd), "miro1", "stamp"),
        (proto::encode(&stranger), "miro9", "unknown_robot"),
        (proto::encode(&good), "miro2", "key_mismatch"),
        (proto::encode(&good), "not.an.id", "key_robot_id"),
    ];
    for (payload, key, reason) in &cases {
        let r = e.observation(Some(key), payload, now);
        let err = r.expect_err(reason);
        assert_eq!(err.reason(), *reason, "{err}");
        assert_eq!(rejected(&e, reason), 1, "{reason}");
    }
    feed(&mut e, "miro1", 10);
    assert_eq!(e.counters().observations_accepted, 10);
    assert!(e.robots(at(1.0)).iter().all(|r| r.robot_id != "miro9"));
    // The same observation twice is a duplicate, counted as such.
    let dup = obs("miro1", 3, 3.0 / 15.0, 0.3 * 3.0 / 15.0);
    let r = e.observation(Some("miro1"), &proto::encode(&dup), at(0.7));
    assert_eq!(r.expect_err("dup").reason(), "duplicate");
}

#[test]
fn statuses_and_liveliness_update_the_roster() {
    let mut e = Engine::new(EngineConfig::default());
    assert!(e.liveliness("miro1", true, at(0.0)).is_ok());
    assert!(e.liveliness("bad/id", true, at(0.0)).is_err());
    let status = proto::RobotStatus {
        version: proto::VERSION,
        robot_id: "miro1".into(),
        stamp: at(0.5),
        pose: Pose2 {
            x_m: 1.0,
            y_m: -0.5,
            theta_rad: 0.3,
        },
        pose_covariance: [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-3],
        head: proto::HeadJoints::default(),
        fps: 15.0,
        timings: vec![],
        footprints: vec![],
        cameras: vec![],
    };
    assert!(
        e.status(Some("miro1"), &proto::encode(&status), at(0.5))
            .is_ok()
    );
    let r = &e.robots(at(1.0))[0];
    assert!(r.online);
    assert_eq!(r.pose.map(|p| p.x_m), Some(1.0));
    assert!((r.since_s.unwrap_or(0.0) - 1.0).abs() < 1e-9);
    assert!(e.liveliness("miro1", false, at(2.0)).is_ok());
    assert!(!e.robots(at(2.5))[0].online);
}

#[test]
fn queries_answer_predictions_and_intercepts() {
    let mut e = Engine::new(EngineConfig::default());
    let q = BallQuery::Predict { horizon_s: 1.0 };
    assert_eq!(e.query(&q, at(0.0)), Err(QueryError::NoEstimate));
    feed(&mut e, "miro1", 30);
    match e.query(&q, at(2.0)) {
        Ok(QueryReply::Prediction(p)) => assert!((p.horizon_s - 1.0).abs() < 1e-12),
        other => panic!("{other:?}"),
    }
    let icpt = BallQuery::Intercept {
        robot_id: "miro1".into(),
        speed_mps: Some(0.4),
    };
    match e.query(&icpt, at(2.0)) {
        Ok(QueryReply::Intercept(i)) => {
            assert_eq!(i.robot_id, "miro1");
            assert!(i.t_s > 0.0 && i.t_s.is_finite());
            let p = i.probability.expect("the intercept says how likely");
            assert!((0.0..=1.0).contains(&p), "{p}");
            // The same robot, far slower, meets the ball no earlier.
            let slow = BallQuery::Intercept {
                robot_id: "miro1".into(),
                speed_mps: Some(0.01),
            };
            match e.query(&slow, at(2.0)) {
                Ok(QueryReply::Intercept(j)) => assert!(j.t_s >= i.t_s, "{j:?} {i:?}"),
                other => panic!("{other:?}"),
            }
        }
        other => panic!("{other:?}"),
    }
    let nobody = BallQuery::Intercept {
        robot_id: "ghost".into(),
        speed_mps: None,
    };
    assert_eq!(
        e.query(&nobody, at(2.0)),
        Err(QueryError::UnknownRobot("ghost".into()))
    );
}

#[test]
fn made_up_robots_cannot_grow_the_roster_without_bound() {
    let mut e = Engine::new(EngineConfig::default());
    for k in 0..(MAX_ROBOTS + 10) {
        let id = format!("r{k}");
        let _ = e.liveliness(&id, true, at(0.0));
    }
    assert_eq!(e.robots(at(0.0)).len(), MAX_ROBOTS);
    // A newcomer takes the place of one that has sent nothing; the table stays bounded.
    let o = obs("latecomer", 0, 0.0, 0.0);
    let r = e.observation(Some("latecomer"), &proto::encode(&o), at(0.05));
    assert!(r.is_ok(), "{r:?}");
    assert_eq!(e.robots(at(0.05)).len(), MAX_ROBOTS);
    assert_eq!(e.counters().robots_evicted, 11);
}

#[test]
fn a_burst_of_made_up_ids_takes_no_place_from_robots_that_are_fusing() {
    let mut e = Engine::new(EngineConfig::default());
    let established = e.config().admission.established_messages;
    // Five honest robots, fusing for a while.
    for k in 0..established {
        for r in 0..5 {
            let id = format!("honest{r}");
            let o = obs(&id, k, k as f64 * 0.05, 0.2);
            let got = e.observation(Some(&id), &proto::encode(&o), at(k as f64 * 0.05 + 0.01));
            assert!(got.is_ok(), "{got:?}");
        }
    }
    // A burst of 300 made-up ids, one valid observation each, within 0.3 s.
    let t = established as f64 * 0.05;
    for k in 0..300u64 {
        let id = format!("fake{k}");
        let at_s = t + k as f64 * 0.001;
        let o = obs(&id, 0, at_s, 0.2);
        let _ = e.observation(Some(&id), &proto::encode(&o), at(at_s + 0.001));
    }
    assert_eq!(e.robots(at(t + 0.3)).len(), MAX_ROBOTS);
    // The honest robots kept their places and are accepted at once, and so is a robot
    // arriving after the burst.
    let after = t + 0.35;
    for r in 0..5 {
        let id = format!("honest{r}");
        let o = obs(&id, established, after, 0.2);
        let got = e.observation(Some(&id), &proto::encode(&o), at(after + 0.01));
        assert!(got.is_ok(), "{id}: {got:?}");
    }
    let o = obs("newcomer", 0, after, 0.2);
    let got = e.observation(Some("newcomer"), &proto::encode(&o), at(after + 0.01));
    assert!(got.is_ok(), "{got:?}");
    assert_eq!(rejected(&e, "too_many_robots"), 0);
    assert!(e.counters().robots_evicted >= 300 - (MAX_ROBOTS as u64 - 5));
}

#[test]
fn a_table_of_established_robots_refuses_a_newcomer() {
    let mut e = Engine::new(EngineConfig {
        admission: AdmissionConfig {
            established_messages: 1,
            ..AdmissionConfig::default()
        },
        ..EngineConfig::default()
    });
    for k in 0..MAX_ROBOTS {
        let id = format!("r{k}");
        let o = obs(&id, 0, 0.0, 0.2);
        assert!(
            e.observation(Some(&id), &proto::encode(&o), at(0.01))
                .is_ok()
        );
    }
    let o = obs("latecomer", 0, 0.5, 0.0);
    let r = e.observation(Some("latecomer"), &proto::encode(&o), at(0.55));
    assert_eq!(r.expect_err("full").reason(), "too_many_robots");
    // Known robots still get through.
    let o = obs("r1", 1, 0.5, 0.2);
    assert!(
        e.observation(Some("r1"), &proto::encode(&o), at(0.55))
            .is_ok()
    );
}

#[test]
fn robots_gone_quiet_give_their_room_to_newcomers() {
    let mut e = Engine::new(EngineConfig {
        admission: AdmissionConfig {
            established_messages: 1,
            ..AdmissionConfig::default()
        },
        ..EngineConfig::default()
    });
    let expiry_s = e.config().admission.robot_expiry_s;
    // Robots that sent something fill the table...
    for k in 0..MAX_ROBOTS {
        let id = format!("r{k}");
        let o = obs(&id, 0, 0.0, 0.2);
        assert!(
            e.observation(Some(&id), &proto::encode(&o), at(0.01))
                .is_ok()
        );
    }
    let o = obs("latecomer", 0, expiry_s * 0.5, 0.0);
    let r = e.observation(Some("latecomer"), &proto::encode(&o), at(expiry_s * 0.5));
    assert_eq!(r.expect_err("full").reason(), "too_many_robots");
    // ... only until they have been quiet for the expiry time.
    let t = expiry_s + 0.5;
    let o = obs("latecomer", 1, t, 0.0);
    let r = e.observation(Some("latecomer"), &proto::encode(&o), at(t + 0.05));
    assert!(r.is_ok(), "{r:?}");
    assert_eq!(e.robots(at(t)).len(), 1);
}

#[test]
fn offline_robots_are_forgotten_after_the_expiry_time() {
    let mut e = Engine::new(EngineConfig::default());
    let expiry_s = e.config().admission.robot_expiry_s;
    feed(&mut e, "miro1", 5);
    e.liveliness("miro2", true, at(0.0)).expect("room");
    // miro2 stays online (its token is there) though quiet; miro1 never had a token.
    feed(&mut e, "miro3", 1);
    let t = expiry_s + 2.0;
    let o = obs("miro3", 100, t, 0.0);
    assert!(
        e.observation(Some("miro3"), &proto::encode(&o), at(t))
            .is_ok()
    );
    let ids: Vec<String> = e.robots(at(t)).into_iter().map(|r| r.robot_id).collect();
    assert_eq!(ids, ["miro2", "miro3"]);
}

#[test]
fn a_robot_flooding_is_rate_limited_and_the_others_are_not() {
    let mut e = Engine::new(EngineConfig::default());
    let burst = e.config().admission.rate_burst;
    feed(&mut e, "miro2", 1);
    let now = at(0.1);
    let mut accepted = 0;
    for seq in 0..(2 * burst as u64) {
        let o = obs("miro1", seq, 0.05, 0.1);
        if e.observation(Some("miro1"), &proto::encode(&o), now)
            .is_ok()
        {
            accepted += 1;
        }
    }
    // The first one admits the robot with a full bucket; the burst follows.
    assert!(accepted <= burst as u64 + 1, "{accepted}");
    assert!(rejected(&e, "rate_limited") >= burst as u64 - 1);
    let o = obs("miro2", 50, 0.09, 0.1);
    assert!(
        e.observation(Some("miro2"), &proto::encode(&o), now)
            .is_ok()
    );
}

/// The largest status validation accepts, every number at full precision, fits the
/// default byte cap: the cap never refuses a status validation would take.
#[test]
fn the_largest_valid_status_fits_the_byte_cap() {
    let v = -1.234_567_890_123_456_7;
    let status = proto::RobotStatus {
        version: proto::VERSION,
        robot_id: "r".repeat(64),
        stamp: at(0.0),
        pose: Pose2 {
            x_m: v,
            y_m: v,
            theta_rad: v,
        },
        pose_covariance: [v; 9],
        head: proto::HeadJoints {
            lift_rad: v,
            yaw_rad: v,
            pitch_rad: v,
        },
        fps: 1_234.567_890_123_456_7,
        timings: vec![
            proto::StageTiming {
                stage: "s".repeat(proto::MAX_STAGE_NAME_BYTES),
                ms: 12_345.678_901_234_567,
            };
            proto::MAX_STATUS_TIMINGS
        ],
        footprints: vec![
            proto::CameraFootprint {
                camera: Camera::Right,
                polygon_m: vec![[v, v]; proto::MAX_FOOTPRINT_POINTS],
            };
            proto::MAX_STATUS_FOOTPRINTS
        ],
        cameras: vec![
            proto::CameraPerception {
                camera: Camera::Right,
                frames: u64::MAX,
                candidates: u64::MAX,
                balls: u64::MAX,
                rejections: (0..proto::MAX_REJECTION_REASONS)
                    .map(|k| (format!("{k:0>w$}", w = proto::MAX_REASON_BYTES), u64::MAX))
                    .collect(),
                frames_per_s: v,
                candidates_per_frame: v,
                balls_per_s: v,
                detector_ms: v,
            };
            proto::MAX_STATUS_FOOTPRINTS
        ],
    };
    let bytes = proto::encode(&status).len();
    assert!(bytes <= DEFAULT_MAX_STATUS_BYTES, "{bytes}");
}

/// Two robots watch a ball rolling along +x at 1 m/s (no friction in this picture: its
/// deceleration is learned, the short run keeps it near the start value); robot `fast`'s
/// clock is `ahead_s` ahead of the server's. Every observation arrives 20–40 ms after its
/// capture. Returns the served along-track error at t (from the true position) and the
/// engine.
fn skewed_pair(ahead_s: f64, cfg: EngineConfig, until_s: f64) -> (f64, Engine) {
    let mut e = Engine::new(cfg);
    let truth = |t: f64| -1.0 + t;
    let mut k = 0u64;
    while (k as f64) / 30.0 < until_s {
        let t = k as f64 / 30.0;
        for (robot, skew) in [("honest", 0.0), ("fast", ahead_s)] {
            let o = Observation {
                robot_pose: Pose2 {
                    x_m: 0.0,
                    y_m: -1.0,
                    theta_rad: 1.57,
                },
                ..observation(robot, k, at(t + skew), [truth(t), 0.0])
            };
            let latency_s = 0.02 + 0.02 * (k % 3) as f64 / 2.0;
            let r = e.observation_decoded(Some(robot), o, at(t + latency_s));
            assert!(r.is_ok(), "{r:?}");
        }
        k += 1;
    }
    let t = until_s;
    let s = e.ball_state(at(t)).expect("a ball");
    (s.position_m[0] - truth(t), e)
}

#[test]
fn a_robot_clock_200_ms_fast_is_corrected_logged_and_counted() {
    let (bias_m, mut e) = skewed_pair(0.2, EngineConfig::default(), 2.0);
    assert!(bias_m.abs() < 0.03, "along-track bias {bias_m} m");
    let robots = e.robots(at(2.0));
    let fast = robots.iter().find(|r| r.robot_id == "fast").expect("fast");
    assert!((fast.clock_correction_s + 0.2).abs() < 0.005, "{fast:?}");
    assert!(fast.clock_suspect);
    let honest = robots
        .iter()
        .find(|r| r.robot_id == "honest")
        .expect("honest");
    assert_eq!(honest.clock_correction_s, 0.0);
    assert!(e.counters().observations_clock_corrected > 0);
    let events = e.take_events();
    assert!(
        events
            .iter()
            .any(|ev| matches!(ev, EngineEvent::ClockCorrected { robot, .. } if robot == "fast")),
        "{events:?}"
    );
    assert!(e.take_events().is_empty(), "events are taken once");
    // Uncorrected, the same robot drags the ball behind (its stamps say it was seen later).
    let off = EngineConfig {
        clock: ClockCheck {
            correct: false,
            ..ClockCheck::default()
        },
        ..EngineConfig::default()
    };
    let (bias_off_m, _) = skewed_pair(0.2, off, 2.0);
    assert!(bias_off_m.abs() > 0.05, "uncorrected bias {bias_off_m} m");
}

#[test]
fn a_clock_that_jumps_is_caught_and_the_ball_is_unharmed() {
    let mut e = Engine::new(EngineConfig::default());
    let mut jumps_seen = 0;
    for k in 0..240u64 {
        let t = k as f64 / 30.0;
        // Robot `jumpy` jumps 0.5 s ahead at 2 s and back at 5 s.
        let skew = if (2.0..5.0).contains(&t) { 0.5 } else { 0.0 };
        for (robot, s) in [("honest", 0.0), ("jumpy", skew)] {
            let o = observation(robot, k, at(t + s), [0.5, 0.2]);
            e.observation_decoded(Some(robot), o, at(t + 0.03)).ok();
        }
        jumps_seen += e
            .take_events()
            .iter()
            .filter(|ev| matches!(ev, EngineEvent::ClockJumped { .. }))
            .count();
    }
    assert_eq!(e.counters().clock_jumps, 2);
    assert_eq!(jumps_seen, 2);
    let s = e.ball_state(at(8.0)).expect("a ball");
    assert!(
        (s.position_m[0] - 0.5).abs() < 0.03 && (s.position_m[1] - 0.2).abs() < 0.03,
        "{s:?}"
    );
    let jumpy = e
        .robots(at(8.0))
        .into_iter()
        .find(|r| r.robot_id == "jumpy")
        .expect("jumpy");
    assert_eq!(jumpy.clock_correction_s, 0.0, "{jumpy:?}");
}
