//! How sure the predicted path is: a covariance for every predicted point and for the stop.
//!
//! The filter's state (position, velocity, rolling deceleration, wall restitution) and its
//! covariance go through the closed-form flight by the unscented transform: twelve sigma
//! points, each flown sample to sample with its own deceleration and restitution, so that
//! the spread follows the flight's non-linear turns (a stop, a bounce off a wall, or a
//! bounce for some sigma points and none for others: the covariance then covers both
//! branches). To that the flight's process noise is added (the filter's own, flown along
//! the served path). Each covariance is taken about the served point, not about the
//! sigma points' mean, so that it also covers how far the served path is from their
//! average. Pure: no clock, no I/O.

use super::filter::{Cov, DECEL, ProcessNoise, RESTITUTION, State, propagate};
use super::motion::{Bounds, MotionModel, fly, speed};
use super::predict;
use nalgebra::SymmetricEigen;
use proto::Prediction;

/// The smallest variance served on each axis, m² (1 mm standard deviation): a covariance
/// the protocol takes must be positive definite.
pub const FLOOR_M2: f64 = 1e-6;

/// The deceleration and restitution a sigma point may take (the filter's own bounds).
const DECEL_RANGE: (f64, f64) = (0.02, 3.0);
const RESTITUTION_RANGE: (f64, f64) = (0.05, 0.95);

/// Sets `covariance_m2` on every sample and on the stop of `prediction`, which was flown
/// from the filter's mean `x` with `model`.
pub fn spread(
    prediction: &mut Prediction,
    x: &State,
    p: &Cov,
    model: &MotionModel,
    bounds: &Bounds,
    noise: &ProcessNoise,
) {
    let sigmas = sigma_points(x, p);
    let times: Vec<f64> = prediction.samples.iter().map(|s| s.t_s).collect();
    let flown: Vec<Vec<[f64; 2]>> = sigmas
        .iter()
        .map(|s| fly_samples(s, model, bounds, &times))
        .collect();
    let q = process_noise(x, model, bounds, noise, &times);
    let weight = 1.0 / sigmas.len() as f64;
    for (k, sample) in prediction.samples.iter_mut().enumerate() {
        let around = sample.position_m;
        let c = scatter(flown.iter().map(|f| f[k]), around, weight);
        sample.covariance_m2 = Some(finish(c, q[k]));
    }
    if let Some(stop) = &mut prediction.stop {
        let stops: Vec<[f64; 2]> = sigmas
            .iter()
            .filter_map(|s| {
                let m = sigma_model(s, model);
                predict::stop([s[0], s[1]], [s[2], s[3]], &m, bounds).map(|p| p.position_m)
            })
            .collect();
        // Sigma points that never stop within the search are left out; with none left the
        // stop carries the process noise alone.
        let w = if stops.is_empty() {
            0.0
        } else {
            1.0 / stops.len() as f64
        };
        let c = scatter(stops.into_iter(), stop.position_m, w);
        let q_stop = process_noise(x, model, bounds, noise, &[stop.t_s])[0];
        stop.covariance_m2 = Some(finish(c, q_stop));
    }
}

/// Widens the covariances of `served` to cover another branch of the flight too: `other`
/// (the same sample times), taken with probability `weight`. Each becomes the mixture's
/// second moment about the served point: (1 − w)·C + w·(C' + d·dᵀ), d the other branch's
/// point less the served one. The served points stay those of `served`.
pub fn mix(served: &mut Prediction, other: &Prediction, weight: f64) {
    let w = weight.clamp(0.0, 1.0);
    for (s, o) in served.samples.iter_mut().zip(&other.samples) {
        if let (Some(c), Some(c_other)) = (&mut s.covariance_m2, o.covariance_m2) {
            *c = mixed(*c, c_other, s.position_m, o.position_m, w);
        }
    }
    if let (Some(stop), Some(o)) = (&mut served.stop, &other.stop)
        && let (Some(c), Some(c_other)) = (&mut stop.covariance_m2, o.covariance_m2)
    {
        *c = mixed(*c, c_other, stop.position_m, o.position_m, w);
    }
}

/// (1 − w)·`c` + w·(`c_other` + d·dᵀ), d = `other` − `at`.
pub fn mixed(c: [f64; 4], c_other: [f64; 4], at: [f64; 2], other: [f64; 2], w: f64) -> [f64; 4] {
    let d = [other[0] - at[0], other[1] - at[1]];
    let outer = [d[0] * d[0], d[0] * d[1], d[1] * d[0], d[1] * d[1]];
    std::array::from_fn(|i| (1.0 - w) * c[i] + w * (c_other[i] + outer[i]))
}

/// The covariance of the ball's position `t_s` after the filter's time, about `around`
/// (the served point there), as [`spread`] gives it for a predicted point.
pub fn covariance_at(
    x: &State,
    p: &Cov,
    model: &MotionModel,
    bounds: &Bounds,
    noise: &ProcessNoise,
    t_s: f64,
    around: [f64; 2],
) -> [f64; 4] {
    let sigmas = sigma_points(x, p);
    let weight = 1.0 / sigmas.len() as f64;
    let points = sigmas
        .iter()
        .map(|s| fly_samples(s, model, bounds, &[t_s])[0]);
    let c = scatter(points, around, weight);
    finish(c, process_noise(x, model, bounds, noise, &[t_s])[0])
}

