use super::*;
use proto::Pitch;
use sim::Rng;
use tools::track_fixtures::Roll;
use tools::tracks::TrackSample;

fn bounds() -> Bounds {
    Bounds::from_pitch(&Pitch::default())
}

fn track(samples: Vec<TrackSample>) -> Track {
    Track {
        name: "roll".into(),
        samples,
    }
}

fn with_noise(mut samples: Vec<TrackSample>, sigma_m: f64, seed: u64) -> Vec<TrackSample> {
    let mut rng = Rng::new(seed);
    for s in &mut samples {
        s.position_m[0] += sigma_m * rng.normal();
        s.position_m[1] += sigma_m * rng.normal();
    }
    samples
}

#[test]
fn smoothed_velocity_of_a_straight_roll() {
    let (samples, _) = Roll {
        velocity_mps: [0.5, -0.2],
        decel_mps2: 0.0,
        duration_s: 1.0,
        ..Roll::default()
    }
    .run(&bounds());
    let ev = TrackEvents::of(&track(samples), &bounds(), 0.04);
    for v in &ev.velocity_mps {
        assert!(
            (v[0] - 0.5).abs() < 1e-6 && (v[1] + 0.2).abs() < 1e-6,
            "{v:?}"
        );
    }
    let s = ev.speed_at(0.5).unwrap_or_else(|| panic!("inside"));
    assert!((s - 0.5f64.hypot(0.2)).abs() < 1e-6);
    assert_eq!(ev.speed_at(1.5), None);
    assert!(ev.bounces.is_empty() && ev.pushes.is_empty());
}

#[test]
fn a_wall_bounce_is_found_and_timed_at_several_rates_and_with_noise() {
    let b = bounds();
    for (rate_hz, noise_m, tolerance_s) in
        [(100.0, 0.0, 0.003), (30.0, 0.0, 0.01), (60.0, 0.003, 0.02)]
    {
        let roll = Roll {
            rate_hz,
            ..Roll::default()
        };
        let (samples, truth) = roll.run(&b);
        assert_eq!(truth.len(), 1, "the fixture bounces once");
        let ev = TrackEvents::of(&track(with_noise(samples, noise_m, 3)), &b, 0.04);
        assert_eq!(ev.bounces.len(), 1, "{rate_hz} Hz: {:?}", ev.bounces);
        let bounce = ev.bounces[0];
        assert_eq!(bounce.wall, WallSide::XMax);
        assert!(
            (bounce.t_s - truth[0]).abs() < tolerance_s,
            "{rate_hz} Hz: {} vs {}",
            bounce.t_s,
            truth[0]
        );
        assert!(
            ev.pushes.is_empty(),
            "{rate_hz} Hz: a bounce is no push: {:?}",
            ev.pushes
        );
        assert_eq!(
            ev.next_bounce(truth[0] - 0.5).map(|x| x.wall),
            Some(WallSide::XMax)
        );
        assert!(ev.next_bounce(truth[0] + 0.1).is_none());
    }
}

#[test]
fn a_head_on_bounce_and_a_corner_are_bounces_not_pushes() {
    let b = bounds();
    let (samples, truth) = Roll {
        start_m: [0.0, 0.0],
        velocity_mps: [1.5, 0.0],
        restitution: 0.5,
        ..Roll::default()
    }
    .run(&b);
    let ev = TrackEvents::of(&track(samples), &b, 0.04);
    assert_eq!(ev.bounces.len(), truth.len());
    assert!(ev.pushes.is_empty(), "{:?}", ev.pushes);
    let (samples, truth) = Roll {
        start_m: [0.5, 0.2],
        velocity_mps: [1.6, 1.2],
        ..Roll::default()
    }
    .run(&b);
    assert!(truth.len() >= 2, "{truth:?}");
    let ev = TrackEvents::of(&track(samples), &b, 0.04);
    assert_eq!(
        ev.bounces.len(),
        truth.len(),
        "{:?} vs {truth:?}",
        ev.bounces
    );
    for (found, t) in ev.bounces.iter().zip(&truth) {
        assert!((found.t_s - t).abs() < 0.005, "{} vs {t}", found.t_s);
    }
}

