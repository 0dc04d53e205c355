#![allow(clippy::unwrap_used)]
use super::*;
use proto::Pose2;
use proto::test_support::{isotropic, observation};

/// A tiny deterministic noise source for synthetic observations.
pub(super) struct Lcg(pub(super) u64);
impl Lcg {
    pub(super) fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64) / ((1u64 << 53) as f64)
    }
    pub(super) fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.uniform().max(1e-12), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

pub(super) const T0: u64 = 1_767_225_600_000_000_000;

pub(super) fn obs(robot: &str, seq: u64, t_s: f64, p: [f64; 2], sigma: f64) -> Observation {
    Observation {
        covariance_m2: isotropic(sigma),
        robot_pose: Pose2 {
            x_m: -1.5,
            y_m: 0.0,
            theta_rad: 0.0,
        },
        ..observation(robot, seq, Stamp(T0).offset_secs(t_s), p)
    }
}

/// A ball rolling along +x from x = −1 at 1 m/s with 0.3 m/s² deceleration, seen by
/// three robots at 15 Hz each with 2 cm noise.
fn rolling_observations(n_per_robot: usize) -> Vec<Observation> {
    let mut rng = Lcg(42);
    let mut out = Vec::new();
    for k in 0..n_per_robot {
        for (r, robot) in ["a", "b", "c"].iter().enumerate() {
            let t = k as f64 / 15.0 + r as f64 * 0.02;
            let s = (1.0 * t - 0.15 * t * t).max(0.0);
            let p = [-1.0 + s + 0.02 * rng.normal(), 0.3 + 0.02 * rng.normal()];
            out.push(obs(robot, k as u64, t, p, 0.02));
        }
    }
    out
}

#[test]
fn follows_a_rolling_ball() {
    let mut f = Fusion::new(FusionConfig::default());
    let all = rolling_observations(30);
    for o in &all {
        f.ingest(o, o.stamp);
    }
    let t = 29.0 / 15.0 + 0.04;
    let st = f.ball_state(Stamp(T0).offset_secs(t)).expect("a state");
    let truth_x = -1.0 + t - 0.15 * t * t;
    assert!(
        (st.position_m[0] - truth_x).abs() < 0.03,
        "{:?} vs {truth_x}",
        st.position_m
    );
    assert!(
        (st.velocity_mps[0] - (1.0 - 0.3 * t)).abs() < 0.08,
        "{:?}",
        st.velocity_mps
    );
    assert_eq!(st.status, BallStatus::Tracking);
    assert_eq!(st.contributors.len(), 3);
}

#[test]
fn late_observations_give_the_in_order_estimate() {
    let ordered = rolling_observations(20);
    let mut in_order = Fusion::new(FusionConfig::default());
    for o in &ordered {
        in_order.ingest(o, o.stamp);
    }
    // Deliver the same observations shuffled, each at most 0.4 s late.
    let mut rng = Lcg(7);
    let mut arrivals: Vec<(Stamp, &Observation)> = ordered
        .iter()
        .map(|o| (o.stamp.offset_secs(0.4 * rng.uniform()), o))
        .collect();
    arrivals.sort_by_key(|a| a.0);
    let mut shuffled = Fusion::new(FusionConfig::default());
    let mut reordered = 0;
    for (arrival, o) in &arrivals {
        if let Ingest::Reordered { .. } = shuffled.ingest(o, *arrival) {
            reordered += 1;
        }
    }
    assert!(reordered > 10, "the test must really reorder ({reordered})");
    assert_eq!(shuffled.counters().too_late, 0);
    assert_eq!(shuffled.tracker(), in_order.tracker());
    let at = Stamp(T0).offset_secs(2.0);
    assert_eq!(shuffled.ball_state(at), in_order.ball_state(at));
}

/// Ingests as received 50 ms after capture.
pub(super) fn ingest(f: &mut Fusion, o: &Observation) -> Ingest {
    f.ingest(o, o.stamp.offset_secs(0.05))
}

