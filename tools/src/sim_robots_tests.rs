use super::*;
use fusion_server::{Engine, EngineConfig, FusionConfig};
use proto::{Camera, MAX_FOOTPRINT_POINTS, MAX_STATUS_FOOTPRINTS, Validate, ValidationContext};
use sim::ObsKind;

#[test]
fn modelled_counters_follow_the_published_sightings() {
    let mut p = ModelledPerception::default();
    for _ in 0..3 {
        p.published(proto::Camera::Left);
    }
    p.published(proto::Camera::Right);
    let first = p.report(1.0, 15.0);
    assert_eq!(
        (first[0].frames, first[0].balls, first[1].balls),
        (15, 3, 1)
    );
    assert!((first[0].balls_per_s - 3.0).abs() < 1e-9);
    p.published(proto::Camera::Left);
    let second = p.report(1.5, 15.0);
    assert!(
        (second[0].balls_per_s - 2.0).abs() < 1e-9,
        "one ball in half a second"
    );
    assert_eq!(second[1].balls_per_s, 0.0);
    assert!(
        second
            .iter()
            .all(|c| c.rejections.is_empty() && c.frames == 22)
    );
}

/// The server's rule.
fn inside(poly: &[[f64; 2]], p: [f64; 2]) -> bool {
    proto::polygon_contains(poly, p)
}

fn holds(footprints: &[proto::CameraFootprint], camera: Camera, p: [f64; 2]) -> bool {
    footprints
        .iter()
        .any(|f| f.camera == camera && inside(&f.polygon_m, p))
}

fn short_match(seed: u64, duration_s: f64) -> SimRun {
    simulate(
        "match",
        seed,
        sim::SimConfig::default().start,
        Some(duration_s),
        None,
    )
    .unwrap_or_else(|e| panic!("{e:#}"))
}

/// Every status time of `track`'s robot at `plan`'s rate, with its status (none while
/// stalled).
fn statuses(run: &SimRun, track: &RobotTrack, plan: StatusPlan) -> Vec<(f64, Option<RobotStatus>)> {
    (0..)
        .map(|k| f64::from(k) * plan.interval_s)
        .take_while(|t_s| *t_s <= run.duration_s)
        .map(|t_s| (t_s, plan.status(run, track, t_s, run.stamp_of(t_s))))
        .collect()
}

#[test]
fn statuses_carry_valid_footprints_for_both_cameras() {
    let run = short_match(3, 20.0);
    let plan = StatusPlan::new(5.0, true);
    let (mut sent, mut stalled, mut both) = (0, 0, 0);
    for track in run.robots.iter().filter(|r| r.observer) {
        for (t_s, status) in statuses(&run, track, plan) {
            let Some(s) = status else {
                stalled += 1;
                continue;
            };
            sent += 1;
            let ctx = ValidationContext::new(run.pitch.clone(), s.stamp);
            s.validate(&ctx)
                .unwrap_or_else(|e| panic!("{} at {t_s}: {e}", s.robot_id));
            assert!(s.footprints.len() <= MAX_STATUS_FOOTPRINTS);
            assert!(
                s.footprints
                    .iter()
                    .all(|f| (3..=MAX_FOOTPRINT_POINTS).contains(&f.polygon_m.len()))
            );
            let cameras: Vec<Camera> = s.footprints.iter().map(|f| f.camera).collect();
            both += usize::from(cameras == [Camera::Left, Camera::Right]);
            // A point 1 m behind the robot is in neither camera's footprint.
            let p = s.pose;
            let behind = [p.x_m - p.theta_rad.cos(), p.y_m - p.theta_rad.sin()];
            assert!(!s.footprints.iter().any(|f| inside(&f.polygon_m, behind)));
        }
    }
    assert!(sent > 400, "{sent}");
    // A camera claims nothing only with a body right in front of it.
    assert!(both * 100 >= sent * 95, "{both} of {sent}");
    // Stalls (perception bursts) happen every 20 s or so a robot: a few statuses are held.
    assert!(stalled < sent / 20, "{stalled} of {sent}");
    // Without footprints, the same statuses carry none.
    let track = &run.robots[0];
    let bare = StatusPlan::new(5.0, false).status(&run, track, 1.0, run.stamp_of(1.0));
    assert!(bare.is_some_and(|s| s.footprints.is_empty()));
}

