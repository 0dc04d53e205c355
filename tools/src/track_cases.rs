//! Regression tracks of situations the simulator's scenarios do not produce, for
//! `evaluate --tracks` (`sim_track --case NAME`):
//!
//! - `relocations`: a ball kicked across a 9 m × 6 m walled pitch, left to stop, then
//!   picked up and put down elsewhere (no samples while it is carried), and kicked again,
//!   ten times. After each kick it slides at 3 m/s² until its speed falls to 0.64 of the
//!   kick's, then rolls at 0.3 m/s² (the two-phase model of the leading small-size trackers);
//!   walls return 0.6 of the normal speed and 0.9 of the tangential.
//! - `puck`: a light, nearly frictionless puck on a 2 m × 1 m walled table (0.05 m/s²,
//!   restitution 0.85, no tangential loss), struck every 2.5 s at 2–4 m/s: many bounces a
//!   second.
//!
//! - `puck-hits`: the air-hockey table of a real recording's kind: a 2 m × 1 m table, little
//!   friction (0.05 m/s²), walls returning 0.9 of the normal speed, struck by mallets
//!   every 0.3–1.5 s at speeds of median about 1.5 m/s and up to 5 m/s (most of its motion
//!   between strikes is bounces off the walls); 60 s at 120 Hz.
//! - `puck-mallets`: an air-hockey puck unlike the core's model in every way a recording
//!   differs: a 1.95 m × 1.04 m table, drag that grows with speed (0.02 m/s² plus 0.08 /s),
//!   walls that return 0.75–0.95 of the normal speed and 0.8–1.0 of the tangential and
//!   turn the puck a few degrees more (spin, an uneven rail), mallets that push it for
//!   15–40 ms rather than strike it at an instant (a third of them hiding it while they do
//!   and up to 60 ms after), a tracker's own 1 mm of jitter and 0.5 ms of timing jitter;
//!   struck every 0.3–1.5 s at 0.5–6 m/s; 60 s at 120 Hz.
//! - `kick-on-arrival`: as `relocations`, but the ball is kicked the moment it is put
//!   down (after 0.05 s), so a tracker sees a ball appear somewhere new already moving.
//! - `hard-kicks`: as `relocations`, on a 9.6 m × 6.6 m pitch, kicked at 3–7 m/s by a
//!   floor unlike the core's starting model: it slides at 4.5 m/s² until its speed falls to
//!   0.55 of the kick's (longer than the core's 3 m/s² to 0.64 after a hard kick), then
//!   rolls at 0.25 m/s² plus 0.06 m/s² per m/s (a rolling resistance that grows with
//!   speed, which the core's constant deceleration does not have); walls return 0.5 of the
//!   normal speed and 0.8 of the tangential.
//!
//! All are made here, from physics written here: they are *synthetic*, never to be taken
//! for recordings. They exercise the evaluation on motion the simulator's scenarios lack
//! (relocations, long bounce sequences); only real recordings say how the core does on a
//! real floor.

use crate::tracks::TrackSample;
use sim::Rng;

/// The cases, by name.
pub const CASES: [&str; 6] = [
    "relocations",
    "puck",
    "puck-hits",
    "puck-mallets",
    "kick-on-arrival",
    "hard-kicks",
];

/// One case's track, its pitch (`LxW`, for `--pitch`) and its `# source:` line.
#[derive(Debug, Clone)]
pub struct Case {
    pub samples: Vec<TrackSample>,
    pub pitch: &'static str,
    pub source: String,
}

struct Physics {
    half: [f64; 2],
    slide_mps2: f64,
    roll_mps2: f64,
    /// Extra rolling deceleration per m/s of speed.
    roll_per_mps: f64,
    /// Sliding ends at this share of the kick's speed.
    slide_until: f64,
    restitution: f64,
    tangential: f64,
}

struct Ball {
    p: [f64; 2],
    v: [f64; 2],
    kick_speed: f64,
}