#[test]
fn too_late_and_duplicates_are_counted_and_dropped() {
    let mut f = Fusion::new(FusionConfig::default());
    assert_eq!(
        ingest(&mut f, &obs("a", 0, 1.0, [0.0, 0.0], 0.02)),
        Ingest::Applied
    );
    assert_eq!(
        ingest(&mut f, &obs("a", 0, 1.0, [0.0, 0.0], 0.02)),
        Ingest::Duplicate
    );
    assert!(matches!(
        ingest(&mut f, &obs("b", 0, 0.3, [0.0, 0.0], 0.02)),
        Ingest::TooLate { .. }
    ));
    let mut bad = obs("b", 1, 1.0, [0.0, 0.0], 0.02);
    bad.covariance_m2 = [0.0; 4];
    assert_eq!(ingest(&mut f, &bad), Ingest::Rejected);
    let c = f.counters();
    assert_eq!(
        (c.applied, c.duplicates, c.too_late, c.rejected),
        (1, 1, 1, 1)
    );
}

#[test]
fn phantom_from_one_robot_does_not_capture_the_estimate() {
    let mut f = Fusion::new(FusionConfig::default());
    let mut rng = Lcg(3);
    // A ball at rest at the origin seen by a, b, c; robot c also reports a phantom at
    // (1, 1) in every other frame.
    for k in 0..60u64 {
        let t = k as f64 / 15.0;
        for (r, robot) in ["a", "b", "c"].iter().enumerate() {
            let p = [0.02 * rng.normal(), 0.02 * rng.normal()];
            ingest(&mut f, &obs(robot, 2 * k, t + 0.01 * r as f64, p, 0.02));
        }
        if k % 2 == 0 {
            ingest(&mut f, &obs("c", 2 * k + 1, t + 0.025, [1.0, 1.0], 0.02));
        }
    }
    let st = f.ball_state(Stamp(T0).offset_secs(4.0)).expect("state");
    assert!(
        st.position_m[0].hypot(st.position_m[1]) < 0.03,
        "{:?}",
        st.position_m
    );
    let c = f
        .robots()
        .iter()
        .find(|r| &*r.robot == "c")
        .expect("robot c");
    assert!(c.outlier_rate > 0.2, "{}", c.outlier_rate);
}

#[test]
fn a_kick_is_followed_within_a_third_of_a_second() {
    let mut f = Fusion::new(FusionConfig::default());
    let mut rng = Lcg(11);
    let mut seq = 0;
    // At rest at (−1, 0) until t = 2 s, then kicked to 2 m/s along +x; 0.3 s later the
    // estimate must be on the moving ball.
    let truth = |t: f64| {
        let d = (t - 2.0).max(0.0);
        -1.0 + 2.0 * d - 0.15 * d * d
    };
    for k in 0..35u64 {
        let t = k as f64 / 15.0;
        for (r, robot) in ["a", "b", "c"].iter().enumerate() {
            let tt = t + 0.02 * r as f64;
            let p = [truth(tt) + 0.02 * rng.normal(), 0.02 * rng.normal()];
            ingest(&mut f, &obs(robot, seq, tt, p, 0.02));
            seq += 1;
        }
    }
    let at = 2.3;
    let st = f.ball_state(Stamp(T0).offset_secs(at)).expect("state");
    assert!(
        (st.position_m[0] - truth(at)).abs() < 0.08,
        "{:?} vs {}",
        st.position_m,
        truth(at)
    );
    assert!(st.velocity_mps[0] > 1.4, "{:?}", st.velocity_mps);
}

/// A rendered scene through the robot agent (`seed-3-towards`, seed 4, the first 1.3 s):
/// one robot 1.9 m away sees a resting ball kicked towards it by a robot that reports
/// nothing. The sightings are long along the view line and the two cameras disagree by a
/// few centimetres, so the kicked ball's first sightings stay inside the resting track's
/// gate: only the run of surprising updates tells the tracker the ball now moves. Each
/// line holds the observation and the simulator's true ball at its capture time.
const UNREPORTED_KICK: &str = include_str!("../../../tests/data/unreported-kick.jsonl");

#[derive(serde::Deserialize)]
struct Recorded {
    t_s: f64,
    truth_m: [f64; 2],
    obs: Observation,
}

/// Replays the recording; returns the mean position error over the 0.7 s after the kick,
/// as the server would have served the estimate at each capture, and the kicks inferred.
pub(super) fn no_kick_inference(cfg: &mut FusionConfig) {
    cfg.tracker.surprises_for_kick = usize::MAX;
    cfg.tracker.onset_chi2 = f64::INFINITY;
}