/// The probability that a ball whose position is N(`point`, `cov`) lies within `reach_m` of
/// `point`: exact for a round covariance, and for an elongated one the round covariance of
/// the same area's (the mass within a circle of a Gaussian with standard deviations σ₁,
/// σ₂ is close to 1 − exp(−r² / 2σ₁σ₂) unless they differ greatly).
pub fn within_reach(cov: [f64; 4], reach_m: f64) -> f64 {
    let det = cov[0] * cov[3] - 0.25 * (cov[1] + cov[2]).powi(2);
    if det.is_nan() || reach_m.is_nan() || det <= 0.0 || reach_m <= 0.0 {
        return 0.0;
    }
    (1.0 - (-reach_m * reach_m / (2.0 * det.sqrt())).exp()).clamp(0.0, 1.0)
}

/// The twelve symmetric sigma points x ± √6 · (the columns of a square root of the
/// covariance: its Cholesky factor, or through its eigenvectors when it is only
/// semi-definite), with the model parameters kept inside the filter's bounds.
fn sigma_points(x: &State, p: &Cov) -> Vec<State> {
    let sym = 0.5 * (p + p.transpose());
    let n = 6.0_f64;
    let root: Cov = match sym.cholesky() {
        Some(c) => c.l() * n.sqrt(),
        None => {
            let eig = SymmetricEigen::new(sym);
            let mut r = eig.eigenvectors;
            for i in 0..6 {
                let scale = (n * eig.eigenvalues[i].max(0.0)).sqrt();
                r.column_mut(i).scale_mut(scale);
            }
            r
        }
    };
    let mut out = Vec::with_capacity(12);
    for i in 0..6 {
        let col = root.column(i);
        for sign in [1.0, -1.0] {
            let mut s = x + col * sign;
            s[DECEL] = s[DECEL].clamp(DECEL_RANGE.0, DECEL_RANGE.1);
            s[RESTITUTION] = s[RESTITUTION].clamp(RESTITUTION_RANGE.0, RESTITUTION_RANGE.1);
            out.push(s);
        }
    }
    out
}

fn sigma_model(s: &State, model: &MotionModel) -> MotionModel {
    MotionModel {
        decel_mps2: s[DECEL],
        restitution: s[RESTITUTION],
        ..*model
    }
}

/// A sigma point's positions at `times`, flown sample to sample as the served path is.
fn fly_samples(s: &State, model: &MotionModel, bounds: &Bounds, times: &[f64]) -> Vec<[f64; 2]> {
    let m = sigma_model(s, model);
    let (mut p, mut v, mut t_prev) = ([s[0], s[1]], [s[2], s[3]], 0.0);
    if speed(v) < m.stop_speed_mps {
        v = [0.0, 0.0];
    }
    let mut roll_from = m.roll_from_mps;
    times
        .iter()
        .map(|&t| {
            if t > t_prev && (v[0] != 0.0 || v[1] != 0.0) {
                let step = MotionModel {
                    roll_from_mps: roll_from,
                    ..m
                };
                let f = fly(p, v, t - t_prev, &step, bounds);
                (p, v, roll_from) = (f.position, f.velocity, f.roll_from_mps);
            }
            t_prev = t.max(t_prev);
            p
        })
        .collect()
}

/// The position block of the process noise accumulated along the mean flight to each of
/// `times` (from no uncertainty at the start).
fn process_noise(
    x: &State,
    model: &MotionModel,
    bounds: &Bounds,
    noise: &ProcessNoise,
    times: &[f64],
) -> Vec<[f64; 4]> {
    let (mut xs, mut q, mut t_prev, mut m) = (*x, Cov::zeros(), 0.0, *model);
    times
        .iter()
        .map(|&t| {
            if t > t_prev {
                let (x_new, q_new, flight) = propagate(&xs, &q, t - t_prev, &m, bounds, noise);
                (xs, q) = (x_new, q_new);
                m.roll_from_mps = flight.roll_from_mps;
                t_prev = t;
            }
            [q[(0, 0)], q[(0, 1)], q[(1, 0)], q[(1, 1)]]
        })
        .collect()
}

/// Σ w (y − around)(y − around)ᵀ over the points, row-major.
fn scatter(points: impl Iterator<Item = [f64; 2]>, around: [f64; 2], weight: f64) -> [f64; 4] {
    let mut c = [0.0; 4];
    for y in points {
        let d = [y[0] - around[0], y[1] - around[1]];
        c[0] += weight * d[0] * d[0];
        c[1] += weight * d[0] * d[1];
        c[3] += weight * d[1] * d[1];
    }
    c[2] = c[1];
    c
}

