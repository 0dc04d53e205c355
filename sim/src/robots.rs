//! Scripted MiRo bodies: unicycle kinematics at MiRo's limits, routines, the kicker's chase.
//!
//! Robots matter to the ball tracker in three ways: they carry the cameras, their bodies
//! block lines of sight and deflect the ball, and their white tops are mistaken for the
//! ball. The behaviours are simple scripts, not football: just enough to move cameras and
//! bodies around the pitch the way a team would.

use crate::rng::Rng;
use crate::vec2::{
    V2, add, angle, axpy, dist, dot, from_angle, norm, perp, rotate, scale, segment_distance, sub,
    unit_or, wrap_angle,
};
use proto::{Pitch, Pose2};

/// MiRo's body seen from above, as a circle.
pub const ROBOT_RADIUS_M: f64 = 0.13;
/// MiRo's top speed.
pub const MAX_SPEED_MPS: f64 = 0.4;
/// Turn-rate limit of the scripted drive.
pub const MAX_TURN_RADPS: f64 = 2.0;
/// Where a kicker waits: this far behind the ball, opposite to the kick direction.
pub const KICK_BEHIND_M: f64 = 0.2;
/// A kicker lining up keeps its centre at least this far from the ball's (contact: 0.17 m).
const KICKER_MIN_GAP_M: f64 = 0.18;
/// Radius of the circle a kicker drives around the ball on to get behind it.
const ORBIT_M: f64 = 0.35;
const ARRIVE_M: f64 = 0.03;
/// Robots that are not kicking keep their centre this far from the ball when it is ahead.
const BALL_CLEARANCE_M: f64 = 0.3;
/// Wandering robots step aside when the ball's path would pass closer than this.
const DODGE_CLEARANCE_M: f64 = 0.3;
/// An observer turns towards the ball when it is more than this far off its heading.
const WATCH_DEADBAND_RAD: f64 = 0.15;

/// An axis-aligned region of the floor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    pub min: V2,
    pub max: V2,
}

impl Rect {
    pub fn sample(&self, rng: &mut Rng) -> V2 {
        [
            rng.range(self.min[0], self.max[0]),
            rng.range(self.min[1], self.max[1]),
        ]
    }

    /// This region intersected with the box |x| ≤ limit[0], |y| ≤ limit[1].
    pub fn within(&self, limit: V2) -> Rect {
        let lo = |v: f64, l: f64| v.clamp(-l, l);
        Rect {
            min: [lo(self.min[0], limit[0]), lo(self.min[1], limit[1])],
            max: [lo(self.max[0], limit[0]), lo(self.max[1], limit[1])],
        }
    }
}

/// What a robot does when it is not the kicker.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Routine {
    /// Stands still with a fixed heading (the seed's observer, bystanders).
    Static,
    /// Goes to `home` and watches the ball from there.
    Hold { home: V2 },
    /// Drives between random points in `region`, pausing at each to watch the ball.
    Wander { region: Rect, pause_s: (f64, f64) },
}

/// Largest |x|, |y| of a robot centre: robots never leave the pitch.
pub fn robot_limits(pitch: &Pitch) -> V2 {
    [
        (pitch.half_length_m() - ROBOT_RADIUS_M).max(0.0),
        (pitch.half_width_m() - ROBOT_RADIUS_M).max(0.0),
    ]
}

fn clamp_to(p: V2, limit: V2) -> V2 {
    [
        p[0].clamp(-limit[0], limit[0]),
        p[1].clamp(-limit[1], limit[1]),
    ]
}

#[derive(Debug, Clone, PartialEq)]
pub struct Robot {
    pub id: String,
    pub observer: bool,
    pub pose: Pose2,
    /// Velocity over the last step (for ball contacts).
    pub vel: V2,
    pub routine: Routine,
    waypoint: Option<V2>,
    pause_until_s: f64,
    rng: Rng,
}

impl Robot {
    pub fn new(id: String, observer: bool, pose: Pose2, routine: Routine, rng: Rng) -> Self {
        Robot {
            id,
            observer,
            pose: Pose2 {
                theta_rad: wrap_angle(pose.theta_rad),
                ..pose
            },
            vel: [0.0, 0.0],
            routine,
            waypoint: None,
            pause_until_s: 0.0,
            rng,
        }
    }

