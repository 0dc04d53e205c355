//! Scenario-level tests of the world: whole runs checked against what the scenarios
//! promise about the ball and the robots. Observation-side checks: `observation_tests`.

use crate::physics::Walls;
use crate::robots::{ROBOT_RADIUS_M, robot_limits};
use crate::vec2::{V2, dist, norm};
use crate::*;
use std::time::Instant;

pub(crate) fn run(name: &str, seed: u64) -> SimRun {
    run_scenario(name, seed, &SimConfig::default()).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
#[ignore = "exploration printout"]
fn summary() {
    for name in scenario_names() {
        for seed in 0..3 {
            let r = run(name, seed);
            let kinds = |k: ObsKind| r.deliveries.iter().filter(|d| d.kind == k).count();
            let kicks: Vec<String> = r
                .events
                .iter()
                .filter_map(|e| match e {
                    BallEvent::Kick {
                        t_s,
                        velocity_mps,
                        kicker_distance_m,
                        ..
                    } => Some(format!(
                        "{t_s:.2}@{:.2}/{kicker_distance_m:.2}",
                        velocity_mps[0].hypot(velocity_mps[1])
                    )),
                    _ => None,
                })
                .collect();
            let contacts = r
                .events
                .iter()
                .filter(|e| matches!(e, BallEvent::RobotContact { .. }))
                .count();
            let stops = r
                .events
                .iter()
                .filter(|e| matches!(e, BallEvent::Stopped { .. }))
                .count();
            println!(
                "{name:22} {seed} ball {} fp {} ph {} bounces {} contacts {contacts} stops {stops} kicks {kicks:?} {:?} {:?}",
                kinds(ObsKind::Ball),
                kinds(ObsKind::FalsePositive),
                kinds(ObsKind::Phantom),
                r.bounce_count(),
                r.stats,
                r.phantom,
            );
        }
    }
}

pub(crate) fn kicks(r: &SimRun) -> Vec<(f64, [f64; 2], String)> {
    r.events
        .iter()
        .filter_map(|e| match e {
            BallEvent::Kick {
                t_s,
                velocity_mps,
                robot_id,
                ..
            } => Some((*t_s, *velocity_mps, robot_id.clone())),
            _ => None,
        })
        .collect()
}

/// True capture time of a delivery (clock offsets are off in the default config).
pub(crate) fn capture_t(r: &SimRun, d: &Delivery) -> f64 {
    r.t_of(d.obs.stamp)
}

/// True when a kick or robot contact happened in [a, b].
fn disturbed(r: &SimRun, a: f64, b: f64) -> bool {
    r.events.iter().any(|e| {
        matches!(e, BallEvent::Kick { .. } | BallEvent::RobotContact { .. })
            && (a..=b).contains(&e.t_s())
    })
}

#[test]
fn same_seed_same_run_and_different_seeds_differ() {
    for name in scenario_names() {
        let a = run(name, 11);
        let b = run(name, 11);
        assert!(a == b, "{name} is not deterministic");
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
        let c = run(name, 12);
        assert!(a.truth != c.truth && a.deliveries != c.deliveries, "{name}");
    }
}

#[test]
fn slide_then_roll_decelerations_match_the_drawn_parameters() {
    for seed in 0..6 {
        let r = run("seed-2-away", seed);
        let p = r.params;
        let (mut slides, mut rolls) = (0, 0);
        for w in r.truth.windows(2) {
            let (a, b) = (w[0], w[1]);
            if a.phase != b.phase || b.phase == BallPhase::Rest || disturbed(&r, a.t_s, b.t_s) {
                continue;
            }
            if r.events.iter().any(|e| (a.t_s..=b.t_s).contains(&e.t_s())) {
                continue;
            }
            let (va, vb) = (norm(a.velocity_mps), norm(b.velocity_mps));
            let decel = (va - vb) / (b.t_s - a.t_s);
            if b.phase == BallPhase::Slide {
                slides += 1;
                assert!(
                    (decel - p.slide_decel_mps2).abs() < 1e-6,
                    "seed {seed}: {decel} vs {p:?}"
                );
            } else {
                rolls += 1;
                let vm = 0.5 * (va + vb);
                let expected = p.rolling_decel_mps2 + p.drag_per_m * vm * vm;
                assert!(
                    (decel - expected).abs() < 1e-4,
                    "seed {seed}: {decel} vs {expected}"
                );
            }
        }
        assert!(slides >= 3 && rolls >= 100, "seed {seed}: {slides} {rolls}");
        // Rolling starts at 5/7 of the kick speed.
        let (t_kick, v, _) = kicks(&r)[0].clone();
        let v_roll = norm(v) * model::SLIDE_TO_ROLL_RATIO;
        let first_roll = r
            .truth
            .iter()
            .find(|s| s.t_s > t_kick && s.phase == BallPhase::Roll);
        let last_slide = r.truth.iter().rev().find(|s| s.phase == BallPhase::Slide);
        let (Some(fr), Some(ls)) = (first_roll, last_slide) else {
            panic!("seed {seed}: no slide/roll");
        };
        assert!(norm(fr.velocity_mps) <= v_roll + 1e-9 && norm(ls.velocity_mps) >= v_roll - 1e-9);
        // It comes to rest with exactly zero velocity.
        let last = r.truth[r.truth.len() - 1];
        assert_eq!(
            (last.phase, last.velocity_mps),
            (BallPhase::Rest, [0.0, 0.0])
        );
    }
}

#[test]
fn ball_stays_within_the_walls_and_robots_on_the_pitch() {
    let pitch = proto::Pitch::default();
    let walls = Walls::new(&pitch);
    let rl = robot_limits(&pitch);
    let mut fastest: f64 = 0.0;
    for name in scenario_names() {
        for seed in 0..2 {
            let r = run(name, seed);
            for s in &r.truth {
                assert!(
                    s.position_m[0].abs() <= walls.limit[0] + 1e-9,
                    "{name} {s:?}"
                );
                assert!(
                    s.position_m[1].abs() <= walls.limit[1] + 1e-9,
                    "{name} {s:?}"
                );
            }
            for track in &r.robots {
                assert_eq!(track.poses.len(), r.truth.len());
                for w in track.poses.windows(2) {
                    let (a, b) = (w[0].1, w[1].1);
                    assert!(
                        b.x_m.abs() <= rl[0] + 1e-9 && b.y_m.abs() <= rl[1] + 1e-9,
                        "{name}"
                    );
                    let v = dist([a.x_m, a.y_m], [b.x_m, b.y_m]) / (w[1].0 - w[0].0);
                    fastest = fastest.max(v);
                }
            }
            for (_, v, _) in kicks(&r) {
                assert!(
                    (0.6 - 1e-9..=2.5 + 1e-9).contains(&norm(v)),
                    "{name}: kick {v:?}"
                );
            }
        }
    }
    // Drive speed is capped at 0.4 m/s; bodies shoving each other apart may add a little.
    assert!(fastest < 0.6, "{fastest}");
}

#[test]
fn wall_bounces_lose_speed_and_draw_restitution_around_the_mean() {
    let mut checked = 0;
    for seed in 0..6 {
        let r = run("team-rally", seed);
        for e in &r.events {
            let BallEvent::WallBounce {
                t_s, restitution, ..
            } = *e
            else {
                continue;
            };
            assert!((restitution - r.params.restitution_mean).abs() <= 0.1 + 1e-12);
            let i = r.truth.partition_point(|s| s.t_s < t_s);
            if i == 0 || i >= r.truth.len() {
                continue;
            }
            let (before, after) = (r.truth[i - 1], r.truth[i]);
            if disturbed(&r, before.t_s, after.t_s) {
                continue;
            }
            assert!(
                norm(after.velocity_mps) < norm(before.velocity_mps),
                "seed {seed} at {t_s}"
            );
            checked += 1;
        }
    }
    assert!(checked > 30, "{checked}");
}

#[test]
fn team_rally_bounces_at_least_six_times() {
    for seed in 0..20 {
        let r = run("team-rally", seed);
        assert!(
            r.bounce_count() >= 6,
            "seed {seed}: {} bounces",
            r.bounce_count()
        );
    }
}

#[test]
fn corner_kicks_rattle_between_two_walls() {
    let (mut rattles, mut total) = (0, 0);
    for seed in 0..10 {
        let r = run("corner", seed);
        let ks = kicks(&r);
        assert!((2..=3).contains(&ks.len()), "seed {seed}");
        for (i, (t, _, _)) in ks.iter().enumerate() {
            let end = ks.get(i + 1).map_or(f64::INFINITY, |k| k.0);
            let walls: Vec<proto::WallSide> = r
                .events
                .iter()
                .filter_map(|e| match e {
                    BallEvent::WallBounce { t_s, wall, .. } if (*t..end).contains(t_s) => {
                        Some(*wall)
                    }
                    _ => None,
                })
                .collect();
            use proto::WallSide::*;
            let x = walls.iter().any(|w| matches!(w, XMax | XMin));
            let y = walls.iter().any(|w| matches!(w, YMax | YMin));
            total += 1;
            rattles += usize::from(x && y);
        }
    }
    assert!(
        rattles * 10 >= total * 6,
        "{rattles} of {total} kicks hit both walls"
    );
}

#[test]
fn kick_restart_kicks_twice_hard_from_rest() {
    for seed in 0..20 {
        let r = run("kick-restart", seed);
        let ks = kicks(&r);
        assert_eq!(ks.len(), 2, "seed {seed}");
        for (t, v, who) in &ks {
            assert!(norm(*v) >= 2.0 && who.starts_with("miro"), "seed {seed}");
            assert_eq!(
                r.truth_at(t - 0.005).phase,
                BallPhase::Rest,
                "seed {seed} at {t}"
            );
        }
        assert!(ks[0].0 >= 1.9, "seed {seed}");
        let stopped_before = r
            .events
            .iter()
            .filter(|e| matches!(e, BallEvent::Stopped { .. }))
            .map(BallEvent::t_s)
            .filter(|&t| t > ks[0].0 && t < ks[1].0)
            .fold(f64::NAN, f64::max);
        assert!(
            ks[1].0 - stopped_before >= 2.0,
            "seed {seed}: rested {}",
            ks[1].0 - stopped_before
        );
    }
}

#[test]
fn a_minute_of_match_simulates_quickly() {
    let t0 = Instant::now();
    let r = run("match", 0);
    let elapsed = t0.elapsed().as_secs_f64();
    println!(
        "60 s match: {elapsed:.3} s wall, {} deliveries, {} truth samples",
        r.deliveries.len(),
        r.truth.len()
    );
    assert!((r.duration_s - 60.0).abs() < 1e-12 && r.truth.len() == 6001);
    assert!(elapsed < 5.0, "{elapsed}");
}

#[test]
#[ignore = "long: ten minutes of match"]
fn ten_minutes_of_match() {
    let cfg = SimConfig {
        duration_s: Some(600.0),
        ..SimConfig::default()
    };
    let t0 = Instant::now();
    let r = run_scenario("match", 0, &cfg).unwrap_or_else(|e| panic!("{e}"));
    println!(
        "600 s match: {:.3} s, {} deliveries",
        t0.elapsed().as_secs_f64(),
        r.deliveries.len()
    );
    assert!(kicks(&r).len() > 100);
}

#[test]
fn seed_scenarios_do_what_the_seed_describes() {
    for seed in 0..10 {
        // 1: crosses the view from y ≈ −1 to y > +0.9, 0.8–1.2 m in front.
        let r = run("seed-1-across", seed);
        let o = r.robots[0].pose_at(0.0);
        let end = r.truth[r.truth.len() - 1].position_m;
        assert!(
            r.truth[0].position_m[1] < -0.9 && end[1] > 0.9,
            "seed {seed}: {end:?}"
        );
        assert_eq!(kicks(&r)[0].2, "script");
        let dx = r.truth[0].position_m[0] - o.x_m;
        assert!((0.8..=1.2).contains(&dx));
        // 2: rolls away from ~0.3 m in front.
        let r = run("seed-2-away", seed);
        let start = r.truth[0].position_m;
        let end = r.truth[r.truth.len() - 1].position_m;
        let o: V2 = [r.robots[0].poses[0].1.x_m, r.robots[0].poses[0].1.y_m];
        assert!(
            (dist(start, o) - 0.3).abs() < 0.05 && dist(end, o) > 1.5,
            "seed {seed}"
        );
        // 3: comes towards the observer and never touches it.
        let r = run("seed-3-towards", seed);
        let o: V2 = [r.robots[0].poses[0].1.x_m, r.robots[0].poses[0].1.y_m];
        let closest = r
            .truth
            .iter()
            .map(|s| dist(s.position_m, o))
            .fold(f64::INFINITY, f64::min);
        assert!(
            closest < 0.7 && closest > ROBOT_RADIUS_M + 0.04,
            "seed {seed}: {closest}"
        );
        assert!(
            !r.events
                .iter()
                .any(|e| matches!(e, BallEvent::RobotContact { .. }))
        );
        // 6: moves away diagonally and passes in front of miro2 without touching it.
        let r = run("seed-6-front-diagonal", seed);
        let m2 = r.robots[1].pose_at(0.0);
        let m2: V2 = [m2.x_m, m2.y_m];
        let closest = r
            .truth
            .iter()
            .map(|s| dist(s.position_m, m2))
            .fold(f64::INFINITY, f64::min);
        assert!((0.25..0.7).contains(&closest), "seed {seed}: {closest}");
        assert!(
            r.robots
                .iter()
                .all(|t| t.poses.windows(2).all(|w| w[0].1 == w[1].1))
        );
    }
}

#[test]
fn odd_pitches_and_steps_still_run_inside_their_walls() {
    use proto::WallSide;
    let cfg = SimConfig {
        pitch: proto::Pitch {
            length_m: 2.4,
            width_m: 1.6,
            walls: vec![WallSide::XMax, WallSide::YMin],
            ..proto::Pitch::default()
        },
        physics_dt_s: 0.002,
        truth_rate_hz: 30.0,
        duration_s: Some(12.0),
        ..SimConfig::default()
    };
    let walls = Walls::new(&cfg.pitch);
    for name in scenario_names() {
        let r = run_scenario(name, 2, &cfg).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(r.truth.len(), 361, "{name}");
        for s in &r.truth {
            assert!(s.position_m[0] <= walls.limit[0] + 1e-9, "{name} {s:?}");
            assert!(s.position_m[1] >= -walls.limit[1] - 1e-9, "{name} {s:?}");
            assert!(s.position_m.iter().all(|p| p.is_finite()));
        }
        assert!(!r.deliveries.is_empty(), "{name}");
    }
}