#[test]
fn footprints_hold_the_ball_the_camera_reports_and_not_a_ball_behind() {
    let run = short_match(1, 30.0);
    let (mut sightings, mut held_alone, mut held_among_bodies) = (0, 0, 0);
    let mut behind = 0;
    for d in run.deliveries.iter().filter(|d| d.kind == ObsKind::Ball) {
        let Some(track) = run.robot(&d.obs.robot_id) else {
            continue;
        };
        let t_s = run.t_of(d.obs.stamp) - track.clock_offset_s;
        let ball = run.truth_at(t_s).position_m;
        let pose = track.pose_at(t_s);
        sightings += 1;
        // The camera's view on its own holds every ball it reports; among the other
        // robots (whose shadows are cut out a slice at a time) almost every one.
        let alone = sim::camera_footprints(&[sim::Moment { pose, others: &[] }]);
        held_alone += usize::from(holds(&alone, d.obs.camera, ball));
        held_among_bodies += usize::from(holds(
            &footprints_of(&run, track, t_s, 0.0),
            d.obs.camera,
            ball,
        ));
    }
    // And a ball behind a robot (more than 150° off its heading) is in no footprint.
    for track in run.robots.iter().filter(|r| r.observer) {
        for k in 0..300 {
            let t_s = f64::from(k) * 0.1;
            let (ball, pose) = (run.truth_at(t_s).position_m, track.pose_at(t_s));
            let off = (ball[1] - pose.y_m).atan2(ball[0] - pose.x_m) - pose.theta_rad;
            if off.cos() < (150f64).to_radians().cos() {
                behind += 1;
                let fps = footprints_of(&run, track, t_s, 0.2);
                assert!(!fps.iter().any(|f| inside(&f.polygon_m, ball)), "{t_s}");
            }
        }
    }
    assert!(sightings > 1000 && behind > 100, "{sightings} {behind}");
    assert_eq!(held_alone, sightings);
    assert!(
        held_among_bodies * 100 >= sightings * 97,
        "{held_among_bodies} of {sightings}"
    );
}

#[test]
fn the_modelled_detector_finds_a_ball_in_a_footprint_at_least_as_often_as_the_server_assumes() {
    // Per image: the detector's probability at the ball's place, less the images dropped
    // (a stalled robot sends no status); the server's recall is by the range from the
    // robot's centre.
    let recall = FusionConfig::default().tracker.views;
    let pose = Pose2::default();
    let footprints = sim::camera_footprints(&[sim::Moment { pose, others: &[] }]);
    assert_eq!(footprints.len(), 2);
    let mut checked = 0;
    for f in &footprints {
        for i in -60..=60 {
            for j in -60..=60 {
                let p = [f64::from(i) * 0.05, f64::from(j) * 0.05];
                if !inside(&f.polygon_m, p) {
                    continue;
                }
                checked += 1;
                let found = sim::model::detection_probability_at(&pose, f.camera, p)
                    * (1.0 - sim::model::DROPOUT_P);
                let assumed = recall.recall_at(p[0].hypot(p[1]));
                assert!(
                    found >= assumed,
                    "{:?} at {p:?}: {found} < {assumed}",
                    f.camera
                );
            }
        }
    }
    assert!(checked > 1000, "{checked}");
}

/// What the server made of a run: its observations at their arrival times and each
/// observer's statuses at 5 Hz (5 ms after their stamps).
#[derive(Debug, Default, Clone, Copy)]
struct Fused {
    /// Ticks (every 0.1 s after the first 2 s) with an estimate within 0.3 m of the ball.
    on_ball: usize,
    /// ... of which the estimate's existence was below one half, and below 0.2 (refuted).
    doubted: usize,
    refuted: usize,
    misses: u64,
    footprints: u64,
    refused: u64,
}