    pub fn pos(&self) -> V2 {
        [self.pose.x_m, self.pose.y_m]
    }

    fn set_pos(&mut self, p: V2) {
        self.pose.x_m = p[0];
        self.pose.y_m = p[1];
    }

    /// One step of behaviour and motion. `chase` is the kick direction when this robot is
    /// the kicker; then it drives to the spot behind the ball, going around it if needed.
    /// Bystanders (wanderers) step out of any of `lanes` they stand in.
    pub fn update(
        &mut self,
        t_s: f64,
        dt: f64,
        ball: V2,
        lanes: &[(V2, V2)],
        chase: Option<V2>,
        limit: V2,
    ) {
        let before = self.pos();
        if let Some(kick_dir) = chase {
            let target = clamp_to(chase_point(before, ball, kick_dir), limit);
            self.drive(target, dt, limit, false);
            // Lining up never shoves the ball (its spot may be out of reach, e.g. behind a
            // ball at a wall): stop short of touching it instead.
            let gap = dist(self.pos(), ball);
            if gap < KICKER_MIN_GAP_M && gap < dist(before, ball) {
                self.set_pos(before);
            }
            // Leaving chase duty: the routine resumes with a fresh waypoint.
            self.waypoint = None;
        } else if let (Routine::Wander { .. }, Some(away)) = (&self.routine, escape(before, lanes))
        {
            let target = clamp_to(axpy(before, 0.5, away), limit);
            self.drive(target, dt, limit, true);
        } else {
            match self.routine {
                Routine::Static => {}
                Routine::Hold { home } => {
                    let home = clamp_to(home, limit);
                    if dist(home, before) > 2.0 * ARRIVE_M && !ball_blocks(before, home, ball) {
                        self.drive(home, dt, limit, false);
                    } else {
                        self.watch(ball, dt);
                    }
                }
                Routine::Wander { region, pause_s } => {
                    self.wander(t_s, dt, ball, region, pause_s, limit)
                }
            }
        }
        self.vel = scale(sub(self.pos(), before), 1.0 / dt);
    }

    fn wander(
        &mut self,
        t_s: f64,
        dt: f64,
        ball: V2,
        region: Rect,
        pause_s: (f64, f64),
        limit: V2,
    ) {
        if t_s < self.pause_until_s {
            self.watch(ball, dt);
            return;
        }
        let region = region.within(limit);
        let here = self.pos();
        let target = match self.waypoint {
            Some(w) if !ball_blocks(here, w, ball) => w,
            _ => {
                let w = region.sample(&mut self.rng);
                self.waypoint = Some(w);
                // Re-plan next step; a blocked robot waits while it watches.
                self.watch(ball, dt);
                return;
            }
        };
        if self.drive(target, dt, limit, false) {
            self.waypoint = None;
            self.pause_until_s = t_s + self.rng.range(pause_s.0, pause_s.1);
        }
    }

    /// Turns on the spot towards the ball (observers only: it keeps the ball in view).
    fn watch(&mut self, ball: V2, dt: f64) {
        if !self.observer {
            return;
        }
        let err = wrap_angle(angle(sub(ball, self.pos())) - self.pose.theta_rad);
        if err.abs() > WATCH_DEADBAND_RAD {
            let turn = err.clamp(-MAX_TURN_RADPS * dt, MAX_TURN_RADPS * dt);
            self.pose.theta_rad = wrap_angle(self.pose.theta_rad + turn);
        }
    }