fn replay_unreported_kick(infer_kicks: bool) -> (f64, u64) {
    let mut cfg = FusionConfig::default();
    if !infer_kicks {
        no_kick_inference(&mut cfg);
    }
    let mut f = Fusion::new(cfg);
    let (mut sum_m, mut n) = (0.0, 0);
    for line in UNREPORTED_KICK.lines() {
        let r: Recorded = serde_json::from_str(line).expect("recorded observation");
        ingest(&mut f, &r.obs);
        if (0.6..=1.3).contains(&r.t_s) {
            let st = f.ball_state(r.obs.stamp).expect("state");
            sum_m += (st.position_m[0] - r.truth_m[0]).hypot(st.position_m[1] - r.truth_m[1]);
            n += 1;
        }
    }
    (sum_m / f64::from(n), f.tracker().kicks_inferred())
}

#[test]
fn an_unreported_kick_seen_by_one_robot_is_followed() {
    let (error, _) = replay_unreported_kick(true);
    let (error_off, kicks_off) = replay_unreported_kick(false);
    assert_eq!(kicks_off, 0);
    // The estimate follows the kick within 6 cm on average (here the covariance of the
    // young resting track is wide enough that no onset needs to be declared); inferring
    // kicks never makes it worse.
    assert!(
        error < 0.06,
        "mean position error after the kick: {error} m"
    );
    assert!(
        error <= error_off + 1e-9,
        "{error} m inferred, {error_off} m not"
    );
}

#[test]
fn a_resting_ball_seen_with_noise_is_not_taken_for_kicked() {
    let mut f = Fusion::new(FusionConfig::default());
    let mut rng = Lcg(8);
    for k in 0..600u64 {
        let t = k as f64 / 30.0;
        let p = [0.5 + 0.045 * rng.normal(), 0.2 + 0.045 * rng.normal()];
        ingest(&mut f, &obs("a", k, t, p, 0.045));
    }
    assert!(
        f.tracker().kicks_inferred() <= 1,
        "{}",
        f.tracker().kicks_inferred()
    );
}

#[test]
fn learns_the_rolling_deceleration_online() {
    let mut f = Fusion::new(FusionConfig::default());
    let mut rng = Lcg(5);
    let (v0, a) = (1.2, 0.22);
    let truth = |t: f64| {
        let t = t.min(v0 / a);
        -1.6 + v0 * t - 0.5 * a * t * t
    };
    let mut seq = 0;
    for k in 0..60u64 {
        let t = k as f64 / 15.0;
        for (r, robot) in ["a", "b", "c"].iter().enumerate() {
            let tt = t + 0.02 * r as f64;
            let p = [truth(tt) + 0.02 * rng.normal(), 0.5 + 0.02 * rng.normal()];
            ingest(&mut f, &obs(robot, seq, tt, p, 0.02));
            seq += 1;
        }
    }
    let st = f.ball_state(Stamp(T0).offset_secs(4.0)).expect("state");
    let learned = st.model.rolling_decel_mps2;
    assert!(
        (learned - a).abs() < 0.04,
        "learned {learned} vs true {a} (started at 0.3)"
    );
    assert!(st.model.decel_samples > 50);
}

#[test]
fn observations_beyond_a_wall_are_dropped_and_counted() {
    let mut f = Fusion::new(FusionConfig::default());
    ingest(&mut f, &obs("a", 0, 1.0, [2.6, 0.0], 0.02));
    assert_eq!(f.counters().outside_walls, 1);
    assert!(f.tracker().tracks().is_empty());
    // Just beyond the wall but within the observation's own noise: kept.
    ingest(&mut f, &obs("a", 1, 1.1, [1.93, 0.0], 0.02));
    assert_eq!(f.counters().outside_walls, 1);
    assert_eq!(f.tracker().tracks().len(), 1);
}

#[test]
fn a_robot_clock_far_ahead_is_rejected_and_harms_no_one() {
    let mut f = Fusion::new(FusionConfig::default());
    // Received at t = 1 s but stamped 5 s later.
    let ahead = obs("fast", 0, 6.0, [0.0, 0.0], 0.02);
    let out = f.ingest(&ahead, Stamp(T0).offset_secs(1.0));
    assert!(matches!(out, Ingest::FromTheFuture { .. }), "{out:?}");
    // Honest robots' observations at t = 1 s are still on time.
    assert_eq!(
        ingest(&mut f, &obs("a", 0, 1.0, [0.0, 0.0], 0.02)),
        Ingest::Applied
    );
    assert_eq!(f.counters().future, 1);
}