impl std::ops::AddAssign for Fused {
    fn add_assign(&mut self, o: Fused) {
        self.on_ball += o.on_ball;
        self.doubted += o.doubted;
        self.refuted += o.refuted;
        self.misses += o.misses;
        self.footprints += o.footprints;
        self.refused += o.refused;
    }
}

/// What reaches the server: an observation, or a status (encoded, as sent).
enum Input<'a> {
    Obs(&'a Observation),
    Status { robot: String, payload: Vec<u8> },
}

fn fuse(run: &SimRun, plan: StatusPlan) -> Fused {
    let mut engine = Engine::new(EngineConfig::default());
    let mut inputs: Vec<(Stamp, Input<'_>)> = run
        .deliveries
        .iter()
        .map(|d| (d.arrival, Input::Obs(&d.obs)))
        .collect();
    for track in run.robots.iter().filter(|r| r.observer) {
        for (t_s, status) in statuses(run, track, plan) {
            if let Some(s) = status {
                let (robot, payload) = (s.robot_id.clone(), proto::encode(&s));
                inputs.push((run.stamp_of(t_s + 0.005), Input::Status { robot, payload }));
            }
        }
    }
    inputs.sort_by_key(|(at, _)| *at);
    let mut out = Fused::default();
    let mut next = inputs.into_iter().peekable();
    for tick in 20.. {
        let t_s = f64::from(tick) * 0.1;
        if t_s > run.duration_s {
            break;
        }
        let at = run.stamp_of(t_s);
        while let Some((arrival, input)) = next.next_if(|(a, _)| *a <= at) {
            // Refusals are counted by the engine; the counters below tell.
            let _ = match input {
                Input::Obs(o) => engine
                    .observation_decoded(Some(&o.robot_id), o.clone(), arrival)
                    .map(|_| ()),
                Input::Status { robot, payload } => {
                    engine.status(Some(&robot), &payload, arrival).map(|_| ())
                }
            };
        }
        let truth = run.truth_at(t_s).position_m;
        if let Some(b) = engine.ball_state(at)
            && (b.position_m[0] - truth[0]).hypot(b.position_m[1] - truth[1]) < 0.3
        {
            out.on_ball += 1;
            out.doubted += usize::from(b.existence < 0.5);
            out.refuted += usize::from(b.existence < 0.2);
        }
    }
    let c = engine.fusion().counters();
    (out.misses, out.footprints, out.refused) = (
        c.misses_in_view,
        c.footprints_accepted,
        c.footprints_rejected,
    );
    out
}

#[test]
fn the_simulated_robots_footprints_do_not_refute_the_ball() {
    let mut with = Fused::default();
    let mut without = Fused::default();
    for seed in 1..=3 {
        let run = short_match(seed, 60.0);
        with += fuse(&run, StatusPlan::new(5.0, true));
        without += fuse(&run, StatusPlan::new(5.0, false));
    }
    // Negative information is at work: footprints kept, none refused, misses counted.
    assert!(with.footprints > 5_000 && with.refused == 0, "{with:?}");
    assert!(with.misses > 100, "{with:?}");
    assert_eq!((without.footprints, without.misses), (0, 0));
    // And it does not cost the ball: the estimate is on it as often, and doubted in at
    // most 1 % of the time.
    assert!(
        with.on_ball * 100 >= without.on_ball * 99,
        "{with:?} {without:?}"
    );
    assert!(with.doubted * 100 <= with.on_ball, "{with:?}");
}

/// Negative information over twenty two-minute matches of four robots, as the demo plays
/// them, with and without footprints. `cargo test --release -p tools --lib -- --ignored footprints_over_twenty_matches
/// --nocapture`
#[test]
#[ignore = "prints figures"]
fn footprints_over_twenty_matches() {
    let mut with = Fused::default();
    let mut without = Fused::default();
    for seed in 1..=20 {
        let run = simulate(
            "match",
            seed,
            sim::SimConfig::default().start,
            Some(120.0),
            Some(4),
        )
        .unwrap_or_else(|e| panic!("{e:#}"));
        with += fuse(&run, StatusPlan::new(5.0, true));
        without += fuse(&run, StatusPlan::new(5.0, false));
    }
    println!("with footprints:    {with:?}\nwithout footprints: {without:?}");
}