    /// Unicycle step towards `target`: turn at ≤ 2 rad/s, drive at ≤ 0.4 m/s, mostly turning
    /// on the spot when facing away (or backing up, when `reverse_ok`). True once arrived.
    fn drive(&mut self, target: V2, dt: f64, limit: V2, reverse_ok: bool) -> bool {
        let here = self.pos();
        let to = sub(target, here);
        let d = norm(to);
        if d < ARRIVE_M {
            return true;
        }
        let mut err = wrap_angle(angle(to) - self.pose.theta_rad);
        let mut gear = 1.0;
        if reverse_ok && err.abs() > std::f64::consts::FRAC_PI_2 {
            err = wrap_angle(err - std::f64::consts::PI);
            gear = -1.0;
        }
        let turn = err.clamp(-MAX_TURN_RADPS * dt, MAX_TURN_RADPS * dt);
        self.pose.theta_rad = wrap_angle(self.pose.theta_rad + turn);
        let align = (err - turn).cos().max(0.0);
        let speed = MAX_SPEED_MPS.min(1.5 * d) * align * align;
        let next = axpy(here, gear * speed * dt, from_angle(self.pose.theta_rad));
        self.set_pos(clamp_to(next, limit));
        false
    }
}

/// The ball's straight path from `ball` up to about where it would stop, if it is rolling.
/// Bystanders keep clear of it so scripted kicks reach their walls and corners; they
/// cannot always make it in time, and then the ball hits them.
pub fn ball_path(ball: V2, ball_vel: V2) -> Option<(V2, V2)> {
    let speed = norm(ball_vel);
    if speed < 0.2 {
        return None;
    }
    let horizon = (speed * speed / (2.0 * 0.3) + 0.3).min(3.0);
    Some((ball, axpy(ball, horizon / speed, ball_vel)))
}

/// The direction to step out of a lane `a`→`b` (a rolling ball's path, a planned kick)
/// when the robot at `pos` is within `DODGE_CLEARANCE_M` of it.
fn escape(pos: V2, lanes: &[(V2, V2)]) -> Option<V2> {
    lanes.iter().find_map(|&(a, b)| {
        let (d, f) = segment_distance(a, b, pos);
        if d > DODGE_CLEARANCE_M || f <= 0.0 {
            return None;
        }
        let u = unit_or(sub(b, a), [1.0, 0.0]);
        let side = if dot(sub(pos, a), perp(u)) >= 0.0 {
            1.0
        } else {
            -1.0
        };
        Some(scale(perp(u), side))
    })
}

/// True when the ball lies close ahead on the way from `from` to `to`.
fn ball_blocks(from: V2, to: V2, ball: V2) -> bool {
    let rel = sub(ball, from);
    norm(rel) < BALL_CLEARANCE_M && dot(rel, sub(to, from)) > 0.0
}

/// Where a kicker should head for: the spot `KICK_BEHIND_M` behind the ball once it is
/// roughly behind it, else a point on a circle around the ball, stepping towards behind,
/// so it does not drive through the ball on the way.
pub fn chase_point(robot: V2, ball: V2, kick_dir: V2) -> V2 {
    let behind = scale(unit_or(kick_dir, [1.0, 0.0]), -1.0);
    let u = sub(robot, ball);
    let alpha = wrap_angle(angle(u) - angle(behind));
    if alpha.abs() <= 0.6 || norm(u) < 1e-9 {
        return axpy(ball, KICK_BEHIND_M, behind);
    }
    let step = alpha.signum() * alpha.abs().min(0.8);
    add(ball, scale(rotate(behind, alpha - step), ORBIT_M))
}

