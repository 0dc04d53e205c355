//! The ball's recent past for a page that has just opened: its position, speed and 2σ
//! ellipse a few times a second over the last half minute of match time, kept from the
//! states the server publishes (`GET /api/history`). Time passed in; a clock that jumps
//! back (a replay moved) or far forward starts the history over.

use proto::{BallState, Stamp};
use serde::Serialize;
use std::collections::VecDeque;

/// Match time the history covers, seconds.
pub const HISTORY_WINDOW_S: f64 = 30.0;
/// Least time between two samples, seconds.
pub const HISTORY_STEP_S: f64 = 0.1;
/// A gap in the clock longer than this starts the history over, seconds.
const JUMP_S: f64 = 5.0;

/// One sample of the ball.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BallSample {
    pub stamp: Stamp,
    pub position_m: [f64; 2],
    pub velocity_mps: [f64; 2],
    /// The position's 2σ ellipse's long half-axis (2σ along its worst direction), metres.
    pub ellipse_2sigma_m: f64,
}

/// The samples of the last [`HISTORY_WINDOW_S`], oldest first.
#[derive(Debug, Clone, Default)]
pub struct BallHistory {
    samples: VecDeque<BallSample>,
    last_seen: Option<Stamp>,
}

/// The long half-axis of the 2σ ellipse of a 4×4 state covariance's position.
fn ellipse_2sigma_m(c: &[f64; 16]) -> f64 {
    let (a, b, d) = (c[0], c[1], c[5]);
    let mid = (a + d) / 2.0;
    let half = ((a - d) / 2.0).hypot(b);
    2.0 * (mid + half).max(0.0).sqrt()
}

impl BallHistory {
    /// The state published at `at` (none when the ball is unknown).
    pub fn push(&mut self, at: Stamp, state: Option<&BallState>) {
        if let Some(last) = self.last_seen
            && (at < last || at.secs_since(last) > JUMP_S)
        {
            self.samples.clear();
        }
        self.last_seen = Some(at);
        while self
            .samples
            .front()
            .is_some_and(|s| at.secs_since(s.stamp) > HISTORY_WINDOW_S)
        {
            self.samples.pop_front();
        }
        let Some(b) = state else { return };
        if self
            .samples
            .back()
            .is_some_and(|s| b.stamp.secs_since(s.stamp) < HISTORY_STEP_S - 1e-3)
        {
            return;
        }
        self.samples.push_back(BallSample {
            stamp: b.stamp,
            position_m: b.position_m,
            velocity_mps: b.velocity_mps,
            ellipse_2sigma_m: ellipse_2sigma_m(&b.covariance),
        });
    }

    /// The samples, oldest first.
    pub fn samples(&self) -> Vec<BallSample> {
        self.samples.iter().copied().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(at: Stamp, x: f64, var: f64) -> BallState {
        let mut c = [0.0; 16];
        c[0] = var;
        c[5] = var / 4.0;
        c[10] = 1.0;
        c[15] = 1.0;
        BallState {
            version: proto::VERSION,
            stamp: at,
            position_m: [x, 0.0],
            velocity_mps: [1.0, 0.0],
            covariance: c,
            status: proto::BallStatus::Tracking,
            last_seen: Some(at),
            contributors: vec![],
            existence: 1.0,
            model: proto::ModelParams {
                rolling_decel_mps2: 0.3,
                wall_restitution: 0.5,
                decel_samples: 0,
                restitution_samples: 0,
                tangential_retention: 0.85,
                slide_decel_mps2: 3.0,
                bounces_seen: 0,
                kicks_inferred: 0,
            },
            prediction: proto::Prediction {
                version: proto::VERSION,
                stamp: at,
                horizon_s: 0.0,
                samples: vec![],
                bounces: vec![],
                stop: None,
            },
        }
    }

    const T0: Stamp = Stamp(1_700_000_000_000_000_000);

    #[test]
    fn ten_samples_a_second_over_the_last_half_minute() {
        let mut h = BallHistory::default();
        // 40 s of states at 30 Hz.
        for k in 0..1200 {
            let at = T0.offset_secs(f64::from(k) / 30.0);
            h.push(at, Some(&state(at, f64::from(k) / 1200.0, 0.01)));
        }
        let s = h.samples();
        let span = s[s.len() - 1].stamp.secs_since(s[0].stamp);
        assert!((29.5..=30.0).contains(&span), "{span}");
        assert!((290..=301).contains(&s.len()), "{}", s.len());
        // A variance of 0.01 m² along x: 2σ = 0.2 m.
        assert!((s[0].ellipse_2sigma_m - 0.2).abs() < 1e-9);
    }

    #[test]
    fn a_clock_that_jumps_starts_over_and_an_unknown_ball_adds_nothing() {
        let mut h = BallHistory::default();
        for k in 0..20 {
            let at = T0.offset_secs(f64::from(k) * 0.1);
            h.push(at, Some(&state(at, 0.0, 0.01)));
        }
        h.push(T0.offset_secs(2.5), None);
        assert_eq!(h.samples().len(), 20);
        // A replay sought back.
        h.push(
            T0.offset_secs(1.0),
            Some(&state(T0.offset_secs(1.0), 0.0, 0.01)),
        );
        assert_eq!(h.samples().len(), 1);
        // And far forward.
        let later = T0.offset_secs(60.0);
        h.push(later, Some(&state(later, 0.0, 0.01)));
        assert_eq!(h.samples().len(), 1);
        assert_eq!(h.samples()[0].stamp, later);
    }
}
