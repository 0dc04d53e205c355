//! How far a robot's clock is from the server's, estimated from its observations: each
//! one's arrival (server clock) minus its capture stamp (robot clock) is the clock offset
//! plus the time the observation took to reach the server, which is never below some floor.
//! The smallest such lag of the recent observations, minus that floor, estimates the
//! offset: queueing and network delays only ever add to the lag, so the smallest one is the
//! least disturbed.

use std::collections::VecDeque;

/// Observations the estimate looks back over.
pub const OFFSET_WINDOW: usize = 64;

/// What the server assumes about the robots' clocks.
#[derive(Debug, Clone, PartialEq)]
pub struct ClockCheck {
    /// The least time from capture to arrival an observation can take (processing on the
    /// robot and the network): subtracted from the smallest lag.
    pub latency_floor_s: f64,
    /// An estimated offset larger than this (either way) marks the robot's clock as
    /// suspect: a lone robot's clock error becomes a position bias of speed × offset.
    pub warn_s: f64,
}

impl Default for ClockCheck {
    fn default() -> Self {
        ClockCheck {
            latency_floor_s: 0.0,
            warn_s: 0.1,
        }
    }
}

/// The recent arrival − capture lags of one robot.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OffsetWindow {
    lags_s: VecDeque<f64>,
}

impl OffsetWindow {
    pub fn push(&mut self, lag_s: f64) {
        if !lag_s.is_finite() {
            return;
        }
        if self.lags_s.len() == OFFSET_WINDOW {
            self.lags_s.pop_front();
        }
        self.lags_s.push_back(lag_s);
    }

    /// Server clock minus robot clock, seconds (positive: the robot's clock is behind).
    pub fn offset_s(&self, check: &ClockCheck) -> Option<f64> {
        let min = self.lags_s.iter().copied().reduce(f64::min)?;
        Some(min - check.latency_floor_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_smallest_recent_lag_less_the_floor() {
        let check = ClockCheck {
            latency_floor_s: 0.01,
            warn_s: 0.1,
        };
        let mut w = OffsetWindow::default();
        assert_eq!(w.offset_s(&check), None);
        // A clock 0.2 s behind, latencies 20..60 ms with one queueing spike.
        for k in 0..100 {
            let latency_s = 0.02 + 0.04 * f64::from(k % 5) / 4.0;
            w.push(0.2 + latency_s + if k == 50 { 1.0 } else { 0.0 });
        }
        w.push(f64::NAN);
        let offset = w.offset_s(&check).expect("an estimate");
        assert!((offset - 0.21).abs() < 1e-9, "{offset}");
        // Only the last OFFSET_WINDOW lags count: the clock fixed, the estimate follows.
        for _ in 0..OFFSET_WINDOW {
            w.push(0.03);
        }
        let offset = w.offset_s(&check).expect("an estimate");
        assert!((offset - 0.02).abs() < 1e-9, "{offset}");
    }
}