#[test]
fn a_ball_that_stops_by_the_wall_or_rests_on_it_does_not_bounce() {
    let b = bounds();
    // Stops 5 cm short of the wall: 1.5 m at 0.3 m/s² from 0.949 m/s.
    let (samples, truth) = Roll {
        start_m: [b.x_max - 1.55, 0.0],
        velocity_mps: [(2.0f64 * 0.3 * 1.5).sqrt(), 0.0],
        ..Roll::default()
    }
    .run(&b);
    assert!(truth.is_empty());
    let ev = TrackEvents::of(&track(with_noise(samples, 0.002, 5)), &b, 0.04);
    assert!(ev.bounces.is_empty(), "{:?}", ev.bounces);
    let resting: Vec<TrackSample> = (0..300)
        .map(|k| TrackSample {
            t_s: k as f64 / 60.0,
            position_m: [b.x_max, 0.3],
        })
        .collect();
    let ev = TrackEvents::of(&track(with_noise(resting, 0.003, 6)), &b, 0.04);
    assert!(ev.bounces.is_empty() && ev.pushes.is_empty());
}

#[test]
fn a_kick_from_rest_is_a_push_near_its_time() {
    let b = bounds();
    let (samples, _) = Roll {
        kick_at_s: 1.0,
        duration_s: 2.0,
        ..Roll::default()
    }
    .run(&b);
    let ev = TrackEvents::of(&track(samples), &b, 0.04);
    assert_eq!(ev.pushes.len(), 1, "{:?}", ev.pushes);
    let (from, to) = ev.pushes[0];
    assert!(from <= 1.0 && to >= 1.0 && to - from < 0.4, "{from}..{to}");
    assert!(ev.pushed_between(0.5, 1.0));
    assert!(!ev.pushed_between(0.2, 0.8));
    assert!(!ev.pushed_between(1.3, 2.0));
}

#[test]
fn a_strike_that_slows_and_turns_the_ball_is_a_course_change_and_a_bounce_is_not() {
    let b = bounds();
    // 1.2 m/s along +x, struck at t = 1 s (x = 0) to 0.5 m/s along +y: its speed falls,
    // so it is no push, but it changed course far from any wall.
    let samples: Vec<TrackSample> = (0..200)
        .map(|k| {
            let t = k as f64 / 100.0;
            let p = if t < 1.0 {
                [-1.2 + 1.2 * t, 0.0]
            } else {
                [0.0, 0.5 * (t - 1.0)]
            };
            TrackSample {
                t_s: t,
                position_m: p,
            }
        })
        .collect();
    let ev = TrackEvents::of(&track(with_noise(samples, 0.002, 3)), &b, 0.04);
    assert!(ev.pushes.is_empty(), "{:?}", ev.pushes);
    assert!(
        ev.course_changed_between(0.9, 1.1),
        "{:?}",
        ev.course_changes
    );
    assert!(!ev.course_changed_between(0.0, 0.7));
    assert!(!ev.course_changed_between(1.3, 2.0));
    // A head-on bounce changes the velocity as much, at the wall: no course change.
    let (samples, truth) = Roll {
        start_m: [0.0, 0.0],
        velocity_mps: [1.5, 0.0],
        restitution: 0.8,
        ..Roll::default()
    }
    .run(&b);
    assert_eq!(truth.len(), 1);
    let ev = TrackEvents::of(&track(with_noise(samples, 0.002, 4)), &b, 0.04);
    assert_eq!(ev.bounces.len(), 1);
    assert!(ev.course_changes.is_empty(), "{:?}", ev.course_changes);
}

#[test]
fn a_ball_that_comes_to_rest_is_a_stop_where_it_rests() {
    let b = bounds();
    // Rolls from rest after 0.5 s, stops, and is seen at rest for a second.
    let (samples, _) = Roll {
        start_m: [-1.0, 0.0],
        velocity_mps: [0.9, 0.0],
        kick_at_s: 0.5,
        duration_s: 5.5,
        ..Roll::default()
    }
    .run(&b);
    let rest_x = -1.0 + 0.9 * 0.9 / (2.0 * 0.3);
    let ev = TrackEvents::of(&track(with_noise(samples, 0.003, 9)), &b, 0.04);
    assert_eq!(ev.stops.len(), 1, "{:?}", ev.stops);
    let (t, p) = ev.stops[0];
    assert!((p[0] - rest_x).abs() < 0.02, "{p:?} vs {rest_x}");
    // Its speed falls below 0.1 m/s 3.17 s in (a third of a second before it stops).
    assert!((t - 3.17).abs() < 0.25, "{t}");
    assert_eq!(ev.next_stop(1.0).map(|s| s.0), Some(t));
    assert_eq!(ev.next_stop(t + 0.1), None);
}