impl Physics {
    /// Advances by `dt` (small): friction, then walls.
    fn step(&self, b: &mut Ball, dt: f64) {
        let speed = b.v[0].hypot(b.v[1]);
        if speed > 0.0 {
            let a = if speed > self.slide_until * b.kick_speed {
                self.slide_mps2
            } else {
                self.roll_mps2 + self.roll_per_mps * speed
            };
            let k = (speed - a * dt).max(0.0) / speed;
            b.v = [b.v[0] * k, b.v[1] * k];
        }
        for i in 0..2 {
            b.p[i] += b.v[i] * dt;
            if b.p[i].abs() > self.half[i] {
                b.p[i] = b.p[i].signum() * (2.0 * self.half[i] - b.p[i].abs());
                b.v[i] *= -self.restitution;
                let j = 1 - i;
                b.v[j] *= self.tangential;
            }
        }
    }

    fn kick(&self, b: &mut Ball, speed: f64, heading: f64) {
        b.v = [speed * heading.cos(), speed * heading.sin()];
        b.kick_speed = speed;
    }
}

const STEP_S: f64 = 0.001;

/// The named case, seeded.
pub fn case(name: &str, seed: u64) -> Option<Case> {
    let mut rng = Rng::new(seed);
    match name {
        "relocations" => Some(relocations(&mut rng, seed, Rest::Settle)),
        "kick-on-arrival" => Some(relocations(&mut rng, seed, Rest::KickOnArrival)),
        "hard-kicks" => Some(hard_kicks(&mut rng, seed)),
        "puck" => Some(puck(&mut rng, seed)),
        "puck-hits" => Some(puck_hits(&mut rng, seed)),
        "puck-mallets" => Some(puck_mallets(&mut rng, seed)),
        _ => None,
    }
}

/// How long a relocated ball rests before its kick.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Rest {
    /// 0.5–1 s: a tracker sees it still first.
    Settle,
    /// 0.05 s: kicked as it is put down.
    KickOnArrival,
}

fn relocations(rng: &mut Rng, seed: u64, rest: Rest) -> Case {
    let (len, wid, r) = (9.0, 6.0, 0.04);
    let ph = Physics {
        half: [len / 2.0 - r, wid / 2.0 - r],
        slide_mps2: 3.0,
        roll_mps2: 0.3,
        roll_per_mps: 0.0,
        slide_until: 0.64,
        restitution: 0.6,
        tangential: 0.9,
    };
    let samples = kicked_about(rng, &ph, rest, (1.5, 4.0), [3.5, 2.3], 0.0);
    let (name, kicked) = match rest {
        Rest::Settle => ("relocations", ""),
        Rest::KickOnArrival => ("kick-on-arrival", ", kicked 0.05 s after it is put down"),
    };
    Case {
        samples,
        pitch: "9x6",
        source: format!(
            "SYNTHETIC, not a real recording: ten kicks on a 9 m x 6 m walled pitch, the ball \
             picked up and put down 2 m or more away between them{kicked}; slide 3 m/s2 to \
             0.64 of the kick speed then roll 0.3 m/s2, walls 0.6 normal and 0.9 tangential; \
             100 Hz; written by `cargo run --release -p tools --bin sim_track -- --case \
             {name} --seed {seed}`"
        ),
    }
}

fn hard_kicks(rng: &mut Rng, seed: u64) -> Case {
    let (len, wid, r) = (9.6, 6.6, 0.04);
    let ph = Physics {
        half: [len / 2.0 - r, wid / 2.0 - r],
        slide_mps2: 4.5,
        roll_mps2: 0.25,
        roll_per_mps: 0.06,
        slide_until: 0.55,
        restitution: 0.5,
        tangential: 0.8,
    };
    let samples = kicked_about(rng, &ph, Rest::Settle, (3.0, 7.0), [3.8, 2.6], 1.0);
    Case {
        samples,
        pitch: "9.6x6.6",
        source: format!(
            "SYNTHETIC, not a real recording: ten kicks at 3-7 m/s on a 9.6 m x 6.6 m walled \
             pitch, each seen at rest for 1 s, then picked up and put down 2 m or more away; \
             slide \
             4.5 m/s2 to 0.55 of the kick speed then roll 0.25 m/s2 plus 0.06 m/s2 per m/s, \
             walls 0.5 normal and 0.8 tangential; 100 Hz; written by `cargo run --release -p \
             tools --bin sim_track -- --case hard-kicks --seed {seed}`"
        ),
    }
}

