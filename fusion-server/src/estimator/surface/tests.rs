use super::*;

/// A small deterministic normal generator.
struct Noise(u64);

impl Noise {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// The true physics of one test world: a box `half` wide each way, two-phase friction,
/// walls that return `restitution` of the normal speed and `tangential` of the other.
#[derive(Clone, Copy)]
struct World {
    half: [f64; 2],
    slide: f64,
    roll: f64,
    ratio: f64,
    restitution: f64,
    tangential: f64,
}

enum Event {
    /// Time, position, the true speed (what the filter would say, roughly).
    Seen(f64, [f64; 2], f64),
    Bounce(BounceEvent),
    Kick(f64, f64),
}

/// Kicks from `starts` (position, velocity), each followed for `each_s`; sightings every
/// `dt_s` with noise `sigma_m`; events as the tracker delivers them (a bounce before the
/// first sighting after it).
fn play(
    w: &World,
    starts: &[([f64; 2], [f64; 2])],
    each_s: f64,
    dt_s: f64,
    sigma_m: f64,
    rng: &mut Noise,
) -> Vec<Event> {
    let step = 1e-4;
    let mut out = Vec::new();
    let mut t = 0.0;
    for (p0, v0) in starts {
        let (mut p, mut v) = (*p0, *v0);
        let kick_speed = v[0].hypot(v[1]);
        let mut sliding = w.slide > w.roll;
        out.push(Event::Kick(t, kick_speed));
        let mut next_seen = t + dt_s;
        let end = t + each_s;
        let mut pending: Vec<BounceEvent> = Vec::new();
        while t < end {
            let s = v[0].hypot(v[1]);
            if s > 0.0 {
                if sliding && s <= w.ratio * kick_speed {
                    sliding = false;
                }
                let a = if sliding { w.slide } else { w.roll };
                let k = (s - a * step).max(0.0) / s;
                v = [v[0] * k, v[1] * k];
            }
            for i in 0..2 {
                p[i] += v[i] * step;
                if p[i].abs() > w.half[i] {
                    let wall = p[i].signum() * w.half[i];
                    pending.push(BounceEvent {
                        t_s: t,
                        axis: i,
                        wall_m: wall,
                        normal_velocity_in_mps: v[i],
                        corner: false,
                    });
                    p[i] = 2.0 * wall - p[i];
                    v[i] *= -w.restitution;
                    v[1 - i] *= w.tangential;
                    sliding = false;
                }
            }
            t += step;
            if t >= next_seen {
                for b in pending.drain(..) {
                    out.push(Event::Bounce(b));
                }
                let z = [p[0] + sigma_m * rng.normal(), p[1] + sigma_m * rng.normal()];
                out.push(Event::Seen(t, z, v[0].hypot(v[1])));
                next_seen += dt_s;
            }
        }
    }
    out
}

fn feed(s: &mut Surface, events: &[Event], sigma_m: f64) {
    for e in events {
        match e {
            Event::Seen(t, z, speed) => s.sighting(*t, *z, sigma_m * sigma_m, *speed),
            Event::Bounce(b) => s.bounce(*b),
            Event::Kick(t, v) => s.kick(*t, *v),
        }
    }
}

fn straight_kicks(n: usize, speed: f64, rng: &mut Noise) -> Vec<([f64; 2], [f64; 2])> {
    (0..n)
        .map(|_| {
            let h = rng.uniform() * std::f64::consts::TAU;
            ([0.0, 0.0], [speed * h.cos(), speed * h.sin()])
        })
        .collect()
}

fn big_room(roll: f64, slide: f64) -> World {
    World {
        half: [50.0, 50.0],
        slide,
        roll,
        ratio: 0.64,
        restitution: 0.6,
        tangential: 0.9,
    }
}

#[test]
fn the_same_defaults_learn_a_table_and_a_carpet() {
    for (roll, slide) in [(0.05, 0.05), (0.6, 3.0), (0.3, 3.0)] {
        let mut rng = Noise(7);
        let w = big_room(roll, slide);
        let kicks = straight_kicks(6, 1.5, &mut rng);
        let events = play(&w, &kicks, 2.0, 1.0 / 60.0, 0.005, &mut rng);
        let mut s = Surface::new(
            &MotionModel::default(),
            SurfaceConfig::default(),
            true,
            true,
        );
        feed(&mut s, &events, 0.005);
        let d = s.rolling_decel();
        assert!(d.samples >= 5, "{roll}: {d:?}");
        assert!(
            (d.mean - roll).abs() < 0.03 + 0.05 * roll,
            "true rolling deceleration {roll}, learned {d:?}"
        );
        if slide > roll {
            let sl = s.slide_decel();
            assert!(sl.samples >= 3, "{sl:?}");
            assert!((sl.mean - slide).abs() < 0.6, "true slide {slide}, {sl:?}");
        }
    }
}

#[test]
fn a_slide_learned_away_from_a_wrong_prior() {
    let mut rng = Noise(3);
    let w = big_room(0.3, 3.0);
    let kicks = straight_kicks(10, 3.0, &mut rng);
    let events = play(&w, &kicks, 2.0, 1.0 / 100.0, 0.003, &mut rng);
    let base = MotionModel {
        slide_decel_mps2: 1.0,
        ..MotionModel::default()
    };
    let mut s = Surface::new(&base, SurfaceConfig::default(), true, true);
    feed(&mut s, &events, 0.003);
    let sl = s.slide_decel();
    assert!((sl.mean - 3.0).abs() < 0.5, "{sl:?}");
    assert!((s.model(&base).slide_decel_mps2 - 3.0).abs() < 0.5);
}

#[test]
fn where_a_hard_kick_stops_sliding_is_learned() {
    // Kicks at 5 m/s slide at 4 m/s² down to 0.5 of the kick's speed (the prior says 0.64);
    // seen at 130 Hz with 3 mm noise.
    let mut rng = Noise(11);
    let w = World {
        ratio: 0.5,
        ..big_room(0.3, 4.0)
    };
    let kicks = straight_kicks(6, 5.0, &mut rng);
    let events = play(&w, &kicks, 2.5, 1.0 / 130.0, 0.003, &mut rng);
    let base = MotionModel {
        slide_decel_mps2: 4.0,
        ..MotionModel::default()
    };
    let mut s = Surface::new(&base, SurfaceConfig::default(), true, true);
    feed(&mut s, &events, 0.003);
    let r = s.roll_ratio();
    assert!(r.samples >= 4, "{r:?}");
    assert!((r.mean - 0.5).abs() < 0.04, "{r:?}");
    assert!((s.model(&base).roll_ratio - r.mean).abs() < 1e-12);
    // Where it is the prior's, it stays there.
    let w = World { ratio: 0.64, ..w };
    let events = play(&w, &kicks, 2.5, 1.0 / 130.0, 0.003, &mut rng);
    let mut s = Surface::new(&base, SurfaceConfig::default(), true, true);
    feed(&mut s, &events, 0.003);
    assert!(
        (s.roll_ratio().mean - 0.64).abs() < 0.03,
        "{:?}",
        s.roll_ratio()
    );
}

fn bouncy_world() -> World {
    World {
        half: [1.0, 0.7],
        slide: 0.1,
        roll: 0.1,
        ratio: 0.64,
        restitution: 0.7,
        tangential: 0.85,
    }
}

#[test]
fn every_bounce_teaches_restitution_and_tangential_retention() {
    let mut rng = Noise(11);
    let w = bouncy_world();
    let kicks = straight_kicks(8, 2.5, &mut rng);
    let events = play(&w, &kicks, 2.0, 1.0 / 120.0, 0.003, &mut rng);
    let bounces = events
        .iter()
        .filter(|e| matches!(e, Event::Bounce(_)))
        .count();
    let mut s = Surface::new(
        &MotionModel::default(),
        SurfaceConfig::default(),
        true,
        true,
    );
    feed(&mut s, &events, 0.003);
    let (e, t) = (s.restitution(), s.tangential_retention());
    assert!(
        e.samples as usize * 2 >= bounces,
        "{} of {bounces} bounces measured",
        e.samples
    );
    assert!((e.mean - 0.7).abs() < 0.04, "{e:?}");
    assert!(t.samples >= 5, "{t:?}");
    assert!((t.mean - 0.85).abs() < 0.05, "{t:?}");
    // And the floor, between the bounces.
    let d = s.rolling_decel();
    assert!((d.mean - 0.1).abs() < 0.06, "{d:?}");
}

#[test]
fn a_few_biased_bounces_do_not_drag_the_walls() {
    let mut rng = Noise(5);
    let w = bouncy_world();
    let kicks = straight_kicks(6, 2.5, &mut rng);
    let good = play(&w, &kicks, 2.0, 1.0 / 120.0, 0.003, &mut rng);
    let mut s = Surface::new(
        &MotionModel::default(),
        SurfaceConfig::default(),
        true,
        true,
    );
    feed(&mut s, &good, 0.003);
    let settled = s.restitution();
    // Three bounces off something soft (a robot against the wall): 0.2.
    let soft = World {
        restitution: 0.2,
        ..w
    };
    let kicks = straight_kicks(1, 2.5, &mut rng);
    let bad = play(&soft, &kicks, 0.9, 1.0 / 120.0, 0.003, &mut rng);
    let n_bad = bad.iter().filter(|e| matches!(e, Event::Bounce(_))).count();
    assert!(n_bad >= 1);
    feed(&mut s, &bad, 0.003);
    let after = s.restitution();
    assert!(
        (after.mean - settled.mean).abs() < 0.1,
        "{settled:?} → {after:?} after {n_bad} soft bounces"
    );
}

#[test]
fn no_samples_no_drift() {
    let base = MotionModel {
        restitution: 0.63,
        ..MotionModel::default()
    };
    let mut s = Surface::new(&base, SurfaceConfig::default(), true, true);
    // A ball at rest, seen for a minute: nothing to learn from.
    let mut rng = Noise(1);
    for k in 0..3600 {
        let t = f64::from(k) / 60.0;
        s.sighting(t, [0.2 + 0.01 * rng.normal(), 0.1], 1e-4, 0.0);
    }
    assert_eq!(s.restitution().mean, 0.63);
    assert_eq!(s.rolling_decel().mean, base.decel_mps2);
    assert_eq!(s.version(), 0);
}

#[test]
fn a_bounce_that_is_not_at_the_wall_is_refused() {
    // The flight said "wall", but the ball turned half a metre short of it (a robot).
    let mut s = Surface::new(
        &MotionModel::default(),
        SurfaceConfig::default(),
        true,
        true,
    );
    let mut rng = Noise(9);
    s.kick(0.0, 2.0);
    let v_in = [1.5, 0.5];
    let turn_s = 0.5;
    for k in 1..=100 {
        let t = f64::from(k) * 0.01;
        let p = if t < turn_s {
            [v_in[0] * t, v_in[1] * t]
        } else {
            let p0 = [v_in[0] * turn_s, v_in[1] * turn_s];
            [p0[0] - 0.8 * (t - turn_s), p0[1] + 0.45 * (t - turn_s)]
        };
        if k == 51 {
            s.bounce(BounceEvent {
                t_s: turn_s,
                axis: 0,
                wall_m: 1.25,
                normal_velocity_in_mps: v_in[0],
                corner: false,
            });
        }
        let z = [p[0] + 0.002 * rng.normal(), p[1] + 0.002 * rng.normal()];
        s.sighting(t, z, 4e-6, 1.5);
    }
    assert_eq!(s.restitution().samples, 0);
    assert!(s.counts().refused >= 1);
}

#[test]
fn nothing_is_learned_when_learning_is_off() {
    let mut rng = Noise(2);
    let w = bouncy_world();
    let kicks = straight_kicks(3, 2.5, &mut rng);
    let events = play(&w, &kicks, 2.0, 1.0 / 120.0, 0.003, &mut rng);
    let mut s = Surface::new(
        &MotionModel::default(),
        SurfaceConfig::default(),
        false,
        false,
    );
    feed(&mut s, &events, 0.003);
    assert_eq!(s.counts(), SurfaceCounts::default());
    assert_eq!(s.model(&MotionModel::default()), MotionModel::default());
}

#[test]
fn poison_sightings_are_ignored() {
    let mut s = Surface::new(
        &MotionModel::default(),
        SurfaceConfig::default(),
        true,
        true,
    );
    s.kick(0.0, 1.0);
    for k in 0..200 {
        let t = f64::from(k) / 100.0;
        s.sighting(t, [f64::NAN, 0.0], 1e-4, 1.0);
        s.sighting(t, [0.0, 0.0], -1.0, 1.0);
        s.sighting(t, [0.0, 0.0], f64::INFINITY, 1.0);
    }
    s.kick(3.0, 1.0);
    assert_eq!(s.counts().rolls, 0);
    assert!(s.rolling_decel().mean.is_finite());
}
