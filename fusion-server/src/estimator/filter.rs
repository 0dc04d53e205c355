//! One extended Kalman filter over [x, y, vx, vy, decel, restitution].
//!
//! The mean is flown with the closed-form [`motion`](super::motion) model. The covariance
//! goes through the flight piece by piece: constant-velocity Jacobians for straight
//! segments (with the sensitivity to the deceleration), reflections at wall hits (with the
//! sensitivity to the restitution). The constant-velocity Jacobian is kept even for a ball at
//! rest so that a kick stays observable; it composes exactly, so the covariance is a flow too.
//! The two model parameters are states, learned from the data where they are observable
//! and frozen (Schmidt "consider" states) where the data would mislead them.

use super::motion::{Bounds, Flight, MotionModel, Piece, fly, speed};
use nalgebra::{Cholesky, Const, Matrix2, SMatrix, SVector, Vector2};

pub type State = SVector<f64, 6>;
pub type Cov = SMatrix<f64, 6, 6>;

pub const DECEL: usize = 4;
pub const RESTITUTION: usize = 5;

const DECEL_RANGE: (f64, f64) = (0.02, 3.0);
const RESTITUTION_RANGE: (f64, f64) = (0.05, 0.95);

/// Process noise for one prediction step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProcessNoise {
    /// White-acceleration spectral density while the ball moves (m²/s³).
    pub accel_m2ps3: f64,
    /// Position random walk while at rest (m²/s).
    pub rest_pos_m2ps: f64,
    /// White-acceleration spectral density while at rest (m²/s³): a kick may come.
    pub rest_vel_m2ps3: f64,
    /// Time constant of the velocity's mean reversion while at rest; infinite for none
    /// (a fresh or just-kicked track whose velocity is still unknown).
    pub rest_velocity_tau_s: f64,
    /// Random walk of the deceleration and restitution states (per second).
    pub decel_per_s: f64,
    pub restitution_per_s: f64,
    /// Per-bounce spread of the restitution, as a fraction of the normal speed in.
    pub bounce_normal_frac: f64,
    /// Per-bounce spread of the tangential loss, as a fraction of the tangential speed.
    pub bounce_tangential_frac: f64,
}

/// What an observation would change: innovation, its covariance and Mahalanobis distance²
/// (infinite when the covariance is not positive definite).
#[derive(Debug, Clone, Copy)]
pub struct Innovation {
    pub y: Vector2<f64>,
    pub s: Matrix2<f64>,
    pub d2: f64,
}

/// Why an update could not be made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FilterError {
    #[error("the innovation covariance is not positive definite")]
    SingularInnovation,
}

/// The innovation with the one factorisation of its covariance that both the distance and
/// the gain use.
struct Factored {
    innovation: Innovation,
    s_chol: Cholesky<f64, Const<2>>,
}

/// Which model parameters an observation may correct (the others are "consider" states).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Learn {
    pub decel: bool,
    pub restitution: bool,
}

/// Starting values of the model parameters: (mean, variance) of each.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelPrior {
    pub decel: (f64, f64),
    pub restitution: (f64, f64),
}

#[derive(Debug, Clone, PartialEq)]
pub struct BallFilter {
    x: State,
    p: Cov,
    /// Filter time in seconds since the fusion epoch.
    t_s: f64,
    /// The ball slides while faster than this ([`MotionModel::roll_from_mps`])...
    roll_from_mps: f64,
    /// ... since the kick at this time.
    kick_t_s: Option<f64>,
}

impl BallFilter {
    /// A filter started at a measured position with unknown velocity.
    pub fn start(
        z: [f64; 2],
        r: &Matrix2<f64>,
        t_s: f64,
        velocity_sigma_mps: f64,
        params: ModelPrior,
    ) -> Self {
        let ModelPrior {
            decel: (decel, decel_var),
            restitution: (restitution, restitution_var),
        } = params;
        let x = State::from_column_slice(&[z[0], z[1], 0.0, 0.0, decel, restitution]);
        let mut p = Cov::zeros();
        p.fixed_view_mut::<2, 2>(0, 0).copy_from(r);
        let vv = velocity_sigma_mps * velocity_sigma_mps;
        p[(2, 2)] = vv;
        p[(3, 3)] = vv;
        p[(DECEL, DECEL)] = decel_var;
        p[(RESTITUTION, RESTITUTION)] = restitution_var;
        BallFilter {
            x,
            p,
            t_s,
            roll_from_mps: 0.0,
            kick_t_s: None,
        }
    }

