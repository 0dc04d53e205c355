//! The kick director: who kicks, when, where to, and how hard.
//!
//! A kick plan names a trigger (a time, or "after the ball has rested this long"), a kicker
//! rule, an aim rule and a speed rule. From `APPROACH_LEAD_S` before the kick the kicker
//! drives to the spot behind the ball; at the kick time the ball gets its velocity whether
//! or not the kicker made it (the event records how far away it was). Aim and kicker are
//! resolved when the approach starts, the exact velocity at the kick, from where the ball
//! then is. Plans run one after another; a repeat rule keeps generating them for as long
//! as the world runs, which is what lets a live `match` go on indefinitely.

use crate::physics::{Ball, Walls, speed_for_distance};
use crate::rng::Rng;
use crate::robots::KICK_BEHIND_M;
use crate::types::{BallPhase, TrueParams};
use crate::vec2::{V2, axpy, dist, dot, norm, scale, segment_distance, sub, unit_or};
use std::collections::VecDeque;

/// The kicker starts driving to the ball this long before the kick.
pub const APPROACH_LEAD_S: f64 = 3.0;
/// Aim points are redrawn (up to `AIM_TRIES` times) until the path clears other robots by this.
const AIM_CLEARANCE_M: f64 = 0.45;
const AIM_TRIES: usize = 12;

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Trigger {
    At(f64),
    /// When the ball has been at rest for `rest_s` (the approach starts when it stops).
    AfterRest {
        rest_s: f64,
    },
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum KickerRule {
    /// No robot: the ball is kicked by the script ("script" in events).
    Script,
    /// The robot nearest the ball when the approach starts.
    Nearest,
    /// The nearer of two robots.
    NearestOf([usize; 2]),
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AimRule {
    /// Exactly this velocity (the speed rule should be `Given`).
    Velocity(V2),
    /// A random point on a wall, reachable and hit at a fair angle.
    WallPoint,
    /// A wall point near a corner, so the ball rattles between the two walls.
    Corner,
    /// A random point on the pitch.
    RandomPoint,
    /// The robot of the pair that is not kicking (a pass).
    OtherOf([usize; 2]),
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SpeedRule {
    /// The speed of `AimRule::Velocity`.
    Given,
    Range(f64, f64),
    /// The speed whose free stop distance is the distance to the target plus `beyond_m`
    /// (drawn), clamped to `lo..=hi`. Uses the true friction: the world knows it.
    Reach {
        lo: f64,
        hi: f64,
        beyond_m: (f64, f64),
    },
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KickPlan {
    pub trigger: Trigger,
    pub kicker: KickerRule,
    pub aim: AimRule,
    pub speed: SpeedRule,
}

/// Endless kicks, each `interval_s` (drawn) after the previous one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Repeat {
    pub interval_s: (f64, f64),
    pub kicker: KickerRule,
    pub aim: AimRule,
    pub speed: SpeedRule,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Target {
    Velocity(V2),
    Point(V2),
    Robot(usize),
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Active {
    kick_s: f64,
    kicker: Option<usize>,
    target: Target,
    speed: SpeedRule,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Stage {
    Idle,
    Waiting(KickPlan),
    Approach(Active),
}

/// What the world sees when the director decides.
#[derive(Debug, Clone, Copy)]
pub struct View<'a> {
    pub t_s: f64,
    pub dt_s: f64,
    pub ball: &'a Ball,
    pub robots: &'a [V2],
    pub params: &'a TrueParams,
    pub walls: &'a Walls,
    /// Largest |x|, |y| of a robot centre.
    pub robot_limit: V2,
}

/// A kick to apply now.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kick {
    pub robot: Option<usize>,
    pub velocity: V2,
}

/// The director's orders for one step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Orders {
    /// The kicker and the kick direction it should line up behind.
    pub chase: Option<(usize, V2)>,
    /// During an approach: the planned kick's lane, from the ball to its target.
    pub lane: Option<(V2, V2)>,
    pub kick: Option<Kick>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Director {
    queue: VecDeque<KickPlan>,
    repeat: Option<Repeat>,
    stage: Stage,
    last_kick_s: f64,
    rng: Rng,
}

impl Director {
    pub fn new(plans: Vec<KickPlan>, repeat: Option<Repeat>, rng: Rng) -> Self {
        Director {
            queue: plans.into(),
            repeat,
            stage: Stage::Idle,
            last_kick_s: 0.0,
            rng,
        }
    }

    pub fn update(&mut self, v: &View) -> Orders {
        // Idle → Waiting → Approach can all happen within one step.
        for _ in 0..3 {
            match self.stage {
                Stage::Idle => match self.next_plan() {
                    Some(p) => self.stage = Stage::Waiting(p),
                    None => return Orders::default(),
                },
                Stage::Waiting(plan) => {
                    let kick_s = match plan.trigger {
                        Trigger::At(t) if v.t_s >= t - APPROACH_LEAD_S => t,
                        Trigger::AfterRest { rest_s } if v.ball.phase == BallPhase::Rest => {
                            v.t_s + rest_s
                        }
                        _ => return Orders::default(),
                    };
                    self.stage = Stage::Approach(self.resolve(plan, kick_s, v));
                }
                Stage::Approach(a) => {
                    if v.t_s >= a.kick_s - 0.5 * v.dt_s {
                        self.stage = Stage::Idle;
                        self.last_kick_s = v.t_s;
                        return Orders {
                            chase: None,
                            lane: None,
                            kick: Some(Kick {
                                robot: a.kicker,
                                velocity: self.velocity(&a, v),
                            }),
                        };
                    }
                    return Orders {
                        chase: a.kicker.map(|k| (k, direction(&a.target, v))),
                        lane: lane(&a.target, v),
                        kick: None,
                    };
                }
            }
        }
        Orders::default()
    }

    fn next_plan(&mut self) -> Option<KickPlan> {
        if let Some(p) = self.queue.pop_front() {
            return Some(p);
        }
        let r = self.repeat?;
        Some(KickPlan {
            trigger: Trigger::At(self.last_kick_s + self.rng.range(r.interval_s.0, r.interval_s.1)),
            kicker: r.kicker,
            aim: r.aim,
            speed: r.speed,
        })
    }

    fn resolve(&mut self, plan: KickPlan, kick_s: f64, v: &View) -> Active {
        let ball = v.ball.pos;
        let nearest = |cands: &mut dyn Iterator<Item = usize>| {
            cands.min_by(|&a, &b| dist(v.robots[a], ball).total_cmp(&dist(v.robots[b], ball)))
        };
        let kicker = match plan.kicker {
            KickerRule::Script => None,
            KickerRule::Nearest => nearest(&mut (0..v.robots.len())),
            KickerRule::NearestOf(pair) => {
                nearest(&mut pair.into_iter().filter(|&i| i < v.robots.len()))
            }
        };
        let target = match plan.aim {
            AimRule::Velocity(vel) => Target::Velocity(vel),
            AimRule::WallPoint => Target::Point(self.clear_aim(kicker, v, wall_point)),
            AimRule::Corner => Target::Point(self.clear_aim(kicker, v, corner_point)),
            AimRule::RandomPoint => Target::Point(self.clear_aim(kicker, v, random_point)),
            AimRule::OtherOf([a, b]) => {
                let other = if kicker == Some(a) { b } else { a };
                if other < v.robots.len() {
                    Target::Robot(other)
                } else {
                    Target::Point(random_point(ball, v.walls, &mut self.rng))
                }
            }
        };
        Active {
            kick_s,
            kicker,
            target,
            speed: plan.speed,
        }
    }

    /// Draws aim points until the straight path to one keeps `AIM_CLEARANCE_M` from every
    /// robot but the kicker and the kicker can get behind the ball for it (else takes the
    /// best): the scenario's kick should do what it is meant to (reach the wall, the
    /// corner), not hit a bystander, nor make the kicker shove a ball lying at a wall.
    fn clear_aim(
        &mut self,
        kicker: Option<usize>,
        v: &View,
        sample: fn(V2, &Walls, &mut Rng) -> V2,
    ) -> V2 {
        let ball = v.ball.pos;
        let mut best = (ball, f64::NEG_INFINITY);
        for _ in 0..AIM_TRIES {
            let p = sample(ball, v.walls, &mut self.rng);
            let mut clearance = (0..v.robots.len())
                .filter(|&i| Some(i) != kicker)
                .map(|i| segment_distance(ball, p, v.robots[i]).0)
                .fold(f64::INFINITY, f64::min);
            let behind = axpy(ball, -KICK_BEHIND_M, unit_or(sub(p, ball), [1.0, 0.0]));
            let reachable = (0..2).all(|k| behind[k].abs() <= v.robot_limit[k] - 0.01);
            if kicker.is_some() && !reachable {
                clearance -= 10.0;
            }
            if clearance >= AIM_CLEARANCE_M {
                return p;
            }
            if clearance > best.1 {
                best = (p, clearance);
            }
        }
        best.0
    }

    fn velocity(&mut self, a: &Active, v: &View) -> V2 {
        let dir = direction(&a.target, v);
        let distance = match a.target {
            Target::Velocity(_) => 0.0,
            Target::Point(p) => dist(p, v.ball.pos),
            Target::Robot(i) => dist(v.robots[i], v.ball.pos),
        };
        let speed = match (a.speed, a.target) {
            (SpeedRule::Given, Target::Velocity(vel)) => norm(vel),
            (SpeedRule::Given, _) => 1.0,
            (SpeedRule::Range(lo, hi), _) => self.rng.range(lo, hi),
            (SpeedRule::Reach { lo, hi, beyond_m }, _) => {
                let extra = self.rng.range(beyond_m.0, beyond_m.1);
                speed_for_distance((distance + extra).max(0.0), v.params).clamp(lo, hi)
            }
        };
        scale(dir, speed)
    }
}

/// The segment the planned kick will send the ball along (None for scripted velocities).
fn lane(target: &Target, v: &View) -> Option<(V2, V2)> {
    match *target {
        Target::Velocity(_) => None,
        Target::Point(p) => Some((v.ball.pos, p)),
        Target::Robot(i) => Some((v.ball.pos, v.robots[i])),
    }
}

fn direction(target: &Target, v: &View) -> V2 {
    let to = match *target {
        Target::Velocity(vel) => return unit_or(vel, [1.0, 0.0]),
        Target::Point(p) => sub(p, v.ball.pos),
        Target::Robot(i) => sub(v.robots[i], v.ball.pos),
    };
    unit_or(to, [1.0, 0.0])
}

/// Wall lines the ball centre can touch: (outward normal, point on the line, half extent).
fn wall_lines(walls: &Walls) -> Vec<(V2, V2, f64)> {
    let [lx, ly] = walls.limit;
    let all = [
        ([1.0, 0.0], [lx, 0.0], ly),
        ([-1.0, 0.0], [-lx, 0.0], ly),
        ([0.0, 1.0], [0.0, ly], lx),
        ([0.0, -1.0], [0.0, -ly], lx),
    ];
    all.into_iter()
        .zip(walls.present)
        .filter_map(|(line, present)| present.then_some(line))
        .collect()
}

/// A wall point 0.6–2.5 m from the ball, approached within 60° of the wall's normal.
pub fn wall_point(ball: V2, walls: &Walls, rng: &mut Rng) -> V2 {
    let lines = wall_lines(walls);
    if lines.is_empty() {
        return random_point(ball, walls, rng);
    }
    for _ in 0..40 {
        let (n, on, half) = lines[rng.index(lines.len())];
        let along = [n[1], -n[0]];
        let along_off = rng.range(-(half - 0.15), half - 0.15);
        let p = [on[0] + along[0] * along_off, on[1] + along[1] * along_off];
        let to = sub(p, ball);
        let d = norm(to);
        if (0.6..=2.5).contains(&d) && dot(to, n) / d >= 0.5 {
            return p;
        }
    }
    // Fallback: straight at the farthest wall.
    let (n, on, _) = lines
        .iter()
        .copied()
        .max_by(|a, b| dot(sub(a.1, ball), a.0).total_cmp(&dot(sub(b.1, ball), b.0)))
        .unwrap_or(lines[0]);
    let depth = dot(sub(on, ball), n);
    [ball[0] + n[0] * depth, ball[1] + n[1] * depth]
}

/// A point on one wall 0.15–0.35 m from the nearest corner at least 0.8 m away, such that
/// the ball still travels towards the other wall of that corner after the first bounce.
pub fn corner_point(ball: V2, walls: &Walls, rng: &mut Rng) -> V2 {
    let [lx, ly] = walls.limit;
    let mut corners: Vec<V2> = Vec::new();
    for (sx, xi) in [(1.0, 0), (-1.0, 1)] {
        for (sy, yi) in [(1.0, 2), (-1.0, 3)] {
            let c = [sx * lx, sy * ly];
            if walls.present[xi] && walls.present[yi] && dist(c, ball) >= 0.8 {
                corners.push(c);
            }
        }
    }
    let Some(&c) = corners
        .iter()
        .min_by(|a, b| dist(**a, ball).total_cmp(&dist(**b, ball)))
    else {
        return wall_point(ball, walls, rng);
    };
    let off = rng.range(0.15, 0.35);
    let (sx, sy) = (c[0].signum(), c[1].signum());
    // Hit the x wall first when the ball is far enough from the y wall, and vice versa.
    let room_y = (c[1] - ball[1]).abs();
    let room_x = (c[0] - ball[0]).abs();
    let x_first = if room_y > off + 0.1 && room_x > off + 0.1 {
        rng.chance(0.5)
    } else {
        room_y > room_x
    };
    if x_first {
        [c[0], c[1] - sy * off]
    } else {
        [c[0] - sx * off, c[1]]
    }
}

/// A point at least 0.5 m from the ball, 0.3 m inside the ball's limits.
pub fn random_point(ball: V2, walls: &Walls, rng: &mut Rng) -> V2 {
    let [lx, ly] = walls.limit;
    let (mx, my) = ((lx - 0.3).max(0.1), (ly - 0.3).max(0.1));
    let mut p = [0.0, 0.0];
    for _ in 0..40 {
        p = [rng.range(-mx, mx), rng.range(-my, my)];
        if dist(p, ball) >= 0.5 {
            break;
        }
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::Pitch;

    fn params() -> TrueParams {
        TrueParams {
            rolling_decel_mps2: 0.3,
            restitution_mean: 0.5,
            slide_decel_mps2: 3.0,
            drag_per_m: 0.01,
        }
    }

    #[test]
    fn approach_then_kick_at_the_planned_time() {
        let walls = Walls::new(&Pitch::default());
        let plan = KickPlan {
            trigger: Trigger::At(5.0),
            kicker: KickerRule::Nearest,
            aim: AimRule::WallPoint,
            speed: SpeedRule::Range(1.5, 2.5),
        };
        let mut d = Director::new(vec![plan], None, Rng::new(1));
        let ball = Ball::at_rest([0.0, 0.0]);
        let robots = [[1.0, 1.0], [0.3, 0.0]];
        let p = params();
        let mut chased_from = None;
        let mut kicked = None;
        for k in 0..7000 {
            let t = k as f64 * 0.001;
            let view = View {
                t_s: t,
                dt_s: 0.001,
                ball: &ball,
                robots: &robots,
                params: &p,
                walls: &walls,
                robot_limit: [1.8, 1.2],
            };
            let o = d.update(&view);
            if let Some((who, _)) = o.chase {
                assert_eq!(who, 1);
                chased_from.get_or_insert(t);
            }
            if let Some(kick) = o.kick {
                kicked = Some((t, kick));
            }
        }
        assert!((chased_from.unwrap_or(0.0) - 2.0).abs() < 0.002);
        let (t, kick) = kicked.unwrap_or((
            0.0,
            Kick {
                robot: None,
                velocity: [0.0; 2],
            },
        ));
        assert!((t - 5.0).abs() < 0.001);
        assert_eq!(kick.robot, Some(1));
        assert!((1.5..2.5).contains(&norm(kick.velocity)));
    }

    #[test]
    fn reach_speed_gets_the_ball_to_the_target() {
        let walls = Walls::new(&Pitch::default());
        let plan = KickPlan {
            trigger: Trigger::AfterRest { rest_s: 0.5 },
            kicker: KickerRule::Script,
            aim: AimRule::RandomPoint,
            speed: SpeedRule::Reach {
                lo: 0.1,
                hi: 5.0,
                beyond_m: (0.0, 0.0),
            },
        };
        let mut d = Director::new(vec![plan], None, Rng::new(2));
        let ball = Ball::at_rest([0.2, 0.1]);
        let p = params();
        let mut kick = None;
        for k in 0..1000 {
            let view = View {
                t_s: k as f64 * 0.001,
                dt_s: 0.001,
                ball: &ball,
                robots: &[],
                params: &p,
                walls: &walls,
                robot_limit: [1.8, 1.2],
            };
            kick = kick.or(d.update(&view).kick);
        }
        let v = kick.map(|k| norm(k.velocity)).unwrap_or(0.0);
        let travelled = crate::physics::stop_distance(v, &p);
        assert!(travelled >= 0.5, "{travelled}");
    }

    #[test]
    fn aim_points_lie_on_walls_and_corners() {
        let walls = Walls::new(&Pitch::default());
        let [lx, ly] = walls.limit;
        let mut rng = Rng::new(3);
        for _ in 0..200 {
            let ball = random_point([9.0, 9.0], &walls, &mut rng);
            let w = wall_point(ball, &walls, &mut rng);
            assert!(
                (w[0].abs() - lx).abs() < 1e-9 || (w[1].abs() - ly).abs() < 1e-9,
                "{w:?}"
            );
            let c = corner_point(ball, &walls, &mut rng);
            let near_corner = (c[0].abs() - lx).abs() < 0.36 && (c[1].abs() - ly).abs() < 0.36;
            assert!(near_corner, "{c:?}");
        }
    }
}
