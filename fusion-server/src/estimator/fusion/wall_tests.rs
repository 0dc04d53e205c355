//! Bounces told from kicks: a wall a little elsewhere than configured, or one that returns
//! another share of the speed than learned, changes the ball's course where and how a
//! bounce does; a strike at a wall changes it as only a kick can.

use super::tests::{Lcg, T0, ingest, obs};
use super::*;

/// A puck-like ball (0.05 m/s²) sliding from (0, −0.2) along +x at `v` (x) and `vy` (y),
/// reflected at x = `wall_x` with restitution `e` (the y speed kept), then struck at
/// `strike_s` (if any) to `struck`: its position at `t`.
fn path(t: f64, v: f64, vy: f64, wall_x: f64, e: f64, strike: Option<(f64, [f64; 2])>) -> [f64; 2] {
    let decel = 0.05;
    let step = 1e-3;
    let (mut p, mut vel) = ([0.0, -0.2], [v, vy]);
    let mut s = 0.0;
    while s < t {
        if let Some((at, to)) = strike
            && s <= at
            && s + step > at
        {
            vel = to;
        }
        let sp = vel[0].hypot(vel[1]);
        if sp > 0.0 {
            let k = (1.0 - decel * step / sp).max(0.0);
            vel = [vel[0] * k, vel[1] * k];
        }
        p = [p[0] + vel[0] * step, p[1] + vel[1] * step];
        if p[0] > wall_x && vel[0] > 0.0 {
            p[0] = 2.0 * wall_x - p[0];
            vel[0] *= -e;
        }
        s += step;
    }
    p
}

/// One overhead tracker at 120 Hz with 3 mm noise sees `truth` for `secs`: the fused core.
fn watch(cfg: FusionConfig, secs: f64, truth: impl Fn(f64) -> [f64; 2]) -> Fusion {
    let mut f = Fusion::new(cfg);
    let mut rng = Lcg(31);
    for k in 0..(secs * 120.0) as u64 {
        let t = k as f64 / 120.0;
        let p = truth(t);
        let z = [p[0] + 0.003 * rng.normal(), p[1] + 0.003 * rng.normal()];
        ingest(&mut f, &obs("overhead", k, t, z, 0.003));
    }
    f
}

fn judging(on: bool) -> FusionConfig {
    let mut cfg = FusionConfig::default();
    cfg.tracker.bounces_at_walls = on;
    cfg
}

#[test]
fn a_bounce_off_a_wall_nearer_than_configured_is_a_bounce_not_a_kick() {
    // The default pitch's x wall stops the ball's centre at 1.95 − 0.04 m; the real one
    // stops it 5 cm sooner, and returns 0.8 of the speed where 0.5 is the prior.
    let x_max = Bounds::from_pitch(&FusionConfig::default().pitch).x_max;
    let truth = |t| path(t, 1.5, 0.2, x_max - 0.05, 0.8, None);
    let judged = watch(judging(true), 2.5, truth);
    let (kicks, bounces) = (
        judged.tracker().kicks_inferred(),
        judged.tracker().bounces_seen(),
    );
    assert_eq!(kicks, 0, "{bounces} bounces");
    assert!(bounces >= 1, "{bounces}");
    // Without the judgement the same bounce is a kick (the failure this guards against).
    let unjudged = watch(judging(false), 2.5, truth);
    assert!(unjudged.tracker().kicks_inferred() >= 1);
    // And the estimate after it moves as the ball does.
    let st = judged
        .ball_state(Stamp(T0).offset_secs(2.5))
        .expect("a state");
    let p = truth(2.5);
    assert!(
        (st.position_m[0] - p[0]).hypot(st.position_m[1] - p[1]) < 0.03,
        "{:?} vs {p:?}",
        st.position_m
    );
    assert!(st.velocity_mps[0] < -0.9, "{:?}", st.velocity_mps);
}

#[test]
fn a_strike_at_a_wall_is_still_a_kick() {
    // Just before the wall the puck is struck back and sideways: its speed along the wall
    // changes far more than any wall changes it.
    let x_max = Bounds::from_pitch(&FusionConfig::default().pitch).x_max;
    let wall_x = x_max;
    let arrive_s = (wall_x - 0.08) / 1.5;
    let truth = |t| path(t, 1.5, 0.0, wall_x, 0.8, Some((arrive_s, [-1.0, 1.2])));
    let f = watch(judging(true), arrive_s + 0.8, truth);
    assert!(
        f.tracker().kicks_inferred() >= 1,
        "{} kicks, {} bounces",
        f.tracker().kicks_inferred(),
        f.tracker().bounces_seen()
    );
}

#[test]
fn a_foreseen_bounce_is_counted_once() {
    // Where the walls and the restitution are as configured the flight foresees the bounce.
    let cfg = FusionConfig::default();
    let x_max = Bounds::from_pitch(&cfg.pitch).x_max;
    let e = cfg.tracker.motion.restitution;
    let truth = |t| path(t, 1.5, 0.2, x_max, e, None);
    let f = watch(cfg, 2.5, truth);
    assert_eq!(f.tracker().kicks_inferred(), 0);
    assert_eq!(f.tracker().bounces_seen(), 1);
    assert_eq!(f.counters().bounces_seen, 1);
}

#[test]
fn where_the_walls_stand_is_learned_from_the_bounces() {
    // A puck going back and forth between x walls that both stand 4 cm inside where the
    // pitch puts them: after a few bounces the flights turn where the puck does.
    let cfg = FusionConfig::default();
    let b = Bounds::from_pitch(&cfg.pitch);
    let (lo, hi) = (b.x_min + 0.04, b.x_max - 0.04);
    let truth = |t: f64| {
        let (mut x, mut v, mut s) = (0.0f64, 2.0f64, 0.0);
        let step = 1e-3;
        while s < t {
            v -= 0.05 * step * v.signum();
            x += v * step;
            if x > hi && v > 0.0 {
                x = 2.0 * hi - x;
                v *= -0.9;
            } else if x < lo && v < 0.0 {
                x = 2.0 * lo - x;
                v *= -0.9;
            }
            s += step;
        }
        [x, 0.1]
    };
    let f = watch(cfg, 8.0, truth);
    let learned = f.tracker().bounds();
    assert!(
        (learned.x_max - hi).abs() < 0.015,
        "{} vs {hi}",
        learned.x_max
    );
    assert!(
        (learned.x_min - lo).abs() < 0.015,
        "{} vs {lo}",
        learned.x_min
    );
    assert_eq!(learned.y_max, b.y_max, "no bounce measured the y walls");
    assert!(
        f.tracker().bounces_seen() >= 3,
        "{}",
        f.tracker().bounces_seen()
    );
    assert_eq!(f.tracker().kicks_inferred(), 0);
}
