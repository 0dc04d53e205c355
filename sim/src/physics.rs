//! The ball's own physics: slide then roll with drag, walls with per-bounce restitution,
//! pushes from robot bodies.
//!
//! Deliberately richer than any filter's model (no "inverse crime"): the estimator has to
//! cope with a skid phase, quadratic drag and scattered restitution it does not model.
//! Within a phase the motion along a straight line is integrated in closed form, so wall
//! contacts and stops are placed exactly inside a step rather than at step ends.

use crate::rng::Rng;
use crate::types::{BallPhase, TrueParams};
use crate::vec2::{V2, axpy, dot, norm, scale, sub, unit_or};
use proto::{Pitch, WallSide};

/// A kicked ball skids until its speed drops to 5/7 of the kick speed: for a solid sphere
/// that is when the contact point stops slipping.
pub const SLIDE_TO_ROLL_RATIO: f64 = 5.0 / 7.0;
/// After a bounce the ball skids again briefly, until it has lost 10 % of its speed.
pub const BOUNCE_RESLIDE_RATIO: f64 = 0.9;
/// Restitution of the ball against a robot's body (soft plastic shell).
pub const ROBOT_RESTITUTION: f64 = 0.3;
/// Spread of per-bounce restitution around the run's mean.
pub const RESTITUTION_SPREAD: f64 = 0.1;
/// Range of the per-bounce tangential friction loss at a wall.
pub const WALL_FRICTION_RANGE: (f64, f64) = (0.03, 0.12);
/// Through a side without a wall the ball is stopped this far outside (the referee's hand),
/// so positions stay near the pitch.
pub const OPEN_SIDE_STOP_M: f64 = 0.5;

impl TrueParams {
    /// Draws a run's parameters: rolling 0.2–0.4 m/s², restitution mean 0.4–0.6, slide
    /// 2.0–3.5 m/s², drag 0–0.03 1/m.
    pub fn draw(rng: &mut Rng) -> Self {
        TrueParams {
            rolling_decel_mps2: rng.range(0.2, 0.4),
            restitution_mean: rng.range(0.4, 0.6),
            slide_decel_mps2: rng.range(2.0, 3.5),
            drag_per_m: rng.range(0.0, 0.03),
        }
    }
}

/// The ball's state inside the physics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ball {
    pub pos: V2,
    pub vel: V2,
    pub phase: BallPhase,
    /// While sliding: the speed at which rolling starts.
    pub slide_until_mps: f64,
}

impl Ball {
    pub fn at_rest(pos: V2) -> Self {
        Ball {
            pos,
            vel: [0.0, 0.0],
            phase: BallPhase::Rest,
            slide_until_mps: 0.0,
        }
    }

    pub fn speed(&self) -> f64 {
        norm(self.vel)
    }

    /// Sets the velocity and starts a skid lasting until speed ≤ `ratio` × the new speed.
    pub fn set_sliding(&mut self, vel: V2, ratio: f64) {
        let speed = norm(vel);
        if speed <= 0.0 {
            self.vel = [0.0, 0.0];
            self.phase = BallPhase::Rest;
            return;
        }
        self.vel = vel;
        self.phase = BallPhase::Slide;
        self.slide_until_mps = ratio * speed;
    }

    /// A kick: the ball skids from `vel` until it rolls.
    pub fn kick(&mut self, vel: V2) {
        self.set_sliding(vel, SLIDE_TO_ROLL_RATIO);
    }
}

/// Where the ball centre may go: the inner wall lines pulled in by the ball radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Walls {
    /// Largest |x| and |y| of the ball centre.
    pub limit: V2,
    /// Walls present at x_max, x_min, y_max, y_min.
    pub present: [bool; 4],
}

impl Walls {
    pub fn new(pitch: &Pitch) -> Self {
        Walls {
            limit: [
                pitch.half_length_m() - pitch.ball_radius_m,
                pitch.half_width_m() - pitch.ball_radius_m,
            ],
            present: [
                pitch.has_wall(WallSide::XMax),
                pitch.has_wall(WallSide::XMin),
                pitch.has_wall(WallSide::YMax),
                pitch.has_wall(WallSide::YMin),
            ],
        }
    }

    fn sides() -> [(WallSide, usize, f64); 4] {
        [
            (WallSide::XMax, 0, 1.0),
            (WallSide::XMin, 0, -1.0),
            (WallSide::YMax, 1, 1.0),
            (WallSide::YMin, 1, -1.0),
        ]
    }

