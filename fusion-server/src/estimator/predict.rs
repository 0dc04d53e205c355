//! The predicted path in closed form: samples, wall bounces, and where the ball stops
//! (their covariances: [`super::spread`]).

use super::motion::{Bounds, MotionModel, fly, speed, stop_point};
use proto::{BounceEvent, PathSample, Prediction, Stamp, StopPoint};

/// Longest time a stop is searched for; a ball on a frictionless model never stops.
pub const MAX_STOP_SEARCH_S: f64 = 60.0;

/// The path from (`position`, `velocity`) at `stamp` over `horizon_s`, sampled every
/// `sample_dt_s`, with every wall bounce inside the horizon and the stop point.
pub fn path(
    position: [f64; 2],
    velocity: [f64; 2],
    model: &MotionModel,
    bounds: &Bounds,
    stamp: Stamp,
    horizon_s: f64,
    sample_dt_s: f64,
) -> Prediction {
    let horizon_s = horizon_s.max(0.0);
    let n = if sample_dt_s > 0.0 {
        (horizon_s / sample_dt_s).ceil() as usize
    } else {
        0
    };
    // Sample to sample (the flight is a flow: flying t1 then t2 is flying t1 + t2), so the
    // path costs one flight, not one per sample.
    let mut samples = Vec::with_capacity(n + 1);
    let (mut p, mut v, mut t_prev) = (position, velocity, 0.0);
    if speed(v) < model.stop_speed_mps {
        v = [0.0, 0.0];
    }
    for k in 0..=n {
        let t_s = (k as f64 * sample_dt_s).min(horizon_s);
        if t_s > t_prev && (v[0] != 0.0 || v[1] != 0.0) {
            let f = fly(p, v, t_s - t_prev, model, bounds);
            (p, v) = (f.position, f.velocity);
        }
        t_prev = t_s;
        samples.push(PathSample {
            t_s,
            position_m: p,
            velocity_mps: v,
            covariance_m2: None,
        });
    }
    let whole = fly(position, velocity, horizon_s, model, bounds);
    let bounces = whole
        .hits()
        .map(|h| BounceEvent {
            t_s: h.t_s,
            position_m: h.position,
            wall: h.wall,
        })
        .collect();
    Prediction {
        version: proto::VERSION,
        stamp,
        horizon_s,
        samples,
        bounces,
        stop: stop(position, velocity, model, bounds),
    }
}

/// Where and when the ball comes to rest (now, if it is at rest).
pub fn stop(
    position: [f64; 2],
    velocity: [f64; 2],
    model: &MotionModel,
    bounds: &Bounds,
) -> Option<StopPoint> {
    if speed(velocity) < model.stop_speed_mps {
        return Some(StopPoint {
            t_s: 0.0,
            position_m: position,
            covariance_m2: None,
        });
    }
    let f = stop_point(position, velocity, model, bounds, MAX_STOP_SEARCH_S);
    f.stopped_at_s.map(|t_s| StopPoint {
        t_s,
        position_m: f.position,
        covariance_m2: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_samples_bounces_and_stop_agree() {
        let m = MotionModel::default();
        let b = Bounds::from_pitch(&proto::Pitch::default());
        let pred = path([1.0, 0.0], [1.5, 0.0], &m, &b, Stamp(7), 3.0, 0.1);
        assert_eq!(pred.samples.len(), 31);
        assert_eq!(pred.samples[0].position_m, [1.0, 0.0]);
        assert_eq!(pred.bounces.len(), 1);
        let hit = pred.bounces[0];
        assert_eq!(hit.wall, proto::WallSide::XMax);
        assert!((hit.position_m[0] - b.x_max).abs() < 1e-12);
        // The sample just after the bounce moves back towards the centre.
        let after = pred
            .samples
            .iter()
            .find(|s| s.t_s > hit.t_s)
            .expect("sample after");
        assert!(after.velocity_mps[0] < 0.0);
        let stop = pred.stop.expect("stops");
        assert!(stop.t_s > hit.t_s && stop.position_m[0] < b.x_max);
    }

    #[test]
    fn samples_are_the_flight_at_their_times() {
        let m = MotionModel::default();
        let b = Bounds::from_pitch(&proto::Pitch::default());
        // Through a corner, a bounce and the stop.
        let (p0, v0) = ([1.2, 0.8], [2.0, 1.6]);
        let pred = path(p0, v0, &m, &b, Stamp(0), 3.0, 0.1);
        for s in &pred.samples {
            let f = fly(p0, v0, s.t_s, &m, &b);
            for k in 0..2 {
                assert!(
                    (s.position_m[k] - f.position[k]).abs() < 1e-9,
                    "{s:?} {f:?}"
                );
                assert!(
                    (s.velocity_mps[k] - f.velocity[k]).abs() < 1e-9,
                    "{s:?} {f:?}"
                );
            }
        }
    }

    #[test]
    fn ball_at_rest_stops_now() {
        let m = MotionModel::default();
        let b = Bounds::from_pitch(&proto::Pitch::default());
        let s = stop([0.2, 0.3], [0.0, 0.001], &m, &b).expect("at rest");
        assert_eq!((s.t_s, s.position_m), (0.0, [0.2, 0.3]));
    }
}