#[test]
fn poison_is_rejected_without_touching_the_state() {
    let mut f = Fusion::new(FusionConfig::default());
    let mut nan = obs("a", 0, 1.0, [f64::NAN, 0.0], 0.02);
    assert_eq!(ingest(&mut f, &nan), Ingest::Rejected);
    nan = obs("a", 1, 1.0, [0.0, 0.0], 0.02);
    nan.robot_pose.theta_rad = f64::INFINITY;
    assert_eq!(ingest(&mut f, &nan), Ingest::Rejected);
    let mut indefinite = obs("a", 2, 1.0, [0.0, 0.0], 0.02);
    indefinite.covariance_m2 = [1e-4, 2e-4, 2e-4, 1e-4];
    assert_eq!(ingest(&mut f, &indefinite), Ingest::Rejected);
    assert_eq!(f.counters().rejected, 3);
    assert!(f.tracker().tracks().is_empty());
}

#[test]
fn a_stream_of_made_up_robot_ids_does_not_grow_the_state_without_end() {
    use crate::estimator::tracker::MAX_ROBOT_SLOTS;
    let mut f = Fusion::new(FusionConfig::default());
    // Three honest robots follow a ball at rest while 3 000 made-up ids each say one
    // thing, ten a second.
    let (mut seq, made_up) = (0u64, 3000usize);
    for k in 0..made_up {
        let t = k as f64 * 0.1;
        for robot in ["a", "b", "c"] {
            f.ingest(
                &obs(robot, seq, t, [0.5, 0.2], 0.02),
                Stamp(T0).offset_secs(t),
            );
            seq += 1;
        }
        let fake = format!("fake{k}");
        let o = obs(&fake, 0, t + 0.05, [-1.0, -0.8], 0.02);
        f.ingest(&o, o.stamp);
    }
    let tracker = f.tracker();
    assert!(
        tracker.robots().len() <= MAX_ROBOT_SLOTS,
        "{} robots kept",
        tracker.robots().len()
    );
    assert!(tracker.robot_slots_reused() >= (made_up + 3 - MAX_ROBOT_SLOTS) as u64);
    assert!(
        f.names.len() < 2 * MAX_ROBOT_SLOTS + 1,
        "{} names",
        f.names.len()
    );
    // The honest robots kept their places, and the ball is theirs.
    for robot in ["a", "b", "c"] {
        assert!(
            tracker.robots().iter().any(|r| &*r.robot == robot),
            "{robot}"
        );
    }
    let t = (made_up - 1) as f64 * 0.1;
    let st = f.ball_state(Stamp(T0).offset_secs(t)).expect("a state");
    assert!((st.position_m[0] - 0.5).abs() < 0.05, "{:?}", st.position_m);
}

/// One robot at 10 Hz watches a ball at rest; the ball is picked up and, 1.5 s later, kicked
/// at 5 m/s from elsewhere. Returns the served position error 0.5 s after the robot first
/// sees the kicked ball, and the hypotheses started through two sightings.
fn moved_ball_fast_kick(cfg: FusionConfig) -> (f64, u64) {
    let mut f = Fusion::new(cfg);
    let mut rng = Lcg(5);
    let truth = |t: f64| {
        let d = t - 4.5;
        [3.5 - 6.5 * d + 0.2 * d * d, -1.0]
    };
    let mut seq = 0;
    for k in 0..30u64 {
        let t = k as f64 / 10.0;
        let p = [-3.0 + 0.02 * rng.normal(), 1.5 + 0.02 * rng.normal()];
        ingest(&mut f, &obs("a", seq, t, p, 0.02));
        seq += 1;
    }
    let first_seen = 4.52;
    for k in 0..6u64 {
        let t = first_seen + k as f64 / 10.0;
        let z = truth(t);
        let p = [z[0] + 0.03 * rng.normal(), z[1] + 0.03 * rng.normal()];
        ingest(&mut f, &obs("a", seq, t, p, 0.03));
        seq += 1;
    }
    let at = first_seen + 0.5;
    let st = f.ball_state(Stamp(T0).offset_secs(at)).expect("state");
    let z = truth(at);
    let err = (st.position_m[0] - z[0]).hypot(st.position_m[1] - z[1]);
    (err, f.tracker().pairs_initiated())
}

