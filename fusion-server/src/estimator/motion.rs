//! The ball's motion model in closed form: after a kick the ball slides at a high constant
//! deceleration until its speed falls to a share of the kick's (the two-phase model of the
//! leading small-size trackers), then rolls at a low one, stops below a speed threshold, and
//! reflects off the walls exactly, the times of impact solved analytically, any number of
//! them within one step. A wall ends the slide.
//!
//! The flight is a *flow*: flying `t1` then `t2` gives the same state as flying `t1 + t2`,
//! which is what makes prediction and filtering consistent at any step size.

use proto::{Pitch, WallSide};

/// Where the ball's centre may go: the pitch shrunk by the ball radius, per walled side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    pub x_min: f64,
    pub x_max: f64,
    pub y_min: f64,
    pub y_max: f64,
    /// Which sides have walls, in the order of [`WallSide::ALL`].
    pub walls: [bool; 4],
}

impl Bounds {
    pub fn from_pitch(pitch: &Pitch) -> Self {
        let hx = pitch.half_length_m() - pitch.ball_radius_m;
        let hy = pitch.half_width_m() - pitch.ball_radius_m;
        let mut walls = [false; 4];
        for (i, side) in WallSide::ALL.iter().enumerate() {
            walls[i] = pitch.has_wall(*side);
        }
        Bounds {
            x_min: -hx,
            x_max: hx,
            y_min: -hy,
            y_max: hy,
            walls,
        }
    }

    /// The wall's coordinate, its axis (0 = x, 1 = y) and the sign of the outward normal.
    fn wall(&self, i: usize) -> (f64, usize, f64) {
        match WallSide::ALL[i] {
            WallSide::XMax => (self.x_max, 0, 1.0),
            WallSide::XMin => (self.x_min, 0, -1.0),
            WallSide::YMax => (self.y_max, 1, 1.0),
            WallSide::YMin => (self.y_min, 1, -1.0),
        }
    }

    /// The sides that have walls: each wall's coordinate, its axis (0 = x, 1 = y) and the
    /// sign of its outward normal.
    pub fn walled_sides(&self) -> impl Iterator<Item = (f64, usize, f64)> + '_ {
        (0..4).filter(|i| self.walls[*i]).map(|i| self.wall(i))
    }
}

/// Parameters of the motion model, and the one piece of state a flight needs besides
/// position and velocity: whether the ball still slides.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionModel {
    /// Constant deceleration opposite to the velocity while rolling.
    pub decel_mps2: f64,
    /// Constant deceleration while sliding, just after a kick.
    pub slide_decel_mps2: f64,
    /// A kicked ball slides until its speed falls to this share of the kick's.
    pub roll_ratio: f64,
    /// The ball slides while faster than this (`roll_ratio` × the kick's speed after a kick;
    /// 0 once it rolls).
    pub roll_from_mps: f64,
    /// Normal speed out / normal speed in at a wall.
    pub restitution: f64,
    /// Tangential speed out / tangential speed in at a wall.
    pub tangential_retention: f64,
    /// Below this speed the ball is at rest.
    pub stop_speed_mps: f64,
}

impl Default for MotionModel {
    fn default() -> Self {
        MotionModel {
            decel_mps2: 0.3,
            slide_decel_mps2: 3.0,
            roll_ratio: 0.64,
            roll_from_mps: 0.0,
            restitution: 0.5,
            tangential_retention: 0.85,
            stop_speed_mps: 0.02,
        }
    }
}

/// A wall impact during a flight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallHit {
    /// Seconds after the start of the flight.
    pub t_s: f64,
    pub position: [f64; 2],
    pub wall: WallSide,
    /// Velocity just before the impact.
    pub velocity_in: [f64; 2],
    /// Axis of the wall's normal: 0 for x walls, 1 for y walls.
    pub axis: usize,
}

/// One piece of a flight, in order: straight decelerating segments and wall hits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Piece {
    /// `dt_s` of time, of which the ball moved for `moving_s` along unit `direction`,
    /// rolling (at the rolling deceleration) or sliding.
    Segment {
        dt_s: f64,
        moving_s: f64,
        direction: [f64; 2],
        rolling: bool,
    },
    Hit(WallHit),
}

