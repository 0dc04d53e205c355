//! Where a robot can meet the ball: the earliest point on the predicted path that a robot
//! at a given position and top speed reaches no later than the ball does.

use super::motion::{Bounds, MotionModel, fly};
use super::predict::{MAX_STOP_SEARCH_S, stop};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterceptSolution {
    /// False when the ball has stopped before the robot can reach its path.
    pub reachable_in_motion: bool,
    /// Seconds from now.
    pub t_s: f64,
    pub point_m: [f64; 2],
    /// How likely the ball is within the robot's reach there and then, given how sure the
    /// path is (set by the caller that knows the covariance: [`super::spread`]).
    pub probability: Option<f64>,
}

const SCAN_DT_S: f64 = 0.01;

/// `g(t) = |path(t) − robot| − speed·t`: the robot makes it when this is ≤ 0.
fn margin(
    p: [f64; 2],
    v: [f64; 2],
    m: &MotionModel,
    b: &Bounds,
    robot: [f64; 2],
    speed_mps: f64,
    t_s: f64,
) -> (f64, [f64; 2]) {
    let at = fly(p, v, t_s, m, b).position;
    (
        (at[0] - robot[0]).hypot(at[1] - robot[1]) - speed_mps * t_s,
        at,
    )
}

/// The earliest meeting point; `None` for a non-positive or non-finite speed.
pub fn intercept(
    position: [f64; 2],
    velocity: [f64; 2],
    model: &MotionModel,
    bounds: &Bounds,
    robot: [f64; 2],
    speed_mps: f64,
) -> Option<InterceptSolution> {
    if !(speed_mps.is_finite() && speed_mps > 0.0) {
        return None;
    }
    let rest = stop(position, velocity, model, bounds).unwrap_or(proto::StopPoint {
        t_s: MAX_STOP_SEARCH_S,
        position_m: fly(position, velocity, MAX_STOP_SEARCH_S, model, bounds).position,
        covariance_m2: None,
    });
    let t_stop = rest.t_s.min(MAX_STOP_SEARCH_S);
    let g = |t: f64| margin(position, velocity, model, bounds, robot, speed_mps, t);
    let (g0, p0) = g(0.0);
    if g0 <= 0.0 {
        return Some(InterceptSolution {
            reachable_in_motion: true,
            t_s: 0.0,
            point_m: p0,
            probability: None,
        });
    }
    let mut lo = 0.0;
    let mut t = SCAN_DT_S;
    while t < t_stop {
        if g(t).0 <= 0.0 {
            // Bisect the first crossing between lo and t.
            let mut hi = t;
            for _ in 0..40 {
                let mid = 0.5 * (lo + hi);
                if g(mid).0 <= 0.0 {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            return Some(InterceptSolution {
                reachable_in_motion: true,
                t_s: hi,
                point_m: g(hi).1,
                probability: None,
            });
        }
        lo = t;
        t += SCAN_DT_S;
    }
    let d = (rest.position_m[0] - robot[0]).hypot(rest.position_m[1] - robot[1]);
    Some(InterceptSolution {
        reachable_in_motion: false,
        t_s: (d / speed_mps).max(t_stop),
        point_m: rest.position_m,
        probability: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn b() -> Bounds {
        Bounds::from_pitch(&proto::Pitch::default())
    }

    #[test]
    fn robot_on_the_path_meets_the_ball_when_both_arrive() {
        let m = MotionModel {
            decel_mps2: 0.0,
            ..MotionModel::default()
        };
        // Ball along +x at 0.5 m/s; robot 1 m ahead on the line, 0.4 m/s towards it.
        let s = intercept([0.0, 0.0], [0.5, 0.0], &m, &b(), [1.0, 0.0], 0.4).expect("valid");
        assert!(s.reachable_in_motion);
        assert!((s.t_s - 1.0 / 0.9).abs() < 1e-6, "{}", s.t_s);
        assert!((s.point_m[0] - 0.5 / 0.9).abs() < 1e-6);
    }

    #[test]
    fn slow_robot_far_away_meets_the_ball_at_rest() {
        let m = MotionModel::default();
        let s = intercept([0.0, 0.0], [0.3, 0.0], &m, &b(), [-1.8, 1.2], 0.1).expect("valid");
        assert!(!s.reachable_in_motion);
        let stop_x = (0.3f64.powi(2) - m.stop_speed_mps.powi(2)) / (2.0 * m.decel_mps2);
        assert!((s.point_m[0] - stop_x).abs() < 1e-6);
        let d = (s.point_m[0] + 1.8).hypot(1.2);
        assert!((s.t_s - d / 0.1).abs() < 1e-6);
    }

    #[test]
    fn earliest_meeting_is_never_beaten_on_a_fine_grid() {
        let m = MotionModel::default();
        let (p, v, robot, speed) = ([0.5, -0.2], [1.6, 0.9], [1.0, 0.8], 0.4);
        let s = intercept(p, v, &m, &b(), robot, speed).expect("valid");
        for k in 0..((s.t_s / 0.001) as usize) {
            let t = k as f64 * 0.001;
            let at = fly(p, v, t, &m, &b()).position;
            assert!((at[0] - robot[0]).hypot(at[1] - robot[1]) > speed * t - 1e-9);
        }
    }

    #[test]
    fn rejects_bad_speed() {
        let m = MotionModel::default();
        assert!(intercept([0.0; 2], [0.0; 2], &m, &b(), [1.0, 0.0], 0.0).is_none());
        assert!(intercept([0.0; 2], [0.0; 2], &m, &b(), [1.0, 0.0], f64::NAN).is_none());
    }
}