#[test]
fn a_moved_ball_kicked_fast_is_found_by_one_slow_robot_within_half_a_second() {
    let pitch = Pitch {
        length_m: 9.0,
        width_m: 6.0,
        ..Pitch::default()
    };
    let (err, pairs) = moved_ball_fast_kick(FusionConfig::for_pitch(pitch.clone()));
    assert!(err < 0.3, "served {err} m from the kicked ball");
    assert!(pairs >= 1, "{pairs}");
    // Without two-point initiation no hypothesis follows a 6.5 m/s ball seen every 65 cm.
    let mut cfg = FusionConfig::for_pitch(pitch);
    cfg.tracker.pair_max_dt_s = 0.0;
    let (err_off, pairs_off) = moved_ball_fast_kick(cfg);
    assert_eq!(pairs_off, 0);
    assert!(err_off > 1.0, "{err_off} m without pairing");
}

/// Robot `a` at (−1.5, 0) facing +x: its left camera sees the floor from x = −1.3 to 1.6.
fn wedge() -> Vec<CameraFootprint> {
    vec![CameraFootprint {
        camera: Camera::Left,
        polygon_m: vec![[-1.3, -0.2], [1.6, -1.2], [1.6, 1.2], [-1.3, 0.2]],
    }]
}

fn look(f: &mut Fusion, robot: &str, t_s: f64, since_s: Option<f64>, fp: &[CameraFootprint]) {
    let at = Stamp(T0).offset_secs(t_s);
    let report = ViewReport {
        robot,
        stamp: at,
        pose: Pose2 {
            x_m: -1.5,
            y_m: 0.0,
            theta_rad: 0.0,
        },
        footprints: fp,
        fps: 10.0,
        since: since_s.map(|s| Stamp(T0).offset_secs(s)),
    };
    let refused = f.footprints(&report, at.offset_secs(0.05));
    assert!(refused.is_empty(), "{refused:?}");
}

/// One robot at 10 Hz watches a ball at rest at (0.5, 0.3) for 3 s, sending a status
/// with footprints every 0.5 s (or none); then the ball is gone (`moved_to` None: picked
/// up) or put down at `moved_to` within 0.3 s, in view. Returns the served state 1.5 s
/// after the ball left and the fusion.
fn ball_taken_away(footprints: bool, moved_to: Option<[f64; 2]>) -> (BallState, Fusion) {
    let mut f = Fusion::new(FusionConfig::default());
    let fp = if footprints { wedge() } else { Vec::new() };
    let mut rng = Lcg(5);
    let mut seq = 0;
    let mut last_status = None;
    for k in 0..45 {
        let t = k as f64 / 10.0;
        if k % 5 == 0 {
            look(&mut f, "a", t, last_status, &fp);
            last_status = Some(t);
        }
        let p = if t < 3.0 {
            Some([0.5, 0.3])
        } else if t >= 3.3 {
            moved_to
        } else {
            None
        };
        if let Some(p) = p {
            let z = [p[0] + 0.01 * rng.normal(), p[1] + 0.01 * rng.normal()];
            ingest(&mut f, &obs("a", seq, t, z, 0.01));
            seq += 1;
        }
    }
    let st = f.ball_state(Stamp(T0).offset_secs(4.5)).expect("a state");
    (st, f)
}

#[test]
fn a_ball_taken_away_in_view_of_a_robot_fades_from_the_estimate() {
    let (seen, _) = {
        let mut f = Fusion::new(FusionConfig::default());
        look(&mut f, "a", 0.0, None, &wedge());
        for k in 0..30u64 {
            ingest(&mut f, &obs("a", k, k as f64 / 10.0, [0.5, 0.3], 0.01));
        }
        (f.ball_state(Stamp(T0).offset_secs(2.9)).expect("state"), ())
    };
    assert!(seen.existence > 0.95, "a ball seen: {}", seen.existence);
    let (st, f) = ball_taken_away(true, None);
    assert!(st.existence < 0.2, "taken away in view: {}", st.existence);
    assert!(f.counters().misses_in_view > 0);
    assert!(f.counters().footprints_accepted >= 9);
    // A robot that sends no footprints keeps today's behaviour: no evidence either way.
    let (blind, f) = ball_taken_away(false, None);
    assert!(blind.existence > 0.95, "{}", blind.existence);
    assert_eq!(f.counters().misses_in_view, 0);
}