/// The outcome of flying the ball for some time.
#[derive(Debug, Clone, PartialEq)]
pub struct Flight {
    pub position: [f64; 2],
    pub velocity: [f64; 2],
    /// When the ball came to rest, seconds after the start, if it did during the flight.
    pub stopped_at_s: Option<f64>,
    /// [`MotionModel::roll_from_mps`] at the end: 0 once the ball rolls.
    pub roll_from_mps: f64,
    pub pieces: Vec<Piece>,
}

impl Flight {
    pub fn hits(&self) -> impl Iterator<Item = &WallHit> {
        self.pieces.iter().filter_map(|p| match p {
            Piece::Hit(h) => Some(h),
            Piece::Segment { .. } => None,
        })
    }
}

const MAX_PIECES: usize = 256;
const TIME_EPS_S: f64 = 1e-12;

/// Time for a ball at speed `s` decelerating at `a` to cover distance `d` (≥ 0), if it does.
fn time_to_cover(s: f64, a: f64, d: f64) -> Option<f64> {
    if d <= 0.0 {
        return Some(0.0);
    }
    if a <= 0.0 {
        return (s > 0.0).then(|| d / s);
    }
    let disc = s * s - 2.0 * a * d;
    // The stable root of s t − a t²/2 = d.
    (disc >= 0.0).then(|| 2.0 * d / (s + disc.sqrt()))
}

/// Flies the ball from `position`, `velocity` for `dt_s` seconds.
pub fn fly(
    position: [f64; 2],
    velocity: [f64; 2],
    dt_s: f64,
    model: &MotionModel,
    bounds: &Bounds,
) -> Flight {
    let a_roll = model.decel_mps2.max(0.0);
    let a_slide = model.slide_decel_mps2.max(a_roll);
    let mut roll_from = model.roll_from_mps.max(0.0);
    let mut p = position;
    let mut v = velocity;
    let mut t = 0.0;
    let mut stopped_at_s = None;
    let mut pieces = Vec::new();
    if speed(v) < model.stop_speed_mps {
        if speed(v) > 0.0 {
            stopped_at_s = Some(0.0);
        }
        v = [0.0, 0.0];
    }
    while t < dt_s {
        let remaining = dt_s - t;
        let s = speed(v);
        if s == 0.0 || pieces.len() >= MAX_PIECES {
            pieces.push(Piece::Segment {
                dt_s: remaining,
                moving_s: 0.0,
                direction: [0.0, 0.0],
                rolling: true,
            });
            break;
        }
        let u = [v[0] / s, v[1] / s];
        let sliding = roll_from > 0.0 && s > roll_from && a_slide > a_roll;
        let a = if sliding { a_slide } else { a_roll };
        let t_stop = if a > 0.0 {
            (s - model.stop_speed_mps).max(0.0) / a
        } else {
            f64::INFINITY
        };
        let t_roll = if sliding {
            (s - roll_from) / a_slide
        } else {
            f64::INFINITY
        };
        let horizon = remaining.min(t_stop).min(t_roll);
        let (t_hit, walls_hit) = first_impact(p, u, s, a, bounds, horizon);
        let step = t_hit.unwrap_or(horizon);
        let travelled = s * step - 0.5 * a * step * step;
        p = [p[0] + u[0] * travelled, p[1] + u[1] * travelled];
        let s_after = (s - a * step).max(0.0);
        v = [u[0] * s_after, u[1] * s_after];
        pieces.push(Piece::Segment {
            dt_s: step,
            moving_s: step,
            direction: u,
            rolling: !sliding,
        });
        t += step;
        if t_hit.is_some() {
            for i in walls_hit.iter().flatten() {
                let (coord, axis, _) = bounds.wall(*i);
                let hit = WallHit {
                    t_s: t,
                    position: p,
                    wall: WallSide::ALL[*i],
                    velocity_in: v,
                    axis,
                };
                if step > 0.0 {
                    p[axis] = coord;
                }
                v[axis] *= -model.restitution;
                v[1 - axis] *= model.tangential_retention;
                pieces.push(Piece::Hit(WallHit { position: p, ..hit }));
            }
            roll_from = 0.0;
            if speed(v) < model.stop_speed_mps {
                v = [0.0, 0.0];
                stopped_at_s = Some(t);
            }
        } else if step >= t_stop && t_stop <= remaining {
            v = [0.0, 0.0];
            stopped_at_s = Some(t);
        } else if step >= t_roll && t_roll <= remaining {
            // Slid down to the rolling speed: it rolls from here.
            roll_from = 0.0;
            continue;
        }
        if step <= TIME_EPS_S && t_hit.is_none() {
            break;
        }
    }
    if stopped_at_s.is_some() || speed(v) == 0.0 {
        roll_from = 0.0;
    }
    Flight {
        position: p,
        velocity: v,
        stopped_at_s,
        roll_from_mps: roll_from,
        pieces,
    }
}