    /// A filter started from two sightings of a moving ball, `z0` (covariance `r0`) at
    /// `t0_s` and `z1` (`r1`) at the later `t1_s`: at `z1`, its velocity the average between
    /// them less the deceleration's share over the gap, the velocity's covariance that of
    /// the difference with `slack_mps` per axis for what a straight line cannot know (a kick
    /// or a bend between the two). Two-point track initiation: a fast ball seen twice is
    /// tracked at once, where one sighting with an unknown velocity cannot gate the next.
    pub fn through(
        (z0, r0, t0_s): ([f64; 2], &Matrix2<f64>, f64),
        (z1, r1, t1_s): ([f64; 2], &Matrix2<f64>, f64),
        slack_mps: f64,
        params: ModelPrior,
    ) -> Self {
        let dt = (t1_s - t0_s).max(1e-3);
        let mut v = [(z1[0] - z0[0]) / dt, (z1[1] - z0[1]) / dt];
        let s = v[0].hypot(v[1]);
        let lost = 0.5 * params.decel.0.max(0.0) * dt;
        let keep = if s > lost { (s - lost) / s } else { 1.0 };
        v = [v[0] * keep, v[1] * keep];
        let mut f = BallFilter::start(z1, r1, t1_s, 0.0, params);
        f.x[2] = v[0];
        f.x[3] = v[1];
        let pv = r1 / dt;
        let vv = (r0 + r1) / (dt * dt) + Matrix2::identity() * slack_mps * slack_mps;
        f.p.fixed_view_mut::<2, 2>(0, 2).copy_from(&pv);
        f.p.fixed_view_mut::<2, 2>(2, 0).copy_from(&pv.transpose());
        f.p.fixed_view_mut::<2, 2>(2, 2).copy_from(&vv);
        f
    }

    /// The mean: [x, y, vx, vy, decel, restitution].
    pub fn state(&self) -> &State {
        &self.x
    }

    /// The covariance of [`state`](Self::state).
    pub fn covariance(&self) -> &Cov {
        &self.p
    }

    /// Filter time in seconds since the fusion epoch.
    pub fn time_s(&self) -> f64 {
        self.t_s
    }

    /// Sets component `k` of the state to `value` with `variance`, uncorrelated with the
    /// others: what a prior on it alone says (a forgotten velocity, a carried-over model).
    pub fn reset_component(&mut self, k: usize, value: f64, variance: f64) {
        self.x[k] = value;
        for j in 0..6 {
            self.p[(k, j)] = 0.0;
            self.p[(j, k)] = 0.0;
        }
        self.p[(k, k)] = variance;
    }

    /// The ball was kicked at `kick_t_s` and slides, by `model`, until its speed falls to
    /// `model.roll_ratio` of the kick's: its speed now plus what the slide took since. Called
    /// again after each update while it slides, so that the kick's speed is read from all
    /// the sightings since; a ball already that slow rolls.
    pub fn slide_since(&mut self, kick_t_s: f64, model: &MotionModel) {
        let s = speed(self.velocity());
        let a = model.slide_decel_mps2;
        let roll_from = model.roll_ratio * (s + a.max(0.0) * (self.t_s - kick_t_s).max(0.0));
        if a > model.decel_mps2 && roll_from.is_finite() && s > roll_from {
            self.roll_from_mps = roll_from;
            self.kick_t_s = Some(kick_t_s);
        } else {
            self.roll();
        }
    }

    /// The ball rolls (no slide phase).
    pub fn roll(&mut self) {
        self.roll_from_mps = 0.0;
        self.kick_t_s = None;
    }

    /// When the ball that still slides was kicked.
    pub fn kick_time_s(&self) -> Option<f64> {
        self.kick_t_s.filter(|_| self.roll_from_mps > 0.0)
    }

    /// Whether the ball still slides after a kick.
    pub fn sliding(&self) -> bool {
        self.roll_from_mps > 0.0
    }

    /// Keeps the restitution within `[lo, hi]` (a learning step's bound).
    pub fn clamp_restitution(&mut self, lo: f64, hi: f64) {
        self.x[RESTITUTION] = self.x[RESTITUTION].clamp(lo, hi);
    }