/// Pushes overlapping robot bodies apart (equal shares) and keeps them on the pitch.
pub fn separate(robots: &mut [Robot], limit: V2) {
    let min_d = 2.0 * ROBOT_RADIUS_M;
    for i in 0..robots.len() {
        for j in (i + 1)..robots.len() {
            let (a, b) = (robots[i].pos(), robots[j].pos());
            let rel = sub(b, a);
            let d = norm(rel);
            if d >= min_d {
                continue;
            }
            let n = unit_or(rel, [0.0, 1.0]);
            let push = 0.5 * (min_d - d);
            robots[i].set_pos(clamp_to(axpy(a, -push, n), limit));
            robots[j].set_pos(clamp_to(axpy(b, push, n), limit));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn robot(x: f64, y: f64, theta: f64, routine: Routine) -> Robot {
        Robot::new(
            "miro1".into(),
            true,
            Pose2 {
                x_m: x,
                y_m: y,
                theta_rad: theta,
            },
            routine,
            Rng::new(1),
        )
    }

    #[test]
    fn drive_respects_speed_and_turn_limits_and_stays_on_pitch() {
        let limit = robot_limits(&Pitch::default());
        let region = Rect {
            min: [-5.0, -5.0],
            max: [5.0, 5.0],
        };
        let mut r = robot(
            0.0,
            0.0,
            0.0,
            Routine::Wander {
                region,
                pause_s: (0.1, 0.2),
            },
        );
        let dt = 0.001;
        for k in 0..60_000 {
            let before = r.pose;
            r.update(k as f64 * dt, dt, [3.0, 3.0], &[], None, limit);
            let moved = dist([before.x_m, before.y_m], r.pos());
            assert!(moved <= MAX_SPEED_MPS * dt + 1e-12);
            assert!(
                wrap_angle(r.pose.theta_rad - before.theta_rad).abs()
                    <= MAX_TURN_RADPS * dt + 1e-12
            );
            assert!(r.pose.x_m.abs() <= limit[0] && r.pose.y_m.abs() <= limit[1]);
        }
    }

    #[test]
    fn kicker_gets_behind_the_ball_without_touching_it() {
        let limit = robot_limits(&Pitch::default());
        // The robot starts in front of the ball relative to the kick direction (+x).
        let ball = [0.0, 0.0];
        let mut r = robot(0.5, 0.05, std::f64::consts::PI, Routine::Static);
        let mut closest: f64 = 1.0;
        for k in 0..10_000 {
            r.update(k as f64 * 0.001, 0.001, ball, &[], Some([1.0, 0.0]), limit);
            closest = closest.min(dist(r.pos(), ball));
        }
        assert!(dist(r.pos(), [-KICK_BEHIND_M, 0.0]) < 0.05, "{:?}", r.pos());
        assert!(closest > ROBOT_RADIUS_M + 0.04, "{closest}");
    }

    #[test]
    fn observer_turns_to_watch_the_ball_when_idle() {
        let limit = robot_limits(&Pitch::default());
        let mut r = robot(0.0, 0.0, 0.0, Routine::Hold { home: [0.0, 0.0] });
        for k in 0..2000 {
            r.update(k as f64 * 0.001, 0.001, [0.0, 1.0], &[], None, limit);
        }
        assert!(
            (r.pose.theta_rad - std::f64::consts::FRAC_PI_2).abs() <= WATCH_DEADBAND_RAD + 1e-9
        );
    }

    #[test]
    fn wanderer_steps_out_of_the_balls_way() {
        let limit = robot_limits(&Pitch::default());
        let region = Rect {
            min: [0.0, 0.0],
            max: [0.0, 0.0],
        };
        // Facing the ball rolling straight at it; 1 s later it has moved sideways.
        let mut r = robot(
            1.0,
            0.05,
            std::f64::consts::PI,
            Routine::Wander {
                region,
                pause_s: (5.0, 5.0),
            },
        );
        let lane = ball_path([0.0, 0.0], [1.5, 0.0]);
        assert!(lane.is_some_and(|l| escape(r.pos(), &[l]).is_some()));
        let away = ball_path([0.0, 0.0], [-1.5, 0.0]);
        assert!(away.is_some_and(|l| escape(r.pos(), &[l]).is_none()));
        let lanes: Vec<(V2, V2)> = lane.into_iter().collect();
        for k in 0..1000 {
            r.update(k as f64 * 0.001, 0.001, [0.0, 0.0], &lanes, None, limit);
        }
        assert!(r.pose.y_m > 0.2, "{:?}", r.pose);
    }

    #[test]
    fn overlapping_robots_are_pushed_apart() {
        let limit = robot_limits(&Pitch::default());
        let mut rs = vec![
            robot(0.0, 0.0, 0.0, Routine::Static),
            robot(0.1, 0.0, 0.0, Routine::Static),
        ];
        separate(&mut rs, limit);
        assert!((dist(rs[0].pos(), rs[1].pos()) - 2.0 * ROBOT_RADIUS_M).abs() < 1e-12);
    }
}