/// The earliest wall impact within `horizon_s`, and which walls (two at a corner).
fn first_impact(
    p: [f64; 2],
    u: [f64; 2],
    s: f64,
    a: f64,
    bounds: &Bounds,
    horizon_s: f64,
) -> (Option<f64>, [Option<usize>; 2]) {
    let mut best: Option<f64> = None;
    let mut walls = [None, None];
    for i in 0..4 {
        if !bounds.walls[i] {
            continue;
        }
        let (coord, axis, outward) = bounds.wall(i);
        let toward = u[axis] * outward;
        if toward <= 0.0 {
            continue;
        }
        let gap = (coord - p[axis]) * outward;
        let Some(t) = time_to_cover(s, a, gap.max(0.0) / toward) else {
            continue;
        };
        if t > horizon_s {
            continue;
        }
        match best {
            Some(b) if t > b + TIME_EPS_S => {}
            Some(b) if (t - b).abs() <= TIME_EPS_S => walls[1] = Some(i),
            _ => {
                best = Some(t);
                walls = [Some(i), None];
            }
        }
    }
    (best, walls)
}

pub fn speed(v: [f64; 2]) -> f64 {
    v[0].hypot(v[1])
}

/// Flies until the ball stops (or `max_s` passes): the stop point and time.
pub fn stop_point(
    position: [f64; 2],
    velocity: [f64; 2],
    model: &MotionModel,
    bounds: &Bounds,
    max_s: f64,
) -> Flight {
    let s = speed(velocity);
    let t = if model.decel_mps2 > 0.0 {
        (s / model.decel_mps2).min(max_s)
    } else {
        max_s
    };
    // Slightly past the analytic stop so the stop itself is inside the flight.
    fly(position, velocity, t + 1e-6, model, bounds)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bounds() -> Bounds {
        Bounds::from_pitch(&Pitch::default())
    }

    /// Brute-force small-step integration of the same physics, the slow obvious reference.
    fn integrate(
        p0: [f64; 2],
        v0: [f64; 2],
        t_s: f64,
        m: &MotionModel,
        b: &Bounds,
    ) -> ([f64; 2], [f64; 2], usize) {
        let dt = 1e-5;
        let (mut p, mut v) = (p0, v0);
        let mut hits = 0;
        let steps = (t_s / dt).round() as usize;
        for _ in 0..steps {
            let s = speed(v);
            if s < m.stop_speed_mps {
                v = [0.0, 0.0];
                continue;
            }
            let s_new = (s - m.decel_mps2 * dt).max(0.0);
            let mid = 0.5 * (s + s_new) / s;
            p = [p[0] + v[0] * mid * dt, p[1] + v[1] * mid * dt];
            v = [v[0] * s_new / s, v[1] * s_new / s];
            for (axis, lo, hi) in [(0, b.x_min, b.x_max), (1, b.y_min, b.y_max)] {
                if p[axis] > hi && v[axis] > 0.0 {
                    p[axis] = 2.0 * hi - p[axis];
                    v[axis] *= -m.restitution;
                    v[1 - axis] *= m.tangential_retention;
                    hits += 1;
                } else if p[axis] < lo && v[axis] < 0.0 {
                    p[axis] = 2.0 * lo - p[axis];
                    v[axis] *= -m.restitution;
                    v[1 - axis] *= m.tangential_retention;
                    hits += 1;
                }
            }
        }
        (p, v, hits)
    }

    #[test]
    fn free_roll_matches_kinematics() {
        let m = MotionModel::default();
        let f = fly([0.0, 0.0], [0.6, 0.0], 1.0, &m, &bounds());
        assert!((f.position[0] - (0.6 - 0.15)).abs() < 1e-12);
        assert!((f.velocity[0] - 0.3).abs() < 1e-12);
        assert!(f.hits().next().is_none());
    }

    #[test]
    fn stops_at_the_analytic_point() {
        let m = MotionModel::default();
        let f = fly([0.0, 0.0], [0.0, 0.6], 5.0, &m, &bounds());
        let t_stop = (0.6 - m.stop_speed_mps) / m.decel_mps2;
        let d = 0.6 * t_stop - 0.5 * m.decel_mps2 * t_stop * t_stop;
        assert!((f.position[1] - d).abs() < 1e-12);
        assert_eq!(f.velocity, [0.0, 0.0]);
        assert!((f.stopped_at_s.expect("stops") - t_stop).abs() < 1e-12);
    }

    #[test]
    fn analytic_bounces_match_small_step_integration() {
        let m = MotionModel {
            decel_mps2: 0.27,
            restitution: 0.55,
            ..MotionModel::default()
        };
        let b = bounds();
        let cases = [
            ([1.0, 0.2], [2.0, 0.7], 2.5),
            ([-1.5, -1.0], [-1.2, -1.9], 3.0),
            ([0.0, 0.0], [2.5, 1.67], 4.0),
            ([1.7, 1.1], [1.0, 1.0], 1.5),
        ];
        for (p0, v0, t) in cases {
            let f = fly(p0, v0, t, &m, &b);
            let (p, v, hits) = integrate(p0, v0, t, &m, &b);
            assert_eq!(f.hits().count(), hits, "case {p0:?} {v0:?}");
            for k in 0..2 {
                assert!(
                    (f.position[k] - p[k]).abs() < 2e-4,
                    "{:?} vs {p:?}",
                    f.position
                );
                assert!(
                    (f.velocity[k] - v[k]).abs() < 2e-4,
                    "{:?} vs {v:?}",
                    f.velocity
                );
            }
            assert!(hits >= 1, "case {p0:?} should bounce");
        }
    }

    #[test]
    fn corner_hit_reflects_both_axes() {
        let m = MotionModel {
            decel_mps2: 0.0,
            restitution: 0.5,
            tangential_retention: 1.0,
            ..MotionModel::default()
        };
        let b = bounds();
        // Aimed exactly at the (x_max, y_max) corner from 0.1 m away on the diagonal.
        let p0 = [b.x_max - 0.1, b.y_max - 0.1];
        let f = fly(p0, [1.0, 1.0], 0.15, &m, &b);
        let hits: Vec<_> = f.hits().collect();
        assert_eq!(hits.len(), 2);
        assert!((f.velocity[0] + 0.5).abs() < 1e-12 && (f.velocity[1] + 0.5).abs() < 1e-12);
        assert!((f.position[0] - (b.x_max - 0.025)).abs() < 1e-9);
    }

    #[test]
    fn flight_is_a_flow() {
        let m = MotionModel::default();
        let b = bounds();
        let (p0, v0) = ([0.3, -0.4], [2.2, 1.1]);
        for (t1, t2) in [(0.3, 0.9), (1.1, 0.05), (0.01, 3.0), (2.0, 2.0)] {
            let whole = fly(p0, v0, t1 + t2, &m, &b);
            let a = fly(p0, v0, t1, &m, &b);
            let c = fly(a.position, a.velocity, t2, &m, &b);
            for k in 0..2 {
                assert!((whole.position[k] - c.position[k]).abs() < 1e-9);
                assert!((whole.velocity[k] - c.velocity[k]).abs() < 1e-9);
            }
            assert_eq!(whole.hits().count(), a.hits().count() + c.hits().count());
        }
    }

    /// Small steps of the two-phase physics: slide at `slide_decel_mps2` while faster than
    /// `roll_from_mps`, roll after; a wall ends the slide.
    fn integrate_two_phase(
        p0: [f64; 2],
        v0: [f64; 2],
        t_s: f64,
        m: &MotionModel,
        b: &Bounds,
    ) -> ([f64; 2], [f64; 2]) {
        let dt = 1e-5;
        let (mut p, mut v, mut roll_from) = (p0, v0, m.roll_from_mps);
        for _ in 0..(t_s / dt).round() as usize {
            let s = speed(v);
            if s < m.stop_speed_mps {
                v = [0.0, 0.0];
                continue;
            }
            let a = if roll_from > 0.0 && s > roll_from {
                m.slide_decel_mps2
            } else {
                m.decel_mps2
            };
            let s_new = (s - a * dt).max(0.0);
            let mid = 0.5 * (s + s_new) / s;
            p = [p[0] + v[0] * mid * dt, p[1] + v[1] * mid * dt];
            v = [v[0] * s_new / s, v[1] * s_new / s];
            for (axis, lo, hi) in [(0, b.x_min, b.x_max), (1, b.y_min, b.y_max)] {
                let out = (p[axis] > hi && v[axis] > 0.0) || (p[axis] < lo && v[axis] < 0.0);
                if out {
                    let wall = if p[axis] > hi { hi } else { lo };
                    p[axis] = 2.0 * wall - p[axis];
                    v[axis] *= -m.restitution;
                    v[1 - axis] *= m.tangential_retention;
                    roll_from = 0.0;
                }
            }
        }
        (p, v)
    }

    #[test]
    fn a_kicked_ball_slides_then_rolls() {
        let b = bounds();
        let m = MotionModel {
            roll_from_mps: 0.64 * 3.0,
            ..MotionModel::default()
        };
        // Still sliding after 0.2 s: 3 m/s² off 3 m/s.
        let f = fly([-1.5, 0.0], [3.0, 0.0], 0.2, &m, &b);
        assert!((f.velocity[0] - 2.4).abs() < 1e-9);
        assert_eq!(f.roll_from_mps, 1.92);
        assert!(
            f.pieces
                .iter()
                .all(|p| matches!(p, Piece::Segment { rolling: false, .. }))
        );
        // Rolls from 1.92 m/s (after 0.36 s) at 0.3 m/s².
        let f = fly([-1.5, 0.0], [3.0, 0.0], 0.6, &m, &b);
        let (ts, tr) = (0.36, 0.24);
        let x = -1.5 + 3.0 * ts - 1.5 * ts * ts + 1.92 * tr - 0.15 * tr * tr;
        assert!((f.position[0] - x).abs() < 1e-9, "{} vs {x}", f.position[0]);
        assert!((f.velocity[0] - (1.92 - 0.3 * tr)).abs() < 1e-9);
        assert_eq!(f.roll_from_mps, 0.0);
        // Against small steps, through bounces (which end the slide).
        for (p0, v0, t) in [
            ([0.0, 0.0], [2.5, 1.2], 1.5),
            ([1.2, 0.9], [3.0, 0.2], 0.4),
            ([-0.5, 0.3], [-0.4, 3.5], 2.0),
        ] {
            let m = MotionModel {
                roll_from_mps: 0.64 * speed(v0),
                ..MotionModel::default()
            };
            let f = fly(p0, v0, t, &m, &b);
            let (p, v) = integrate_two_phase(p0, v0, t, &m, &b);
            for k in 0..2 {
                assert!((f.position[k] - p[k]).abs() < 1e-3, "{f:?} vs {p:?}");
                assert!((f.velocity[k] - v[k]).abs() < 1e-3, "{f:?} vs {v:?}");
            }
        }
    }

    #[test]
    fn a_sliding_flight_is_a_flow() {
        let b = bounds();
        let (p0, v0) = ([0.3, -0.4], [2.6, 1.3]);
        let m = MotionModel {
            roll_from_mps: 0.64 * speed(v0),
            ..MotionModel::default()
        };
        for (t1, t2) in [(0.1, 0.9), (0.25, 0.05), (0.01, 3.0), (0.6, 0.6)] {
            let whole = fly(p0, v0, t1 + t2, &m, &b);
            let a = fly(p0, v0, t1, &m, &b);
            let m2 = MotionModel {
                roll_from_mps: a.roll_from_mps,
                ..m
            };
            let c = fly(a.position, a.velocity, t2, &m2, &b);
            for k in 0..2 {
                assert!((whole.position[k] - c.position[k]).abs() < 1e-9);
                assert!((whole.velocity[k] - c.velocity[k]).abs() < 1e-9);
            }
            assert_eq!(whole.roll_from_mps, c.roll_from_mps);
        }
    }

    #[test]
    fn outside_the_bounds_moving_out_reflects_at_once() {
        let m = MotionModel::default();
        let b = bounds();
        let f = fly([b.x_max + 0.02, 0.0], [0.5, 0.0], 0.1, &m, &b);
        assert_eq!(f.hits().count(), 1);
        assert!(f.velocity[0] < 0.0);
    }

    #[test]
    fn open_sides_let_the_ball_leave() {
        let pitch = Pitch {
            walls: vec![WallSide::YMax, WallSide::YMin],
            ..Pitch::default()
        };
        let b = Bounds::from_pitch(&pitch);
        let f = fly([1.5, 0.0], [2.0, 0.0], 1.0, &MotionModel::default(), &b);
        assert!(f.position[0] > 1.95);
        assert_eq!(f.hits().count(), 0);
    }
}