/// Ten kicks at `speeds` (m/s, uniform), each left to stop and seen at rest for
/// `rest_after_s`, the ball then carried 1–2 s (no samples) and put down at least 2 m away,
/// within ±`spots_m` of the centre; 100 Hz.
fn kicked_about(
    rng: &mut Rng,
    ph: &Physics,
    rest: Rest,
    speeds: (f64, f64),
    spots_m: [f64; 2],
    rest_after_s: f64,
) -> Vec<TrackSample> {
    let rate_s = 1.0 / 100.0;
    let mut samples = Vec::new();
    let (mut t, mut next_sample) = (0.0, 0.0);
    let spot = |rng: &mut Rng| {
        [
            rng.range(-spots_m[0], spots_m[0]),
            rng.range(-spots_m[1], spots_m[1]),
        ]
    };
    let mut b = Ball {
        p: spot(rng),
        v: [0.0, 0.0],
        kick_speed: 0.0,
    };
    for kick in 0..10 {
        // At rest for a moment, then kicked.
        let rest_s = match rest {
            Rest::Settle => rng.range(0.5, 1.0),
            Rest::KickOnArrival => 0.05,
        };
        let speed = rng.range(speeds.0, speeds.1);
        let heading = rng.range(-std::f64::consts::PI, std::f64::consts::PI);
        let mut clock = 0.0;
        let mut kicked = false;
        let mut stopped_s: Option<f64> = None;
        loop {
            if !kicked && clock >= rest_s {
                ph.kick(&mut b, speed, heading);
                kicked = true;
            }
            if t >= next_sample - 1e-9 {
                samples.push(TrackSample {
                    t_s: t,
                    position_m: b.p,
                });
                next_sample += rate_s;
            }
            ph.step(&mut b, STEP_S);
            t += STEP_S;
            clock += STEP_S;
            if kicked && b.v == [0.0, 0.0] {
                stopped_s.get_or_insert(clock);
            }
            if stopped_s.is_some_and(|at| clock > rest_s + 1.0 && clock >= at + rest_after_s) {
                break;
            }
        }
        if kick < 9 {
            // Picked up and carried for 1–2 s, unseen, then put down at least 2 m away.
            t += rng.range(1.0, 2.0);
            next_sample = t;
            let from = b.p;
            b.p = loop {
                let p = spot(rng);
                if (p[0] - from[0]).hypot(p[1] - from[1]) > 2.0 {
                    break p;
                }
            };
        }
    }
    samples
}

/// A strike of a puck: its speed (m/s), heading (rad) and the time to the next (s).
struct Strike {
    speed: f64,
    heading: f64,
    gap_s: f64,
}

/// A puck on a 2 m × 1 m walled table (0.05 m/s², no tangential loss), struck from 0.2 s
/// on as `strike` says, sampled at 120 Hz for `duration_s`.
fn struck_puck(
    rng: &mut Rng,
    restitution: f64,
    duration_s: f64,
    strike: impl Fn(&mut Rng) -> Strike,
) -> Vec<TrackSample> {
    let (len, wid, r) = (2.0, 1.0, 0.03);
    let ph = Physics {
        half: [len / 2.0 - r, wid / 2.0 - r],
        slide_mps2: 0.05,
        roll_mps2: 0.05,
        roll_per_mps: 0.0,
        slide_until: 0.0,
        restitution,
        tangential: 1.0,
    };
    let rate_s = 1.0 / 120.0;
    let mut samples = Vec::new();
    let mut b = Ball {
        p: [0.0, 0.0],
        v: [0.0, 0.0],
        kick_speed: 0.0,
    };
    let (mut t, mut next_sample, mut next_strike) = (0.0, 0.0, 0.2);
    while t < duration_s {
        if t >= next_strike {
            let s = strike(rng);
            ph.kick(&mut b, s.speed, s.heading);
            next_strike += s.gap_s;
        }
        if t >= next_sample - 1e-9 {
            samples.push(TrackSample {
                t_s: t,
                position_m: b.p,
            });
            next_sample += rate_s;
        }
        ph.step(&mut b, STEP_S);
        t += STEP_S;
    }
    samples
}

