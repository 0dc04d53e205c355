//! Scenario specifications: who is on the pitch, where the ball starts, the kick plans.
//!
//! The seed's six live in `seed_scenarios`; the team scenarios (three to five moving
//! observers) are built here. Everything is drawn from the scenario's random stream, so a
//! (name, seed) pair always describes the same match.

use crate::kicks::{AimRule, KickPlan, KickerRule, Repeat, SpeedRule, Trigger};
use crate::latency::LatencyProfile;
use crate::rng::Rng;
use crate::robots::{Rect, Routine, robot_limits};
use crate::types::TrueParams;
use crate::vec2::{V2, dist};
use proto::{Pitch, Pose2};

/// Default length of `match` (and any scenario, when `SimConfig::duration_s` overrides it).
pub const MATCH_DEFAULT_S: f64 = 60.0;

#[derive(Debug, Clone, PartialEq)]
pub struct RobotSpec {
    pub id: String,
    pub observer: bool,
    pub pose: Pose2,
    pub routine: Routine,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioSpec {
    pub duration_s: f64,
    /// The ball starts at rest here.
    pub ball: V2,
    pub robots: Vec<RobotSpec>,
    pub plans: Vec<KickPlan>,
    pub repeat: Option<Repeat>,
    pub latency: LatencyProfile,
    /// The robot that also reports a phantom ball (its spot is chosen by the world).
    pub phantom_robot: Option<usize>,
    /// Capture rate of every observing robot (both cameras at each capture).
    pub frame_rate_hz: f64,
}

/// Builds the named scenario, or None for an unknown name.
pub fn build(
    name: &str,
    rng: &mut Rng,
    params: &TrueParams,
    pitch: &Pitch,
    team_size: Option<usize>,
) -> Option<ScenarioSpec> {
    if let Some(spec) = crate::seed_scenarios::build(name, rng, params, pitch) {
        return Some(spec);
    }
    let spec = match name {
        "team-rally" => rally(rng, pitch, 30.0),
        "corner" => corner(rng, pitch),
        "occluded-pass" => occluded_pass(rng, pitch),
        "phantom" => ScenarioSpec {
            phantom_robot: Some(3),
            ..rally(rng, pitch, 20.0)
        },
        "late-packets" => ScenarioSpec {
            latency: LatencyProfile::Heavy,
            ..rally(rng, pitch, 20.0)
        },
        "kick-restart" => kick_restart(rng, pitch),
        // The seed's lone MiRo watching a ball cross its view, its perception loop at 5 Hz
        // (and at 10 Hz, the seed's own rate): the estimate must not wait for a fast robot.
        "single-slow-robot" | "single-slow-robot-10hz" => ScenarioSpec {
            frame_rate_hz: if name == "single-slow-robot" {
                5.0
            } else {
                10.0
            },
            ..crate::seed_scenarios::build("seed-1-across", rng, params, pitch)?
        },
        "match" => football_match(rng, pitch, team_size.unwrap_or(5)),
        _ => return None,
    };
    Some(spec)
}

/// A region given as fractions of the robots' reachable half-extents.
fn zone(pitch: &Pitch, x: (f64, f64), y: (f64, f64)) -> Rect {
    let l = robot_limits(pitch);
    Rect {
        min: [x.0 * l[0], y.0 * l[1]],
        max: [x.1 * l[0], y.1 * l[1]],
    }
}

/// Robots wandering in `zones`, started at random points of their zones that keep clear of
/// each other and of the ball.
fn wanderers(rng: &mut Rng, zones: &[Rect], ball: V2) -> Vec<RobotSpec> {
    let mut placed: Vec<V2> = Vec::new();
    zones
        .iter()
        .enumerate()
        .map(|(i, z)| {
            let mut p = z.sample(rng);
            for _ in 0..50 {
                if placed.iter().all(|q| dist(*q, p) > 0.45) && dist(p, ball) > 0.5 {
                    break;
                }
                p = z.sample(rng);
            }
            placed.push(p);
            RobotSpec {
                id: format!("miro{}", i + 1),
                observer: true,
                pose: Pose2 {
                    x_m: p[0],
                    y_m: p[1],
                    theta_rad: rng.range(-std::f64::consts::PI, std::f64::consts::PI),
                },
                routine: Routine::Wander {
                    region: *z,
                    pause_s: (0.5, 2.0),
                },
            }
        })
        .collect()
}

fn quadrants(pitch: &Pitch) -> Vec<Rect> {
    vec![
        zone(pitch, (-1.0, 0.1), (-1.0, 0.1)),
        zone(pitch, (-0.1, 1.0), (-1.0, 0.1)),
        zone(pitch, (-0.1, 1.0), (-0.1, 1.0)),
        zone(pitch, (-1.0, 0.1), (-0.1, 1.0)),
    ]
}

fn base(duration_s: f64, ball: V2, robots: Vec<RobotSpec>) -> ScenarioSpec {
    ScenarioSpec {
        duration_s,
        ball,
        robots,
        plans: Vec::new(),
        repeat: None,
        latency: LatencyProfile::Normal,
        phantom_robot: None,
        frame_rate_hz: crate::observer::FRAME_RATE_HZ,
    }
}

/// Hard kicks at walls by whoever is nearest, every ~4 s.
fn rally(rng: &mut Rng, pitch: &Pitch, duration_s: f64) -> ScenarioSpec {
    let ball = [rng.range(-0.5, 0.5), rng.range(-0.4, 0.4)];
    let robots = wanderers(rng, &quadrants(pitch), ball);
    let speed = SpeedRule::Reach {
        lo: 1.5,
        hi: 2.5,
        beyond_m: (0.5, 1.5),
    };
    ScenarioSpec {
        plans: vec![KickPlan {
            trigger: Trigger::At(rng.range(2.5, 3.5)),
            kicker: KickerRule::Nearest,
            aim: AimRule::WallPoint,
            speed,
        }],
        repeat: Some(Repeat {
            interval_s: (3.5, 4.5),
            kicker: KickerRule::Nearest,
            aim: AimRule::WallPoint,
            speed,
        }),
        ..base(duration_s, ball, robots)
    }
}

/// Two or three kicks into corners at an angle, so the ball rattles between the walls.
fn corner(rng: &mut Rng, pitch: &Pitch) -> ScenarioSpec {
    let ball = [rng.range(-0.6, 0.6), rng.range(-0.4, 0.4)];
    let zones = [
        zone(pitch, (-1.0, -0.2), (-1.0, 1.0)),
        zone(pitch, (-0.5, 0.5), (-1.0, 1.0)),
        zone(pitch, (0.2, 1.0), (-1.0, 1.0)),
    ];
    let robots = wanderers(rng, &zones, ball);
    let plan = |t: f64| KickPlan {
        trigger: Trigger::At(t),
        kicker: KickerRule::Nearest,
        aim: AimRule::Corner,
        speed: SpeedRule::Reach {
            lo: 1.2,
            hi: 2.2,
            beyond_m: (0.8, 1.4),
        },
    };
    let t1 = rng.range(2.0, 2.5);
    let t2 = t1 + rng.range(4.5, 5.0);
    let mut plans = vec![plan(t1), plan(t2)];
    if rng.chance(0.5) {
        plans.push(plan(t2 + rng.range(4.0, 4.5)));
    }
    ScenarioSpec {
        plans,
        ..base(15.0, ball, robots)
    }
}

/// miro1 and miro2 pass back and forth along the pitch; miro3 roams between the lane and
/// miro4, which watches from the side, so bodies block lines of sight for stretches.
fn occluded_pass(rng: &mut Rng, pitch: &Pitch) -> ScenarioSpec {
    let l = robot_limits(pitch);
    let side = rng.sign();
    let home1 = [
        (-1.2 + rng.range(-0.1, 0.1)).max(-l[0]),
        rng.range(-0.3, 0.3),
    ];
    let home2 = [(1.2 + rng.range(-0.1, 0.1)).min(l[0]), rng.range(-0.3, 0.3)];
    let ball = [home1[0] + 0.35, home1[1]];
    let band = |lo: f64, hi: f64| if side > 0.0 { (lo, hi) } else { (-hi, -lo) };
    let y3 = band(0.2 / l[1].max(0.2), 0.55 / l[1].max(0.55));
    let y4 = band(0.7 / l[1].max(0.7), 1.0);
    let mut robots = wanderers(
        rng,
        &[zone(pitch, (-0.5, 0.5), y3), zone(pitch, (-0.7, 0.7), y4)],
        ball,
    );
    for (i, r) in robots.iter_mut().enumerate() {
        r.id = format!("miro{}", i + 3);
    }
    let holder = |id: &str, home: V2, theta: f64| RobotSpec {
        id: id.into(),
        observer: true,
        pose: Pose2 {
            x_m: home[0],
            y_m: home[1],
            theta_rad: theta,
        },
        routine: Routine::Hold { home },
    };
    robots.insert(0, holder("miro2", home2, std::f64::consts::PI));
    robots.insert(0, holder("miro1", home1, 0.0));
    let speed = SpeedRule::Reach {
        lo: 0.6,
        hi: 2.0,
        beyond_m: (-0.45, -0.3),
    };
    let pass = AimRule::OtherOf([0, 1]);
    ScenarioSpec {
        plans: vec![KickPlan {
            trigger: Trigger::At(rng.range(1.5, 2.5)),
            kicker: KickerRule::NearestOf([0, 1]),
            aim: pass,
            speed,
        }],
        repeat: Some(Repeat {
            interval_s: (3.5, 4.5),
            kicker: KickerRule::NearestOf([0, 1]),
            aim: pass,
            speed,
        }),
        ..base(20.0, ball, robots)
    }
}

/// The ball rests ~2 s, is kicked hard, stops, rests 2.2–2.8 s and is kicked hard again.
fn kick_restart(rng: &mut Rng, pitch: &Pitch) -> ScenarioSpec {
    let ball = [rng.range(-0.6, 0.6), rng.range(-0.4, 0.4)];
    let zones = [
        zone(pitch, (-1.0, 0.0), (-1.0, 1.0)),
        zone(pitch, (-0.5, 0.5), (-1.0, 1.0)),
        zone(pitch, (0.0, 1.0), (-1.0, 1.0)),
    ];
    let robots = wanderers(rng, &zones, ball);
    let hard = SpeedRule::Range(2.0, 2.5);
    ScenarioSpec {
        plans: vec![
            KickPlan {
                trigger: Trigger::At(rng.range(2.0, 2.5)),
                kicker: KickerRule::Nearest,
                aim: AimRule::WallPoint,
                speed: hard,
            },
            KickPlan {
                trigger: Trigger::AfterRest {
                    rest_s: rng.range(2.2, 2.8),
                },
                kicker: KickerRule::Nearest,
                aim: AimRule::WallPoint,
                speed: hard,
            },
        ],
        ..base(16.0, ball, robots)
    }
}

/// Zones of a match team of `n`: the five-a-side layout, a subset of it for fewer robots,
/// and a grid of overlapping columns for more.
fn match_zones(pitch: &Pitch, n: usize) -> Vec<Rect> {
    let five = [
        zone(pitch, (-1.0, -0.2), (-1.0, 0.2)),
        zone(pitch, (-1.0, -0.2), (-0.2, 1.0)),
        zone(pitch, (-0.5, 0.5), (-0.8, 0.8)),
        zone(pitch, (0.2, 1.0), (-1.0, 0.2)),
        zone(pitch, (0.2, 1.0), (-0.2, 1.0)),
    ];
    if n <= 5 {
        // Wings first, the centre last.
        let mut pick = [0usize, 4, 1, 3, 2][..n.max(1)].to_vec();
        pick.sort_unstable();
        return pick.into_iter().map(|i| five[i]).collect();
    }
    let cols = n.div_ceil(2);
    (0..n)
        .map(|i| {
            let (c, r) = ((i / 2) as f64, (i % 2) as f64);
            let w = 2.0 / cols as f64;
            let x0 = -1.0 + c * w;
            zone(
                pitch,
                ((x0 - 0.1).max(-1.0), (x0 + w + 0.1).min(1.0)),
                (-1.0 + r * 0.9, 0.1 + r * 0.9),
            )
        })
        .collect()
}

/// A generic match: `n` robots (five by default) in zones, the nearest kicks every 3–6 s
/// to a random point.
fn football_match(rng: &mut Rng, pitch: &Pitch, n: usize) -> ScenarioSpec {
    let ball = [rng.range(-0.3, 0.3), rng.range(-0.3, 0.3)];
    let zones = match_zones(pitch, n);
    let robots = wanderers(rng, &zones, ball);
    let speed = SpeedRule::Reach {
        lo: 0.6,
        hi: 2.5,
        beyond_m: (-0.2, 0.6),
    };
    ScenarioSpec {
        plans: vec![KickPlan {
            trigger: Trigger::At(rng.range(1.5, 3.0)),
            kicker: KickerRule::Nearest,
            aim: AimRule::RandomPoint,
            speed,
        }],
        repeat: Some(Repeat {
            interval_s: (3.0, 6.0),
            kicker: KickerRule::Nearest,
            aim: AimRule::RandomPoint,
            speed,
        }),
        ..base(MATCH_DEFAULT_S, ball, robots)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::TEAM_SCENARIOS;

    #[test]
    fn a_match_takes_any_team_size() {
        let params = TrueParams::draw(&mut Rng::new(2));
        for n in [1, 3, 4, 5, 8, 20] {
            let spec = build(
                "match",
                &mut Rng::new(1),
                &params,
                &Pitch::default(),
                Some(n),
            )
            .expect("match");
            assert_eq!(spec.robots.len(), n);
        }
    }

    #[test]
    fn team_scenarios_build_with_their_robot_counts() {
        let params = TrueParams {
            rolling_decel_mps2: 0.3,
            restitution_mean: 0.5,
            slide_decel_mps2: 3.0,
            drag_per_m: 0.01,
        };
        let counts = [4, 3, 4, 4, 4, 3, 5];
        for (name, n) in TEAM_SCENARIOS.iter().zip(counts) {
            let spec = build(name, &mut Rng::new(1), &params, &Pitch::default(), None);
            let Some(spec) = spec else {
                panic!("{name}");
            };
            assert_eq!(spec.robots.len(), n, "{name}");
            assert!(spec.robots.iter().all(|r| r.observer), "{name}");
            let ids: Vec<String> = spec.robots.iter().map(|r| r.id.clone()).collect();
            let expected: Vec<String> = (1..=n).map(|i| format!("miro{i}")).collect();
            assert_eq!(ids, expected, "{name}");
            let l = robot_limits(&Pitch::default());
            for r in &spec.robots {
                assert!(
                    r.pose.x_m.abs() <= l[0] && r.pose.y_m.abs() <= l[1],
                    "{name}"
                );
            }
        }
    }
}