    /// Keeps a point inside the walled sides (for robots pushing the ball into a wall).
    pub fn clamp(&self, p: V2) -> V2 {
        let mut q = p;
        for (i, (_, axis, sign)) in Self::sides().into_iter().enumerate() {
            if self.present[i] && q[axis] * sign > self.limit[axis] {
                q[axis] = sign * self.limit[axis];
            }
        }
        q
    }
}

/// What the physics reports from a step; `dt_s` is the offset into the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PhysEvent {
    Bounce {
        dt_s: f64,
        pos: V2,
        wall: WallSide,
        restitution: f64,
        speed_in: f64,
        speed_out: f64,
    },
    Stopped {
        dt_s: f64,
        pos: V2,
    },
}

/// Speed and distance travelled after `tau` seconds in `phase`, starting at speed `v0`.
/// Rolling obeys dv/dt = −(a + k v²), solved with tan/ln; sliding is constant deceleration.
pub fn advance(phase: BallPhase, v0: f64, tau: f64, p: &TrueParams) -> (f64, f64) {
    match phase {
        BallPhase::Rest => (0.0, 0.0),
        BallPhase::Slide => linear(v0, p.slide_decel_mps2, tau),
        BallPhase::Roll => {
            let (a, k) = (p.rolling_decel_mps2, p.drag_per_m);
            if k < 1e-12 {
                return linear(v0, a, tau);
            }
            let c = (a / k).sqrt();
            let w = (a * k).sqrt();
            let phi0 = (v0 / c).atan();
            let phi = (phi0 - w * tau).max(0.0);
            (c * phi.tan(), (phi.cos() / phi0.cos()).ln() / k)
        }
    }
}

fn linear(v0: f64, a: f64, tau: f64) -> (f64, f64) {
    let tau = tau.min(v0 / a);
    (v0 - a * tau, v0 * tau - 0.5 * a * tau * tau)
}

/// Time for the speed to fall from `v0` to `v1` in `phase` (v1 < v0).
pub fn time_to_speed(phase: BallPhase, v0: f64, v1: f64, p: &TrueParams) -> f64 {
    match phase {
        BallPhase::Rest => 0.0,
        BallPhase::Slide => (v0 - v1).max(0.0) / p.slide_decel_mps2,
        BallPhase::Roll => {
            let (a, k) = (p.rolling_decel_mps2, p.drag_per_m);
            if k < 1e-12 {
                return (v0 - v1).max(0.0) / a;
            }
            let c = (a / k).sqrt();
            (((v0 / c).atan() - (v1 / c).atan()) / (a * k).sqrt()).max(0.0)
        }
    }
}

/// Time to cover distance `s` in `phase` from speed `v0`, or None if it stops first.
pub fn time_to_distance(phase: BallPhase, v0: f64, s: f64, p: &TrueParams) -> Option<f64> {
    let lin = |a: f64| {
        let disc = v0 * v0 - 2.0 * a * s;
        (disc >= 0.0).then(|| (v0 - disc.sqrt()) / a)
    };
    match phase {
        BallPhase::Rest => (s <= 0.0).then_some(0.0),
        BallPhase::Slide => lin(p.slide_decel_mps2),
        BallPhase::Roll => {
            let (a, k) = (p.rolling_decel_mps2, p.drag_per_m);
            if k < 1e-12 {
                return lin(a);
            }
            let c = (a / k).sqrt();
            let phi0 = (v0 / c).atan();
            let cos_phi = phi0.cos() * (k * s).exp();
            (cos_phi <= 1.0).then(|| (phi0 - cos_phi.acos()) / (a * k).sqrt())
        }
    }
}

/// Distance a ball kicked at `speed` travels before it stops, ignoring walls and robots.
pub fn stop_distance(speed: f64, p: &TrueParams) -> f64 {
    let v_roll = SLIDE_TO_ROLL_RATIO * speed;
    let (_, s_slide) = advance(
        BallPhase::Slide,
        speed,
        time_to_speed(BallPhase::Slide, speed, v_roll, p),
        p,
    );
    let (_, s_roll) = advance(
        BallPhase::Roll,
        v_roll,
        time_to_speed(BallPhase::Roll, v_roll, 0.0, p),
        p,
    );
    s_slide + s_roll
}