fn puck(rng: &mut Rng, seed: u64) -> Case {
    let samples = struck_puck(rng, 0.85, 30.0, |rng| {
        let heading = rng.range(-std::f64::consts::PI, std::f64::consts::PI);
        Strike {
            speed: rng.range(2.0, 4.0),
            heading,
            gap_s: 2.5,
        }
    });
    Case {
        samples,
        pitch: "2x1",
        source: format!(
            "SYNTHETIC, not a real recording: a puck on a 2 m x 1 m walled table, 0.05 m/s2, \
             restitution 0.85, struck every 2.5 s at 2-4 m/s; 120 Hz, 30 s; written by \
             `cargo run --release -p tools --bin sim_track -- --case puck --seed {seed}`"
        ),
    }
}

fn puck_hits(rng: &mut Rng, seed: u64) -> Case {
    let samples = struck_puck(rng, 0.9, 60.0, |rng| {
        // Most strikes gentle, a few hard: 0.5 m/s plus 4.5 m/s times u³.
        let u = rng.range(0.0, 1.0);
        let speed = 0.5 + 4.5 * u * u * u;
        let heading = rng.range(-std::f64::consts::PI, std::f64::consts::PI);
        Strike {
            speed,
            heading,
            gap_s: rng.range(0.3, 1.5),
        }
    });
    Case {
        samples,
        pitch: "2x1",
        source: format!(
            "SYNTHETIC, not a real recording: a puck on a 2 m x 1 m walled table, 0.05 m/s2, \
             restitution 0.9, struck every 0.3-1.5 s at 0.5-5 m/s (most strikes gentle); \
             120 Hz, 60 s; written by `cargo run --release -p tools --bin sim_track -- --case \
             puck-hits --seed {seed}`"
        ),
    }
}

/// A mallet's push under way: the puck's velocity moves from `from` to `to` until `end_s`.
struct Push {
    from: [f64; 2],
    to: [f64; 2],
    start_s: f64,
    end_s: f64,
    /// The puck is hidden until this time.
    hidden_until_s: f64,
}