    pub fn position(&self) -> [f64; 2] {
        [self.x[0], self.x[1]]
    }

    pub fn velocity(&self) -> [f64; 2] {
        [self.x[2], self.x[3]]
    }

    /// The motion model with this filter's learned parameters.
    pub fn model(&self, base: &MotionModel) -> MotionModel {
        MotionModel {
            decel_mps2: self.x[DECEL],
            restitution: self.x[RESTITUTION],
            roll_from_mps: self.roll_from_mps,
            ..*base
        }
    }

    /// Predicts forward to `t_s` (no-op if not later). Returns the flight flown.
    pub fn predict_to(
        &mut self,
        t_s: f64,
        base: &MotionModel,
        bounds: &Bounds,
        noise: &ProcessNoise,
    ) -> Option<Flight> {
        let dt_s = t_s - self.t_s;
        if dt_s <= 0.0 {
            return None;
        }
        let base = MotionModel {
            roll_from_mps: self.roll_from_mps,
            ..*base
        };
        let (x, p, flight) = propagate(&self.x, &self.p, dt_s, &base, bounds, noise);
        self.x = x;
        self.p = p;
        self.t_s = t_s;
        self.roll_from_mps = flight.roll_from_mps;
        if self.roll_from_mps == 0.0 {
            self.kick_t_s = None;
        }
        Some(flight)
    }

    /// The innovation of `z` (covariance `r`) and the Cholesky factor of its covariance.
    fn factor(&self, z: [f64; 2], r: &Matrix2<f64>) -> Result<Factored, FilterError> {
        let y = Vector2::new(z[0] - self.x[0], z[1] - self.x[1]);
        let s = self.p.fixed_view::<2, 2>(0, 0) + r;
        let s_chol = Cholesky::new(s).ok_or(FilterError::SingularInnovation)?;
        let d2 = y.dot(&s_chol.solve(&y));
        Ok(Factored {
            innovation: Innovation { y, s, d2 },
            s_chol,
        })
    }

    /// What observing `z` with covariance `r` would change; its distance is infinite when
    /// the innovation covariance is not positive definite.
    pub fn innovation(&self, z: [f64; 2], r: &Matrix2<f64>) -> Innovation {
        match self.factor(z, r) {
            Ok(f) => f.innovation,
            Err(_) => Innovation {
                y: Vector2::new(z[0] - self.x[0], z[1] - self.x[1]),
                s: self.p.fixed_view::<2, 2>(0, 0) + r,
                d2: f64::INFINITY,
            },
        }
    }

    /// Covariance-weighted update with measurement covariance `r`. `learn` says whether the
    /// deceleration and restitution states may be corrected by this observation. An
    /// innovation covariance that is not positive definite leaves the filter as it was and
    /// is an error.
    pub fn update(
        &mut self,
        z: [f64; 2],
        r: &Matrix2<f64>,
        learn: Learn,
    ) -> Result<Innovation, FilterError> {
        let Factored {
            innovation: inn,
            s_chol,
        } = self.factor(z, r)?;
        // K = P Hᵀ S⁻¹, from Kᵀ = S⁻¹ H P (S and P symmetric).
        let mut k: SMatrix<f64, 6, 2> = s_chol
            .solve(&self.p.fixed_view::<2, 6>(0, 0).into_owned())
            .transpose();
        if !learn.decel {
            k.row_mut(DECEL).fill(0.0);
        }
        if !learn.restitution {
            k.row_mut(RESTITUTION).fill(0.0);
        }
        self.x += k * inn.y;
        // Joseph form: stays symmetric positive semi-definite for any gain, including the
        // Schmidt gain with frozen rows.
        let mut kh = Cov::zeros();
        kh.fixed_view_mut::<6, 2>(0, 0).copy_from(&k);
        let i_kh = Cov::identity() - kh;
        self.p = i_kh * self.p * i_kh.transpose() + k * r * k.transpose();
        self.p = 0.5 * (self.p + self.p.transpose());
        self.x[DECEL] = self.x[DECEL].clamp(DECEL_RANGE.0, DECEL_RANGE.1);
        self.x[RESTITUTION] = self.x[RESTITUTION].clamp(RESTITUTION_RANGE.0, RESTITUTION_RANGE.1);
        Ok(inn)
    }
}

