//! The seed's method, as its dissertation describes it: a constant-velocity Kalman filter
//! stepped every 100 ms over whatever observations have arrived, velocity from an
//! exponentially weighted moving average of position differences, prediction
//! x_t = x_0 + t·v_0, no friction, no walls, no capture-time ordering.

use nalgebra::{Matrix2, Matrix4, Vector4};
use proto::{Observation, Stamp};
use std::collections::VecDeque;

const STEP_S: f64 = 0.1;
const EWMA_ALPHA: f64 = 0.3;
/// White-acceleration density of the constant-velocity model.
const Q_ACCEL: f64 = 0.5;

#[derive(Debug, Clone)]
pub struct SeedBaseline {
    x: Vector4<f64>,
    p: Matrix4<f64>,
    started: bool,
    /// Arrival-ordered observations not yet consumed by a 100 ms step.
    queue: VecDeque<(Stamp, Observation)>,
    next_step: Option<Stamp>,
    last_position: Option<[f64; 2]>,
    velocity: [f64; 2],
    /// Recent positions, for the seed's 3σ validation of candidates.
    recent: VecDeque<[f64; 2]>,
}

impl Default for SeedBaseline {
    fn default() -> Self {
        SeedBaseline {
            x: Vector4::zeros(),
            p: Matrix4::identity(),
            started: false,
            queue: VecDeque::new(),
            next_step: None,
            last_position: None,
            velocity: [0.0; 2],
            recent: VecDeque::new(),
        }
    }
}

impl SeedBaseline {
    pub fn ingest(&mut self, arrival: Stamp, obs: &Observation) {
        self.queue.push_back((arrival, obs.clone()));
        if self.next_step.is_none() {
            self.next_step = Some(arrival.offset_secs(STEP_S));
        }
    }

    /// Runs the 100 ms loop up to `at`; returns the position and EWMA velocity.
    pub fn query(&mut self, at: Stamp) -> Option<([f64; 2], [f64; 2])> {
        while let Some(step) = self.next_step.filter(|s| *s <= at) {
            self.step(step);
            self.next_step = Some(step.offset_secs(STEP_S));
        }
        self.last_position.map(|p| (p, self.velocity))
    }

    fn step(&mut self, now: Stamp) {
        let f = Matrix4::new(
            1.0, 0.0, STEP_S, 0.0, 0.0, 1.0, 0.0, STEP_S, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        );
        let (d3, d2) = (STEP_S.powi(3) / 3.0, STEP_S.powi(2) / 2.0);
        let q = Matrix4::new(
            d3, 0.0, d2, 0.0, 0.0, d3, 0.0, d2, d2, 0.0, STEP_S, 0.0, 0.0, d2, 0.0, STEP_S,
        ) * Q_ACCEL;
        if self.started {
            self.x = f * self.x;
            self.p = f * self.p * f.transpose() + q;
        }
        while self.queue.front().is_some_and(|(a, _)| *a <= now) {
            let Some((_, obs)) = self.queue.pop_front() else {
                break;
            };
            self.update(&obs);
        }
        if !self.started {
            return;
        }
        let pos = [self.x[0], self.x[1]];
        if let Some(prev) = self.last_position {
            for k in 0..2 {
                let d = (pos[k] - prev[k]) / STEP_S;
                self.velocity[k] = EWMA_ALPHA * d + (1.0 - EWMA_ALPHA) * self.velocity[k];
            }
        }
        self.last_position = Some(pos);
        self.recent.push_back(pos);
        if self.recent.len() > 10 {
            self.recent.pop_front();
        }
    }

    /// The seed's validation: reject candidates beyond 3σ of the recent positions and the
    /// next half second of linear predictions.
    fn plausible(&self, z: [f64; 2]) -> bool {
        if self.recent.len() < 3 {
            return true;
        }
        let last = self.recent.back().copied().unwrap_or(z);
        let mut pts: Vec<[f64; 2]> = self.recent.iter().copied().collect();
        for k in 1..=5 {
            let t = k as f64 * STEP_S;
            pts.push([
                last[0] + t * self.velocity[0],
                last[1] + t * self.velocity[1],
            ]);
        }
        let n = pts.len() as f64;
        let mean = [
            pts.iter().map(|p| p[0]).sum::<f64>() / n,
            pts.iter().map(|p| p[1]).sum::<f64>() / n,
        ];
        let var = pts
            .iter()
            .map(|p| (p[0] - mean[0]).powi(2) + (p[1] - mean[1]).powi(2))
            .sum::<f64>()
            / n;
        let sigma = var.sqrt().max(0.1);
        (z[0] - mean[0]).hypot(z[1] - mean[1]) <= 3.0 * sigma
    }

    fn update(&mut self, obs: &Observation) {
        let z = obs.position_m;
        if !self.started {
            self.x = Vector4::new(z[0], z[1], 0.0, 0.0);
            self.p = Matrix4::from_diagonal(&Vector4::new(0.01, 0.01, 1.0, 1.0));
            self.started = true;
            return;
        }
        if !self.plausible(z) {
            return;
        }
        let c = obs.covariance_m2;
        let r = Matrix2::new(c[0], c[1], c[2], c[3]);
        let s = self.p.fixed_view::<2, 2>(0, 0) + r;
        let Some(s_inv) = s.try_inverse() else { return };
        let k = self.p.fixed_view::<4, 2>(0, 0) * s_inv;
        let y = nalgebra::Vector2::new(z[0] - self.x[0], z[1] - self.x[1]);
        self.x += k * y;
        let mut i_kh = Matrix4::identity();
        let kh = k * nalgebra::Matrix2x4::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0);
        i_kh -= kh;
        self.p = i_kh * self.p;
        self.p = 0.5 * (self.p + self.p.transpose());
    }
}