fn puck_mallets(rng: &mut Rng, seed: u64) -> Case {
    let (len, wid, r) = (1.95, 1.04, 0.032);
    let half = [len / 2.0 - r, wid / 2.0 - r];
    let (drag_mps2, drag_per_s) = (0.02, 0.08);
    let rate_s = 1.0 / 120.0;
    let duration_s = 60.0;
    let mut samples = Vec::new();
    let (mut p, mut v) = ([0.0_f64, 0.0_f64], [0.0_f64, 0.0_f64]);
    let (mut t, mut next_sample, mut next_strike) = (0.0, 0.0, 0.2);
    let mut push: Option<Push> = None;
    while t < duration_s {
        if push.is_none() && t >= next_strike {
            // Most strikes gentle, a few hard: 0.5 m/s plus 5.5 m/s times u³.
            let u = rng.uniform();
            let speed = 0.5 + 5.5 * u * u * u;
            let heading = rng.range(-std::f64::consts::PI, std::f64::consts::PI);
            let contact_s = rng.range(0.015, 0.04);
            let hidden_s = if rng.chance(1.0 / 3.0) {
                contact_s + rng.range(0.0, 0.06)
            } else {
                0.0
            };
            push = Some(Push {
                from: v,
                to: [speed * heading.cos(), speed * heading.sin()],
                start_s: t,
                end_s: t + contact_s,
                hidden_until_s: t + hidden_s,
            });
            next_strike = t + rng.range(0.3, 1.5);
        }
        match &push {
            Some(m) if t < m.end_s => {
                let f = ((t - m.start_s) / (m.end_s - m.start_s)).clamp(0.0, 1.0);
                v = [
                    m.from[0] + (m.to[0] - m.from[0]) * f,
                    m.from[1] + (m.to[1] - m.from[1]) * f,
                ];
            }
            _ => {
                let speed = v[0].hypot(v[1]);
                if speed > 0.0 {
                    let a = drag_mps2 + drag_per_s * speed;
                    let k = (speed - a * STEP_S).max(0.0) / speed;
                    v = [v[0] * k, v[1] * k];
                }
            }
        }
        let hidden = push.as_ref().is_some_and(|m| t < m.hidden_until_s);
        if push.as_ref().is_some_and(|m| t >= m.end_s && !hidden) {
            push = None;
        }
        if t >= next_sample - 1e-9 {
            if !hidden {
                samples.push(TrackSample {
                    t_s: t + 0.0005 * rng.normal(),
                    position_m: [p[0] + 0.001 * rng.normal(), p[1] + 0.001 * rng.normal()],
                });
            }
            next_sample += rate_s;
        }
        for i in 0..2 {
            p[i] += v[i] * STEP_S;
            if p[i].abs() > half[i] {
                p[i] = p[i].signum() * (2.0 * half[i] - p[i].abs());
                let j = 1 - i;
                v[i] *= -rng.range(0.75, 0.95);
                v[j] *= rng.range(0.8, 1.0);
                // Spin and an uneven rail turn it a few degrees more.
                let turn = 3f64.to_radians() * rng.normal();
                let (c, s) = (turn.cos(), turn.sin());
                v = [c * v[0] - s * v[1], s * v[0] + c * v[1]];
                // A turn may not send it back into the rail it left.
                if v[i] * p[i] > 0.0 {
                    v[i] = -v[i];
                }
            }
        }
        t += STEP_S;
    }
    // The timing jitter must keep the samples in order.
    samples.dedup_by(|b, a| b.t_s <= a.t_s);
    Case {
        samples,
        pitch: "1.95x1.04",
        source: format!(
            "SYNTHETIC, not a real recording: a puck on a 1.95 m x 1.04 m walled table, drag \
             0.02 m/s2 plus 0.08 /s, walls 0.75-0.95 normal and 0.8-1.0 tangential turning it \
             3 degrees more (sd), mallets pushing it for 15-40 ms every 0.3-1.5 s to 0.5-6 \
             m/s (a third hiding it for up to 60 ms more), 1 mm and 0.5 ms of tracker jitter; \
             120 Hz, 60 s; written by `cargo run --release -p tools --bin sim_track -- --case \
             puck-mallets --seed {seed}`"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_case_stays_on_its_pitch_and_is_seeded() {
        for name in CASES {
            let c = case(name, 3).expect("a case");
            let (l, w) = c.pitch.split_once('x').expect("LxW");
            let (l, w): (f64, f64) = (l.parse().expect("l"), w.parse().expect("w"));
            assert!(c.samples.len() > 1000, "{name}");
            assert!(c.samples.windows(2).all(|s| s[1].t_s > s[0].t_s), "{name}");
            assert!(
                c.samples
                    .iter()
                    .all(|s| s.position_m[0].abs() < l / 2.0 && s.position_m[1].abs() < w / 2.0),
                "{name}"
            );
            assert!(c.source.starts_with("SYNTHETIC"));
            assert_eq!(
                case(name, 3).map(|c| c.samples.len()),
                Some(c.samples.len())
            );
        }
        assert!(case("nope", 1).is_none());
    }

    #[test]
    fn the_relocations_case_moves_the_ball_nine_times_and_the_puck_bounces_often() {
        let gaps = |c: &Case| {
            c.samples
                .windows(2)
                .filter(|s| s[1].t_s - s[0].t_s > 0.5)
                .count()
        };
        let r = case("relocations", 1).expect("relocations");
        assert_eq!(gaps(&r), 9);
        let k = case("kick-on-arrival", 1).expect("kick-on-arrival");
        assert_eq!(gaps(&k), 9);
        // Moving again within a tenth of a second of each reappearance.
        let restarts = k
            .samples
            .windows(2)
            .enumerate()
            .filter(|(_, s)| s[1].t_s - s[0].t_s > 0.5)
            .filter(|(i, _)| {
                let at = &k.samples[i + 1..];
                at.iter()
                    .take_while(|s| s.t_s - at[0].t_s < 0.1)
                    .any(|s| s.position_m != at[0].position_m)
            })
            .count();
        assert_eq!(restarts, 9);
        let p = case("puck", 1).expect("puck");
        let reversals = p
            .samples
            .windows(3)
            .filter(|s| {
                let d0 = s[1].position_m[0] - s[0].position_m[0];
                let d1 = s[2].position_m[0] - s[1].position_m[0];
                d0 * d1 < 0.0
            })
            .count();
        assert!(
            reversals > 20,
            "{reversals} bounces off the short walls in 30 s"
        );
    }
}
