//! A finished run: everything the evaluation needs, with time helpers.

use crate::types::{BallEvent, Delivery, RobotTrack, SimStats, TrueParams, TruthSample};
use crate::vec2::lerp;
use crate::{SimConfig, SimError, World};
use proto::{Pitch, Stamp};

/// The complete record of one scenario run.
#[derive(Debug, Clone, PartialEq)]
pub struct SimRun {
    pub scenario: String,
    pub seed: u64,
    /// Epoch of t = 0.
    pub start: Stamp,
    pub duration_s: f64,
    pub pitch: Pitch,
    /// The ball every 1/truth_rate_hz from 0 to `duration_s`.
    pub truth: Vec<TruthSample>,
    /// Every robot, observer or not.
    pub robots: Vec<RobotTrack>,
    /// Every observation, sorted by arrival (ties: capture stamp, then robot id).
    pub deliveries: Vec<Delivery>,
    /// Sorted by time.
    pub events: Vec<BallEvent>,
    pub params: TrueParams,
    pub stats: SimStats,
    /// The robot that reported a phantom ball and where the phantom was (scenario `phantom`).
    pub phantom: Option<(String, [f64; 2])>,
}

/// Runs a named scenario to its end.
pub fn run_scenario(name: &str, seed: u64, cfg: &SimConfig) -> Result<SimRun, SimError> {
    let mut world = World::new(name, seed, cfg)?;
    let deliveries = world.advance_to(world.duration_s());
    Ok(world.into_run(deliveries))
}

impl SimRun {
    /// The true ball at `t_s`, linearly interpolated between samples and clamped to the run.
    /// The phase is the nearer sample's; a resting ball has exactly zero velocity.
    pub fn truth_at(&self, t_s: f64) -> TruthSample {
        let Some(first) = self.truth.first().copied() else {
            return TruthSample {
                t_s,
                position_m: [0.0, 0.0],
                velocity_mps: [0.0, 0.0],
                phase: crate::BallPhase::Rest,
            };
        };
        if t_s <= first.t_s {
            return TruthSample { t_s, ..first };
        }
        let i = self.truth.partition_point(|s| s.t_s <= t_s);
        if i >= self.truth.len() {
            let last = self.truth[self.truth.len() - 1];
            return TruthSample { t_s, ..last };
        }
        let (a, b) = (self.truth[i - 1], self.truth[i]);
        let f = if b.t_s > a.t_s {
            (t_s - a.t_s) / (b.t_s - a.t_s)
        } else {
            0.0
        };
        let phase = if f < 0.5 { a.phase } else { b.phase };
        TruthSample {
            t_s,
            position_m: lerp(a.position_m, b.position_m, f),
            velocity_mps: if phase == crate::BallPhase::Rest {
                [0.0, 0.0]
            } else {
                lerp(a.velocity_mps, b.velocity_mps, f)
            },
            phase,
        }
    }

    /// Seconds since the run's start (true time; an observation's stamp also carries its
    /// robot's clock offset).
    pub fn t_of(&self, stamp: Stamp) -> f64 {
        stamp.secs_since(self.start)
    }

    pub fn stamp_of(&self, t_s: f64) -> Stamp {
        self.start.offset_secs(t_s)
    }

    /// Ids of the robots that report observations.
    pub fn observer_ids(&self) -> Vec<String> {
        self.robots
            .iter()
            .filter(|r| r.observer)
            .map(|r| r.id.clone())
            .collect()
    }

    /// The robot track with this id.
    pub fn robot(&self, id: &str) -> Option<&RobotTrack> {
        self.robots.iter().find(|r| r.id == id)
    }

    /// Wall bounces, in order.
    pub fn bounce_count(&self) -> usize {
        self.events
            .iter()
            .filter(|e| matches!(e, BallEvent::WallBounce { .. }))
            .count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BallPhase;

    #[test]
    fn truth_interpolates_and_clamps_and_stamps_round_trip() {
        let run =
            run_scenario("seed-2-away", 4, &SimConfig::default()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(run.truth.len(), 601);
        assert!((run.truth[600].t_s - 6.0).abs() < 1e-9);
        let a = run.truth[100];
        let b = run.truth[101];
        let mid = run.truth_at(0.5 * (a.t_s + b.t_s));
        assert!((mid.position_m[0] - 0.5 * (a.position_m[0] + b.position_m[0])).abs() < 1e-12);
        assert_eq!(run.truth_at(-1.0).position_m, run.truth[0].position_m);
        assert_eq!(run.truth_at(99.0).position_m, run.truth[600].position_m);
        assert_eq!(run.truth_at(0.0).phase, BallPhase::Rest);
        let t = 2.345;
        assert!((run.t_of(run.stamp_of(t)) - t).abs() < 1e-9);
        assert_eq!(run.observer_ids(), vec!["miro1".to_string()]);
        assert!(run.robot("miro1").is_some());
    }
}