/// The spread plus the process noise, symmetric, with the floor on the diagonal.
fn finish(c: [f64; 4], q: [f64; 4]) -> [f64; 4] {
    let off = 0.5 * (c[1] + c[2] + q[1] + q[2]);
    [c[0] + q[0] + FLOOR_M2, off, off, c[3] + q[3] + FLOOR_M2]
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use proto::Stamp;

    fn noise() -> ProcessNoise {
        ProcessNoise {
            accel_m2ps3: 0.01,
            rest_pos_m2ps: 1e-6,
            rest_vel_m2ps3: 1e-4,
            rest_velocity_tau_s: 0.5,
            decel_per_s: 0.0,
            restitution_per_s: 0.0,
            bounce_normal_frac: 0.1,
            bounce_tangential_frac: 0.05,
        }
    }

    fn state(p: [f64; 2], v: [f64; 2]) -> State {
        State::from_column_slice(&[p[0], p[1], v[0], v[1], 0.3, 0.5])
    }

    fn cov(pos: f64, vel: f64, decel: f64, rest: f64) -> Cov {
        Cov::from_diagonal(&State::from_column_slice(&[
            pos, pos, vel, vel, decel, rest,
        ]))
    }

    fn predicted(x: &State, p: &Cov) -> Prediction {
        let m = MotionModel::default();
        let b = Bounds::from_pitch(&proto::Pitch::default());
        let mut pred = predict::path([x[0], x[1]], [x[2], x[3]], &m, &b, Stamp(0), 3.0, 0.1);
        spread(&mut pred, x, p, &m, &b, &noise());
        pred
    }

    fn det(c: [f64; 4]) -> f64 {
        c[0] * c[3] - c[1] * c[2]
    }

    #[test]
    fn uncertainty_grows_along_a_rolling_path_and_is_served_valid() {
        let x = state([-1.0, 0.0], [0.8, 0.1]);
        let pred = predicted(&x, &cov(1e-4, 4e-3, 1e-3, 1e-3));
        let c: Vec<[f64; 4]> = pred
            .samples
            .iter()
            .map(|s| s.covariance_m2.unwrap())
            .collect();
        // At the start the position's own variance; later more, along the motion most.
        assert!((c[0][0] - 1e-4 - FLOOR_M2).abs() < 1e-9, "{:?}", c[0]);
        assert!(
            c[10][0] > 3.0 * c[0][0] && c[20][0] > c[10][0],
            "{:?}",
            &c[..21]
        );
        assert!(
            c[10][0] > c[10][3],
            "along the motion more than across: {:?}",
            c[10]
        );
        assert!(pred.stop.unwrap().covariance_m2.is_some());
        let ctx = proto::ValidationContext::new(proto::Pitch::default(), Stamp(0));
        proto::Validate::validate(&pred, &ctx).expect("served covariances are valid");
        assert!(c.iter().all(|c| det(*c) > 0.0));
    }

    #[test]
    fn reach_probability_grows_with_reach_and_falls_with_spread() {
        let tight = [0.0025, 0.0, 0.0, 0.0025];
        // σ = 5 cm round: within one σ 39 %, within two 86 %.
        assert!((within_reach(tight, 0.05) - 0.3935).abs() < 1e-3);
        assert!((within_reach(tight, 0.10) - 0.8647).abs() < 1e-3);
        assert!(within_reach([0.04, 0.0, 0.0, 0.04], 0.10) < within_reach(tight, 0.10));
        assert_eq!(within_reach([0.0, 0.0, 0.0, 0.0], 0.1), 0.0);
        let x = state([0.0, 0.0], [0.6, 0.0]);
        let p = cov(1e-4, 4e-3, 1e-3, 1e-3);
        let m = MotionModel::default();
        let b = Bounds::from_pitch(&proto::Pitch::default());
        let pred = predicted(&x, &p);
        let at = pred.samples[10];
        let c = covariance_at(&x, &p, &m, &b, &noise(), at.t_s, at.position_m);
        let served = at.covariance_m2.unwrap();
        for k in 0..4 {
            assert!((c[k] - served[k]).abs() < 1e-9, "{c:?} {served:?}");
        }
    }

    #[test]
    fn a_certain_state_keeps_only_the_process_noise() {
        let x = state([0.0, 0.0], [0.5, 0.0]);
        let pred = predicted(&x, &Cov::zeros());
        let c1 = pred.samples[10].covariance_m2.unwrap();
        // White acceleration: q t³/3 along each axis after 1 s, plus the floor.
        assert!((c1[0] - (0.01 / 3.0 + FLOOR_M2)).abs() < 1e-6, "{c1:?}");
    }

    #[test]
    fn a_ball_that_may_or_may_not_reach_the_wall_spreads_over_both() {
        // Heading for the x wall with an uncertain speed: some sigma points bounce back.
        let b = Bounds::from_pitch(&proto::Pitch::default());
        let x = state([b.x_max - 0.4, 0.0], [0.55, 0.0]);
        let pred = predicted(&x, &cov(1e-4, 0.02, 1e-3, 1e-3));
        let stop = pred.stop.unwrap();
        let c = stop.covariance_m2.unwrap();
        assert!(
            c[0].sqrt() > 0.05,
            "the stop's spread along x covers both: {c:?}"
        );
        assert!(stop.position_m[0] <= b.x_max);
    }
}