/// The pure propagation of mean and covariance over `dt_s`.
pub fn propagate(
    x: &State,
    p: &Cov,
    dt_s: f64,
    base: &MotionModel,
    bounds: &Bounds,
    noise: &ProcessNoise,
) -> (State, Cov, Flight) {
    let model = MotionModel {
        decel_mps2: x[DECEL],
        restitution: x[RESTITUTION],
        ..*base
    };
    let flight = fly([x[0], x[1]], [x[2], x[3]], dt_s, &model, bounds);
    let (f, q) = jacobian_and_noise(&flight, &model, noise);
    let mut x_new = *x;
    x_new[0] = flight.position[0];
    x_new[1] = flight.position[1];
    x_new[2] = flight.velocity[0];
    x_new[3] = flight.velocity[1];
    let mut p_new = f * p * f.transpose() + q;
    p_new = 0.5 * (p_new + p_new.transpose());
    (x_new, p_new, flight)
}

/// Accumulates the flight's Jacobian F and process noise Q piece by piece
/// (Q ← A Q Aᵀ + Q_piece, F ← A F), which composes exactly across step splits.
fn jacobian_and_noise(flight: &Flight, model: &MotionModel, noise: &ProcessNoise) -> (Cov, Cov) {
    let mut f = Cov::identity();
    let mut q = Cov::zeros();
    for piece in &flight.pieces {
        let (a, q_piece) = match *piece {
            Piece::Segment {
                dt_s,
                moving_s,
                direction,
                rolling,
            } => segment(dt_s, moving_s, direction, rolling, noise),
            Piece::Hit(hit) => {
                let axis = hit.axis;
                let (n, t) = (2 + axis, 2 + (1 - axis));
                let mut b = Cov::identity();
                b[(axis, axis)] = -model.restitution;
                b[(n, n)] = -model.restitution;
                b[(t, t)] = model.tangential_retention;
                b[(n, RESTITUTION)] = -hit.velocity_in[axis];
                let mut qb = Cov::zeros();
                qb[(n, n)] = (noise.bounce_normal_frac * hit.velocity_in[axis]).powi(2);
                qb[(t, t)] = (noise.bounce_tangential_frac * hit.velocity_in[1 - axis]).powi(2);
                (b, qb)
            }
        };
        q = a * q * a.transpose() + q_piece;
        f = a * f;
    }
    (f, q)
}