/// The kick speed whose free stop distance is `distance_m` (bisection; monotone in speed).
pub fn speed_for_distance(distance_m: f64, p: &TrueParams) -> f64 {
    let (mut lo, mut hi) = (0.0, 20.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if stop_distance(mid, p) < distance_m {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The first wall the ball reaches moving `s_max` metres along `dir` from `pos`: the distance
/// and the sides hit there (two in a corner).
fn first_wall(pos: V2, dir: V2, s_max: f64, walls: &Walls) -> Option<(f64, Vec<WallSide>)> {
    let mut best: Option<(f64, Vec<WallSide>)> = None;
    for (i, (side, axis, sign)) in Walls::sides().into_iter().enumerate() {
        let toward = dir[axis] * sign;
        if !walls.present[i] || toward <= 0.0 {
            continue;
        }
        let s = ((walls.limit[axis] - pos[axis] * sign) / toward).max(0.0);
        if s > s_max {
            continue;
        }
        best = match best {
            Some((b, mut sides)) if (s - b).abs() <= 1e-12 => {
                sides.push(side);
                Some((b.min(s), sides))
            }
            Some((b, sides)) if b < s => Some((b, sides)),
            _ => Some((s, vec![side])),
        };
    }
    best
}

/// Advances the ball by `dt` seconds, reflecting off walls and ending phases exactly where
/// they happen within the step. Restitution and wall friction are drawn from `rng`.
pub fn step(
    ball: &mut Ball,
    dt: f64,
    p: &TrueParams,
    walls: &Walls,
    rng: &mut Rng,
    out: &mut Vec<PhysEvent>,
) {
    let mut done = 0.0;
    // A step holds at most a few phase changes and bounces; the cap guards degenerate input.
    for _ in 0..16 {
        let rem = dt - done;
        if rem <= 0.0 || ball.phase == BallPhase::Rest {
            break;
        }
        let v0 = ball.speed();
        if v0 <= 0.0 {
            stop(ball, done, out);
            break;
        }
        let dir = scale(ball.vel, 1.0 / v0);
        if ball.phase == BallPhase::Slide && v0 <= ball.slide_until_mps {
            ball.phase = BallPhase::Roll;
            continue;
        }
        let v_end = match ball.phase {
            BallPhase::Slide => ball.slide_until_mps,
            _ => 0.0,
        };
        let tau_end = time_to_speed(ball.phase, v0, v_end, p);
        let tau = rem.min(tau_end);
        let (v1, s) = advance(ball.phase, v0, tau, p);
        if let Some((s_hit, sides)) = first_wall(ball.pos, dir, s, walls) {
            let tau_hit = time_to_distance(ball.phase, v0, s_hit, p)
                .unwrap_or(tau)
                .min(tau);
            let (v_hit, _) = advance(ball.phase, v0, tau_hit, p);
            ball.pos = walls.clamp(axpy(ball.pos, s_hit, dir));
            ball.vel = scale(dir, v_hit);
            done += tau_hit;
            for side in sides {
                bounce(ball, side, p, rng, done, out);
            }
            ball.set_sliding(ball.vel, BOUNCE_RESLIDE_RATIO);
            continue;
        }
        ball.pos = axpy(ball.pos, s, dir);
        done += tau;
        if tau_end <= rem {
            if ball.phase == BallPhase::Slide {
                ball.phase = BallPhase::Roll;
                ball.vel = scale(dir, v_end);
            } else {
                stop(ball, done, out);
            }
        } else {
            ball.vel = scale(dir, v1);
        }
    }
    stop_outside_open_sides(ball, walls, done.min(dt), out);
}

fn stop(ball: &mut Ball, dt_s: f64, out: &mut Vec<PhysEvent>) {
    ball.vel = [0.0, 0.0];
    ball.phase = BallPhase::Rest;
    out.push(PhysEvent::Stopped {
        dt_s,
        pos: ball.pos,
    });
}

/// Reflects the velocity off one wall: normal × −e, tangential × (1 − μ), both drawn.
fn bounce(
    ball: &mut Ball,
    side: WallSide,
    p: &TrueParams,
    rng: &mut Rng,
    dt_s: f64,
    out: &mut Vec<PhysEvent>,
) {
    let axis = match side {
        WallSide::XMax | WallSide::XMin => 0,
        WallSide::YMax | WallSide::YMin => 1,
    };
    let e = p.restitution_mean + rng.range(-RESTITUTION_SPREAD, RESTITUTION_SPREAD);
    let mu = rng.range(WALL_FRICTION_RANGE.0, WALL_FRICTION_RANGE.1);
    let speed_in = ball.speed();
    ball.vel[axis] *= -e;
    ball.vel[1 - axis] *= 1.0 - mu;
    out.push(PhysEvent::Bounce {
        dt_s,
        pos: ball.pos,
        wall: side,
        restitution: e,
        speed_in,
        speed_out: ball.speed(),
    });
}

fn stop_outside_open_sides(ball: &mut Ball, walls: &Walls, dt_s: f64, out: &mut Vec<PhysEvent>) {
    if ball.phase == BallPhase::Rest {
        return;
    }
    let beyond = (0..2).any(|axis| ball.pos[axis].abs() > walls.limit[axis] + OPEN_SIDE_STOP_M);
    if beyond {
        stop(ball, dt_s, out);
    }
}

/// A robot body the ball can hit: centre, velocity, radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    pub pos: V2,
    pub vel: V2,
    pub radius_m: f64,
}

/// Resolves overlap of the ball with robot bodies: pushes the ball out along the contact
/// normal and reflects the relative velocity with `ROBOT_RESTITUTION`. Returns, per body in
/// contact, whether the ball was struck (approaching rather than just touching).
pub fn robot_contacts(
    ball: &mut Ball,
    ball_radius_m: f64,
    bodies: &[Body],
    walls: &Walls,
) -> Vec<(usize, bool)> {
    let mut contacts = Vec::new();
    for (i, b) in bodies.iter().enumerate() {
        let reach = b.radius_m + ball_radius_m;
        let rel = sub(ball.pos, b.pos);
        let d = norm(rel);
        if d >= reach {
            continue;
        }
        let n = unit_or(rel, [1.0, 0.0]);
        ball.pos = walls.clamp(axpy(b.pos, reach, n));
        let vn = dot(sub(ball.vel, b.vel), n);
        let struck = vn < 0.0;
        if struck {
            let vel = axpy(ball.vel, -(1.0 + ROBOT_RESTITUTION) * vn, n);
            ball.set_sliding(vel, BOUNCE_RESLIDE_RATIO);
        }
        contacts.push((i, struck));
    }
    contacts
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> TrueParams {
        TrueParams {
            rolling_decel_mps2: 0.3,
            restitution_mean: 0.5,
            slide_decel_mps2: 3.0,
            drag_per_m: 0.02,
        }
    }

    #[test]
    fn closed_form_roll_matches_small_step_integration() {
        let p = params();
        let (mut v, mut s) = (1.2, 0.0);
        let h = 1e-6;
        for _ in 0..1_000_000 {
            let a = p.rolling_decel_mps2 + p.drag_per_m * v * v;
            let v_mid = v - 0.5 * h * a;
            s += h * v_mid;
            v -= h * (p.rolling_decel_mps2 + p.drag_per_m * v_mid * v_mid);
        }
        let (v1, s1) = advance(BallPhase::Roll, 1.2, 1.0, &p);
        assert!(
            (v1 - v).abs() < 1e-8 && (s1 - s).abs() < 1e-8,
            "{v1} {v} {s1} {s}"
        );
        let t = time_to_distance(BallPhase::Roll, 1.2, s1, &p).unwrap_or(f64::NAN);
        assert!((t - 1.0).abs() < 1e-9);
        assert!((time_to_speed(BallPhase::Roll, 1.2, v1, &p) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn slides_then_rolls_then_stops_where_predicted() {
        let walls = Walls::new(&Pitch {
            length_m: 100.0,
            width_m: 100.0,
            ..Pitch::default()
        });
        let mut ball = Ball::at_rest([0.0, 0.0]);
        ball.kick([1.5, 0.0]);
        let mut rng = Rng::new(1);
        let mut out = Vec::new();
        let p = params();
        let mut t = 0.0;
        let mut roll_started = None;
        while ball.phase != BallPhase::Rest {
            step(&mut ball, 0.001, &p, &walls, &mut rng, &mut out);
            t += 0.001;
            if ball.phase == BallPhase::Roll && roll_started.is_none() {
                roll_started = Some(t);
            }
        }
        let expected_slide = (1.5 - 1.5 * SLIDE_TO_ROLL_RATIO) / 3.0;
        let started = roll_started.unwrap_or(f64::NAN);
        assert!((started - expected_slide).abs() <= 0.001 + 1e-9);
        assert!(
            (ball.pos[0] - stop_distance(1.5, &p)).abs() < 1e-9,
            "{}",
            ball.pos[0]
        );
        assert!(matches!(out.last(), Some(PhysEvent::Stopped { .. })));
        assert_eq!(ball.vel, [0.0, 0.0]);
        let v = speed_for_distance(2.0, &p);
        assert!((stop_distance(v, &p) - 2.0).abs() < 1e-9);
    }

    #[test]
    fn bounces_never_gain_energy_and_ball_stays_inside() {
        let pitch = Pitch::default();
        let walls = Walls::new(&pitch);
        let mut rng = Rng::new(3);
        let mut bounces = 0;
        for i in 0..50 {
            let mut ball = Ball::at_rest([rng.range(-1.5, 1.5), rng.range(-1.0, 1.0)]);
            let a = rng.range(0.0, std::f64::consts::TAU);
            ball.kick(scale([a.cos(), a.sin()], rng.range(1.5, 3.0)));
            let mut out = Vec::new();
            for _ in 0..8000 {
                step(&mut ball, 0.001, &params(), &walls, &mut rng, &mut out);
                assert!(ball.pos[0].abs() <= walls.limit[0] + 1e-12, "run {i}");
                assert!(ball.pos[1].abs() <= walls.limit[1] + 1e-12, "run {i}");
            }
            for e in out {
                if let PhysEvent::Bounce {
                    speed_in,
                    speed_out,
                    restitution,
                    ..
                } = e
                {
                    bounces += 1;
                    assert!(speed_out < speed_in);
                    assert!((0.3..=0.7).contains(&restitution));
                }
            }
        }
        assert!(bounces > 50);
    }

    #[test]
    fn corner_hit_reflects_both_components_in_one_step() {
        let walls = Walls::new(&Pitch::default());
        let [lx, ly] = walls.limit;
        // Exactly on the diagonal into the corner, 0.5 mm away in each axis.
        let mut ball = Ball::at_rest([lx - 0.0005, ly - 0.0005]);
        ball.set_sliding([1.0, 1.0], BOUNCE_RESLIDE_RATIO);
        let mut out = Vec::new();
        step(
            &mut ball,
            0.001,
            &params(),
            &walls,
            &mut Rng::new(5),
            &mut out,
        );
        let walls_hit: Vec<WallSide> = out
            .iter()
            .filter_map(|e| match e {
                PhysEvent::Bounce { wall, .. } => Some(*wall),
                _ => None,
            })
            .collect();
        assert_eq!(walls_hit, vec![WallSide::XMax, WallSide::YMax]);
        assert!(ball.vel[0] < 0.0 && ball.vel[1] < 0.0);
        assert!(ball.pos[0] <= lx && ball.pos[1] <= ly);
        // Slightly off the diagonal: the two walls are hit one after the other, same step.
        let mut ball = Ball::at_rest([lx - 0.0004, ly - 0.0006]);
        ball.set_sliding([1.0, 1.0], BOUNCE_RESLIDE_RATIO);
        out.clear();
        step(
            &mut ball,
            0.001,
            &params(),
            &walls,
            &mut Rng::new(5),
            &mut out,
        );
        assert_eq!(out.len(), 2);
        assert!(ball.vel[0] < 0.0 && ball.vel[1] < 0.0);
    }

    #[test]
    fn robot_body_reflects_and_pushes_resting_ball() {
        let walls = Walls::new(&Pitch::default());
        let mut ball = Ball::at_rest([0.0, 0.0]);
        let robot = Body {
            pos: [-0.16, 0.0],
            vel: [0.3, 0.0],
            radius_m: 0.13,
        };
        let c = robot_contacts(&mut ball, 0.04, &[robot], &walls);
        assert_eq!(c, vec![(0, true)]);
        assert!((ball.pos[0] - 0.01).abs() < 1e-12);
        assert!((ball.vel[0] - 1.3 * 0.3).abs() < 1e-12);
        assert_eq!(ball.phase, BallPhase::Slide);
        // A ball rolling into a still robot comes back at 0.3 of its normal speed.
        let mut ball = Ball::at_rest([0.0, 0.0]);
        ball.set_sliding([-1.0, 0.0], 1.0);
        let still = Body {
            vel: [0.0, 0.0],
            ..robot
        };
        robot_contacts(&mut ball, 0.04, &[still], &walls);
        assert!((ball.vel[0] - 0.3).abs() < 1e-12);
        // Pushed out to the contact distance, it is no longer in contact.
        let before = ball;
        assert_eq!(robot_contacts(&mut ball, 0.04, &[still], &walls), vec![]);
        assert_eq!(ball, before);
    }
}
