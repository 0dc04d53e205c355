//! The last few seconds of observations as the engine judged them, accepted or rejected
//! with the reason, for the coach's page: each robot's recent sightings with their
//! covariance ellipses, and the ones that were refused and why.

use proto::{Camera, Observation, Stamp};
use serde::Serialize;
use std::collections::VecDeque;

/// Observations kept, all robots together (a bound on memory whatever arrives).
pub const RECENT_OBS_MAX: usize = 1024;

/// One observation as the page draws it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RecentObs {
    pub robot_id: String,
    pub seq: u64,
    pub camera: Camera,
    /// Capture stamp.
    pub stamp: Stamp,
    /// When the server received it.
    pub received: Stamp,
    pub position_m: [f64; 2],
    /// Row-major 2×2, as reported (before the robot's trust scale).
    pub covariance_m2: [f64; 4],
    pub accepted: bool,
    /// Why it was refused (the reason label of the metrics), `null` when accepted.
    pub reason: Option<&'static str>,
}

/// A bounded ring of recent observations.
#[derive(Debug, Clone, Default)]
pub struct RecentObservations {
    ring: VecDeque<RecentObs>,
}

impl RecentObservations {
    /// Remembers `obs`, received at `received`; `reason` is `None` when it was accepted.
    pub fn push(&mut self, obs: &Observation, received: Stamp, reason: Option<&'static str>) {
        // A made-up id of any length must not fill memory: those are only counted.
        if !proto::is_valid_id(&obs.robot_id) {
            return;
        }
        if self.ring.len() >= RECENT_OBS_MAX {
            self.ring.pop_front();
        }
        self.ring.push_back(RecentObs {
            robot_id: obs.robot_id.clone(),
            seq: obs.seq,
            camera: obs.camera,
            stamp: obs.stamp,
            received,
            position_m: obs.position_m,
            covariance_m2: obs.covariance_m2,
            accepted: reason.is_none(),
            reason,
        });
    }

    /// Those received in the `window_s` seconds up to `now`, oldest first. (After a replay
    /// seeks back, later ones are left out too.)
    pub fn within(&self, now: Stamp, window_s: f64) -> Vec<RecentObs> {
        self.ring
            .iter()
            .filter(|o| {
                let age_s = now.secs_since(o.received);
                (0.0..=window_s).contains(&age_s)
            })
            .cloned()
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::test_support::observation;

    fn obs(seq: u64) -> Observation {
        observation("miro1", seq, Stamp(1_000_000_000 * seq), [0.1, 0.2])
    }

    #[test]
    fn keeps_a_bounded_window_with_reasons() {
        let mut r = RecentObservations::default();
        for k in 0..(RECENT_OBS_MAX as u64 + 10) {
            let reason = (k % 2 == 1).then_some("too_late");
            r.push(&obs(k), Stamp(1_000_000_000 * k), reason);
        }
        assert_eq!(r.ring.len(), RECENT_OBS_MAX);
        let now = Stamp(1_000_000_000 * (RECENT_OBS_MAX as u64 + 9));
        let last = r.within(now, 2.5);
        assert_eq!(last.len(), 3, "{last:?}");
        assert_eq!(last[2].reason, Some("too_late"));
        assert!(!last[2].accepted);
        assert!(last[1].accepted);
        // Nothing received after `now` is shown (a replay that went back).
        assert!(r.within(Stamp(0), 10.0).is_empty());
    }
}