fn segment(
    dt_s: f64,
    moving_s: f64,
    dir: [f64; 2],
    rolling: bool,
    noise: &ProcessNoise,
) -> (Cov, Cov) {
    let mut a = Cov::identity();
    let mut q = Cov::zeros();
    if moving_s > 0.0 || !noise.rest_velocity_tau_s.is_finite() {
        // Rolling: constant-velocity Jacobian and white-acceleration noise, which compose
        // exactly, plus the sensitivity to the deceleration.
        let qa = if moving_s > 0.0 {
            noise.accel_m2ps3
        } else {
            noise.rest_vel_m2ps3
        };
        let q_pos = if moving_s > 0.0 {
            0.0
        } else {
            noise.rest_pos_m2ps
        };
        for k in 0..2 {
            a[(k, 2 + k)] = dt_s;
            q[(k, k)] = qa * dt_s.powi(3) / 3.0 + q_pos * dt_s;
            q[(k, 2 + k)] = qa * dt_s.powi(2) / 2.0;
            q[(2 + k, k)] = q[(k, 2 + k)];
            q[(2 + k, 2 + k)] = qa * dt_s;
        }
    } else {
        // At rest: the velocity is a mean-reverting (Ornstein–Uhlenbeck) process. A kick
        // may come, so the velocity keeps some uncertainty and stays observable, but an
        // unseen ball at rest does not drift off by an ever-growing velocity. Exact
        // transition and noise integral, so this composes exactly too.
        let tau = noise.rest_velocity_tau_s;
        let g = (-dt_s / tau).exp();
        let g2 = (-2.0 * dt_s / tau).exp();
        let qa = noise.rest_vel_m2ps3;
        let q_vv = qa * tau / 2.0 * (1.0 - g2);
        let q_pv = qa * tau * (tau * (1.0 - g) - tau / 2.0 * (1.0 - g2));
        let q_pp = qa * tau * tau * (dt_s - 2.0 * tau * (1.0 - g) + tau / 2.0 * (1.0 - g2));
        for k in 0..2 {
            a[(k, 2 + k)] = tau * (1.0 - g);
            a[(2 + k, 2 + k)] = g;
            q[(k, k)] = q_pp + noise.rest_pos_m2ps * dt_s;
            q[(k, 2 + k)] = q_pv;
            q[(2 + k, k)] = q_pv;
            q[(2 + k, 2 + k)] = q_vv;
        }
    }
    // The rolling deceleration acts only while the ball rolls (a sliding one is not a state).
    let m = if rolling { moving_s } else { 0.0 };
    let half_m2 = 0.5 * m * m;
    for k in 0..2 {
        a[(k, DECEL)] = -half_m2 * dir[k];
        a[(2 + k, DECEL)] = -m * dir[k];
    }
    // The deceleration's random walk, integrated exactly through the segment's linear
    // dynamics (ṗ = v, v̇ = −a·u, ȧ = w), so that splitting a segment changes nothing.
    let qd = noise.decel_per_s;
    for i in 0..2 {
        for j in 0..2 {
            let uu = dir[i] * dir[j];
            q[(i, j)] += qd * uu * m.powi(5) / 20.0;
            q[(i, 2 + j)] += qd * uu * m.powi(4) / 8.0;
            q[(2 + i, j)] += qd * uu * m.powi(4) / 8.0;
            q[(2 + i, 2 + j)] += qd * uu * m.powi(3) / 3.0;
        }
        q[(i, DECEL)] = -qd * dir[i] * m.powi(3) / 6.0;
        q[(DECEL, i)] = q[(i, DECEL)];
        q[(2 + i, DECEL)] = -qd * dir[i] * m.powi(2) / 2.0;
        q[(DECEL, 2 + i)] = q[(2 + i, DECEL)];
    }
    q[(DECEL, DECEL)] = qd * dt_s;
    q[(RESTITUTION, RESTITUTION)] = noise.restitution_per_s * dt_s;
    (a, q)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn noise() -> ProcessNoise {
        ProcessNoise {
            accel_m2ps3: 0.05,
            rest_pos_m2ps: 1e-4,
            rest_vel_m2ps3: 0.01,
            rest_velocity_tau_s: 0.3,
            decel_per_s: 1e-4,
            restitution_per_s: 1e-4,
            bounce_normal_frac: 0.15,
            bounce_tangential_frac: 0.05,
        }
    }

    fn filter_at(p: [f64; 2], v: [f64; 2]) -> BallFilter {
        let r = Matrix2::identity() * 1e-3;
        let mut f = BallFilter::start(
            p,
            &r,
            0.0,
            0.5,
            ModelPrior {
                decel: (0.3, 0.01),
                restitution: (0.5, 0.02),
            },
        );
        f.x[2] = v[0];
        f.x[3] = v[1];
        f
    }

    fn bounds() -> Bounds {
        Bounds::from_pitch(&proto::Pitch::default())
    }

    fn is_symmetric_psd(p: &Cov) -> bool {
        let sym = (p - p.transpose()).abs().max() <= 1e-12 * p.abs().max().max(1.0);
        let eig = p.symmetric_eigenvalues();
        sym && eig.iter().all(|e| *e >= -1e-12)
    }

    proptest! {
        #[test]
        fn covariance_stays_symmetric_psd(
            px in -1.9..1.9f64, py in -1.25..1.25f64, vx in -3.0..3.0f64, vy in -3.0..3.0f64,
            steps in proptest::collection::vec((0.001..0.3f64, -2.0..2.0f64, -1.3..1.3f64, 1e-5..0.05f64), 1..40),
        ) {
            let mut f = filter_at([px, py], [vx, vy]);
            let mut t = 0.0;
            for (dt, zx, zy, r) in steps {
                t += dt;
                f.predict_to(t, &MotionModel::default(), &bounds(), &noise());
                prop_assert!(is_symmetric_psd(&f.p));
                let rm = Matrix2::new(r, 0.3 * r, 0.3 * r, 2.0 * r);
                let learn = Learn {
                    decel: true,
                    restitution: true,
                };
                prop_assert!(f.update([zx, zy], &rm, learn).is_ok());
                prop_assert!(is_symmetric_psd(&f.p), "{}", f.p);
            }
        }

        #[test]
        fn predicting_t1_then_t2_equals_t1_plus_t2(
            px in -1.9..1.9f64, py in -1.25..1.25f64, vx in -3.0..3.0f64, vy in -3.0..3.0f64,
            t1 in 0.0..3.0f64, t2 in 0.0..3.0f64,
        ) {
            let f0 = filter_at([px, py], [vx, vy]);
            let (m, b, n) = (MotionModel::default(), bounds(), noise());
            let (x12, p12, _) = propagate(&f0.x, &f0.p, t1 + t2, &m, &b, &n);
            let (x1, p1, _) = propagate(&f0.x, &f0.p, t1, &m, &b, &n);
            let (x2, p2, _) = propagate(&x1, &p1, t2, &m, &b, &n);
            prop_assert!((x12 - x2).abs().max() < 1e-8, "{x12} vs {x2}");
            prop_assert!((p12 - p2).abs().max() < 1e-8 * p12.abs().max().max(1.0), "{p12} vs {p2}");
        }
    }

    #[test]
    fn jacobian_matches_finite_differences_through_a_bounce() {
        let f0 = filter_at([1.5, 0.1], [1.2, 0.4]);
        let (m, b) = (MotionModel::default(), bounds());
        let flight = fly(f0.position(), f0.velocity(), 0.6, &f0.model(&m), &b);
        assert_eq!(flight.hits().count(), 1);
        let (jac, _) = jacobian_and_noise(&flight, &f0.model(&m), &noise());
        let h = 1e-6;
        for j in [0, 1, 2, 3, DECEL, RESTITUTION] {
            let mut xp = f0.x;
            xp[j] += h;
            let mut xm = f0.x;
            xm[j] -= h;
            let fp = fly(
                [xp[0], xp[1]],
                [xp[2], xp[3]],
                0.6,
                &f0.model(&m).with(xp),
                &b,
            );
            let fm = fly(
                [xm[0], xm[1]],
                [xm[2], xm[3]],
                0.6,
                &f0.model(&m).with(xm),
                &b,
            );
            let d = [
                (fp.position[0] - fm.position[0]) / (2.0 * h),
                (fp.position[1] - fm.position[1]) / (2.0 * h),
                (fp.velocity[0] - fm.velocity[0]) / (2.0 * h),
                (fp.velocity[1] - fm.velocity[1]) / (2.0 * h),
            ];
            for i in 0..4 {
                // The constant-velocity Jacobian leaves out the lateral effect of the
                // deceleration's direction (a·t/s ≈ 0.15 here); that bounds the mismatch.
                assert!(
                    (jac[(i, j)] - d[i]).abs() < 0.2,
                    "F[{i},{j}] = {} vs {}",
                    jac[(i, j)],
                    d[i]
                );
            }
        }
    }

    trait With {
        fn with(self, x: State) -> Self;
    }
    impl With for MotionModel {
        fn with(self, x: State) -> Self {
            MotionModel {
                decel_mps2: x[DECEL],
                restitution: x[RESTITUTION],
                ..self
            }
        }
    }

    #[test]
    fn an_innovation_covariance_that_is_not_positive_definite_is_refused() {
        let mut f = filter_at([0.0, 0.0], [0.0, 0.0]);
        let before = f.clone();
        // A measurement covariance cancelling the position's: S is zero.
        let r = -f.covariance().fixed_view::<2, 2>(0, 0).into_owned();
        assert_eq!(
            f.update([0.1, 0.1], &r, Learn::default()).err(),
            Some(FilterError::SingularInnovation)
        );
        assert_eq!(f, before, "the filter is left as it was");
        assert!(f.innovation([0.1, 0.1], &r).d2.is_infinite());
    }

    #[test]
    fn update_pulls_towards_the_measurement_by_covariance() {
        let mut f = filter_at([0.0, 0.0], [0.0, 0.0]);
        // Confident in y, doubtful in x: the update moves x more than y.
        let r = Matrix2::new(1e-2, 0.0, 0.0, 1e-6);
        f.p[(0, 0)] = 1e-3;
        f.p[(1, 1)] = 1e-3;
        assert!(f.update([0.1, 0.1], &r, Learn::default()).is_ok());
        assert!(f.x[0] > 0.0 && f.x[0] < 0.02, "{}", f.x[0]);
        assert!(f.x[1] > 0.09, "{}", f.x[1]);
        assert_eq!(f.x[DECEL], 0.3);
    }
}