#[test]
fn a_ball_put_down_elsewhere_in_view_takes_over_at_once() {
    let b = [-0.5, -0.4];
    let (st, f) = ball_taken_away(true, Some(b));
    let err = (st.position_m[0] - b[0]).hypot(st.position_m[1] - b[1]);
    assert!(err < 0.05, "{err} m from the ball put down");
    assert!(st.existence > 0.9, "{}", st.existence);
    assert!(f.counters().misses_in_view > 0);
}

#[test]
fn a_robot_that_claims_to_see_the_ball_s_place_cannot_erase_what_another_sees() {
    let mut f = Fusion::new(FusionConfig::default());
    let mut rng = Lcg(9);
    for k in 0..60u64 {
        let t = k as f64 / 20.0;
        // `a` sees the ball at (0.5, 0.3) at 20 Hz and sends no footprint.
        let z = [0.5 + 0.01 * rng.normal(), 0.3 + 0.01 * rng.normal()];
        ingest(&mut f, &obs("a", k, t, z, 0.01));
        // `liar` claims a view over it and reports a phantom elsewhere at 20 Hz.
        if k % 10 == 0 {
            look(&mut f, "liar", t, (k > 0).then_some(t - 0.5), &wedge());
        }
        ingest(&mut f, &obs("liar", k, t + 0.01, [-1.0, -0.1], 0.01));
        // `ghost` claims the same view and never sends an observation.
        if k % 10 == 0 {
            look(&mut f, "ghost", t, (k > 0).then_some(t - 0.5), &wedge());
        }
    }
    let st = f.ball_state(Stamp(T0).offset_secs(3.0)).expect("state");
    assert!((st.position_m[0] - 0.5).abs() < 0.03 && (st.position_m[1] - 0.3).abs() < 0.03);
    assert!(st.existence > 0.95, "{}", st.existence);
}

#[test]
fn bad_footprints_are_refused_counted_and_change_nothing() {
    let mut f = Fusion::new(FusionConfig::default());
    let whole = vec![CameraFootprint {
        camera: Camera::Right,
        polygon_m: vec![[-3.0, -2.0], [3.0, -2.0], [3.0, 2.0], [-3.0, 2.0]],
    }];
    let line = vec![CameraFootprint {
        camera: Camera::Left,
        polygon_m: vec![[0.0, 0.0], [1.0, 0.0]],
    }];
    for fp in [whole, line] {
        let at = Stamp(T0);
        let report = ViewReport {
            robot: "a",
            stamp: at,
            pose: Pose2::default(),
            footprints: &fp,
            fps: 30.0,
            since: None,
        };
        assert_eq!(f.footprints(&report, at).len(), 1);
    }
    assert_eq!(f.counters().footprints_rejected, 2);
    assert_eq!(f.counters().footprints_accepted, 0);
}

