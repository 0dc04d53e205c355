//! The plainest reference a reader could write: a least-squares straight line through the
//! observations captured in the last [`WINDOW_S`], ordered by capture time. It holds no
//! old estimate (a ball seen somewhere new is followed as soon as the window turns over),
//! has no friction and no walls of its own.

use proto::{Observation, Stamp};
use std::collections::VecDeque;

/// Observations captured this long before the newest one are fitted.
pub const WINDOW_S: f64 = 0.25;
/// A sighting this far from the line's prediction starts a new line (a moved ball).
pub const RESTART_M: f64 = 0.5;

#[derive(Debug, Clone, Default)]
pub struct LineFit {
    /// (capture, position), capture-ordered.
    window: VecDeque<(Stamp, [f64; 2])>,
}

impl LineFit {
    pub fn ingest(&mut self, obs: &Observation) {
        let t = obs.stamp;
        if let Some((p, _)) = self.at(t)
            && (p[0] - obs.position_m[0]).hypot(p[1] - obs.position_m[1]) > RESTART_M
        {
            self.window.clear();
        }
        let k = self.window.partition_point(|(s, _)| *s <= t);
        self.window.insert(k, (t, obs.position_m));
        if let Some((newest, _)) = self.window.back().copied() {
            while self
                .window
                .front()
                .is_some_and(|(s, _)| newest.secs_since(*s) > WINDOW_S)
            {
                self.window.pop_front();
            }
        }
    }

    /// Position and velocity of the line at `at`; with one sighting, that point at rest.
    pub fn at(&self, at: Stamp) -> Option<([f64; 2], [f64; 2])> {
        let (t0, _) = *self.window.back()?;
        let n = self.window.len() as f64;
        let ts: Vec<f64> = self.window.iter().map(|(s, _)| s.secs_since(t0)).collect();
        let t_mean = ts.iter().sum::<f64>() / n;
        let stt: f64 = ts.iter().map(|t| (t - t_mean).powi(2)).sum();
        let mut pos = [0.0; 2];
        let mut vel = [0.0; 2];
        for k in 0..2 {
            let mean = self.window.iter().map(|(_, p)| p[k]).sum::<f64>() / n;
            let stp: f64 = ts
                .iter()
                .zip(&self.window)
                .map(|(t, (_, p))| (t - t_mean) * (p[k] - mean))
                .sum();
            let slope = if stt > 1e-9 { stp / stt } else { 0.0 };
            vel[k] = slope;
            pos[k] = mean + slope * (at.secs_since(t0) - t_mean);
        }
        Some((pos, vel))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::test_support::observation;

    fn obs(t_s: f64, p: [f64; 2]) -> Observation {
        observation("r1", 0, Stamp::from_secs_f64(100.0 + t_s), p)
    }

    #[test]
    fn a_straight_roll_is_fitted_and_a_moved_ball_restarts_the_line() {
        let mut f = LineFit::default();
        for k in 0..10 {
            let t = k as f64 * 0.05;
            f.ingest(&obs(t, [1.0 + 2.0 * t, 0.5]));
        }
        let (p, v) = f.at(Stamp::from_secs_f64(100.5)).expect("a line");
        assert!((v[0] - 2.0).abs() < 1e-6 && v[1].abs() < 1e-6, "{v:?}");
        assert!((p[0] - 2.0).abs() < 1e-6, "{p:?}");
        f.ingest(&obs(0.5, [-3.0, -2.0]));
        let (p, v) = f.at(Stamp::from_secs_f64(100.6)).expect("a line");
        assert_eq!((p, v), ([-3.0, -2.0], [0.0, 0.0]));
    }
}