/// A ball at rest, kicked along +x at 2.5 m/s by nobody who reports it: it slides at
/// 3 m/s² down to 0.64 of that, then rolls at 0.3 m/s². Seen by two robots at 100 Hz with
/// 1 cm noise up to `until_s`; returns the along-track error of the path predicted 0.8 s
/// ahead from there, and whether the estimate then slides.
fn predict_after_a_sliding_kick(cfg: FusionConfig, until_s: f64) -> (f64, bool) {
    let truth = |t: f64| {
        let (t0, v0, a_s, a_r) = (1.0, 2.5, 3.0, 0.3);
        let t_slide = (1.0 - 0.64) * v0 / a_s;
        let dt = (t - t0).max(0.0);
        let x = if dt <= t_slide {
            v0 * dt - 0.5 * a_s * dt * dt
        } else {
            let v1 = 0.64 * v0;
            let r = dt - t_slide;
            v0 * t_slide - 0.5 * a_s * t_slide * t_slide + v1 * r - 0.5 * a_r * r * r
        };
        [-1.0 + x, 0.3]
    };
    let mut f = Fusion::new(cfg);
    let mut rng = Lcg(17);
    let mut last = Stamp(T0);
    for k in 0..((until_s * 100.0) as u64) {
        for (r, robot) in ["a", "b"].iter().enumerate() {
            let t = k as f64 / 100.0 + 0.005 * r as f64;
            let p = truth(t);
            let z = [p[0] + 0.01 * rng.normal(), p[1] + 0.01 * rng.normal()];
            let o = obs(robot, k, t, z, 0.01);
            last = o.stamp;
            ingest(&mut f, &o);
        }
    }
    let st = f.ball_state(last).expect("a state");
    let ahead = st
        .prediction
        .samples
        .iter()
        .min_by(|a, b| (a.t_s - 0.8).abs().total_cmp(&(b.t_s - 0.8).abs()))
        .expect("samples");
    let t_now = (last.0 - T0) as f64 * 1e-9;
    let want = truth(t_now + ahead.t_s);
    let err = (ahead.position_m[0] - want[0]).abs();
    let sliding = f.tracker().main().is_some_and(|m| m.filter.sliding());
    (err, sliding)
}

#[test]
fn a_kicked_ball_is_predicted_to_slide_then_roll() {
    let (err, sliding) = predict_after_a_sliding_kick(FusionConfig::default(), 1.1);
    assert!(sliding, "the kicked estimate slides");
    // Without a slide phase the same kick is predicted to run on much farther.
    let mut no_slide = FusionConfig::default();
    no_slide.tracker.motion.slide_decel_mps2 = no_slide.tracker.motion.decel_mps2;
    no_slide.tracker.learn_decel = false;
    let (err_roll, sliding_roll) = predict_after_a_sliding_kick(no_slide, 1.1);
    assert!(!sliding_roll);
    assert!(err < 0.08, "0.8 s ahead: {err} m off");
    assert!(
        err < 0.5 * err_roll,
        "{err} m sliding, {err_roll} m rolling"
    );
}

#[test]
fn a_kick_suspected_but_not_yet_clear_widens_the_path_but_does_not_move_it() {
    // One 10 Hz robot sees a ball at rest for 1.5 s, then one sighting 0.3 m off: a kick
    // at 3 m/s or a bad frame, too soon to tell.
    let mut f = Fusion::new(FusionConfig::default());
    let mut rng = Lcg(3);
    let mut k = 0;
    while k <= 15 {
        let t = k as f64 * 0.1;
        let p = [0.5 + 0.01 * rng.normal(), 0.2 + 0.01 * rng.normal()];
        f.ingest(&obs("a", k, t, p, 0.01), Stamp(T0).offset_secs(t));
        k += 1;
    }
    let at_1 = |st: &BallState| {
        let s = st
            .prediction
            .samples
            .iter()
            .find(|s| (s.t_s - 1.0).abs() < 1e-6)
            .unwrap();
        (s.position_m, s.covariance_m2.unwrap())
    };
    let before = f.ball_state(Stamp(T0).offset_secs(1.55)).unwrap();
    let (p_before, c_before) = at_1(&before);
    let t = 1.6;
    f.ingest(&obs("a", k, t, [0.8, 0.2], 0.01), Stamp(T0).offset_secs(t));
    let after = f.ball_state(Stamp(T0).offset_secs(1.65)).unwrap();
    let (p_after, c_after) = at_1(&after);
    assert!(
        (p_after[0] - p_before[0]).abs() < 0.02,
        "the served path stays the unkicked one: {p_before:?} then {p_after:?}"
    );
    assert!(
        c_after[0] > 50.0 * c_before[0] && c_after[0] > 0.04,
        "the 1 s point's x variance: {} then {}",
        c_before[0],
        c_after[0]
    );
    // The next sightings on the same line make the kick clear: the path follows it.
    for (j, x) in [1.1, 1.4].iter().enumerate() {
        let t = 1.7 + 0.1 * j as f64;
        f.ingest(
            &obs("a", k + 1 + j as u64, t, [*x, 0.2], 0.01),
            Stamp(T0).offset_secs(t),
        );
    }
    let kicked = f.ball_state(Stamp(T0).offset_secs(1.85)).unwrap();
    assert!(kicked.velocity_mps[0] > 1.5, "{:?}", kicked.velocity_mps);
}
