//! The public record of a run: ground truth, robot tracks, deliveries, events, parameters.

use crate::vec2::{lerp, lerp_angle};
use proto::{Observation, Pose2, Stamp, WallSide};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// How the ball is moving. A kicked ball first skids (sliding friction, large deceleration)
/// until it rolls without slipping; only then does the small rolling resistance apply.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum BallPhase {
    Rest,
    Slide,
    Roll,
}

/// The ball's true state at one instant (`t_s` seconds after the run's start).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TruthSample {
    pub t_s: f64,
    pub position_m: [f64; 2],
    pub velocity_mps: [f64; 2],
    pub phase: BallPhase,
}

/// The world's physical parameters for one run, drawn from the seed. An estimator that
/// calibrates online can be scored against these.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TrueParams {
    /// Constant part of the rolling deceleration.
    pub rolling_decel_mps2: f64,
    /// Mean wall restitution; each bounce draws its own value within ±0.1 of it.
    pub restitution_mean: f64,
    /// Deceleration while the ball skids (after kicks and bounces).
    pub slide_decel_mps2: f64,
    /// Quadratic drag while rolling: extra deceleration `drag_per_m · v²`.
    pub drag_per_m: f64,
}

/// Something that happened to the ball.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum BallEvent {
    /// The ball was given `velocity_mps`. `robot_id` is "script" for kicks no robot made;
    /// `kicker_distance_m` is the kicker's centre-to-ball-centre distance (0 for "script").
    Kick {
        t_s: f64,
        robot_id: String,
        velocity_mps: [f64; 2],
        kicker_distance_m: f64,
    },
    /// The ball hit a wall; `restitution` is the value drawn for this bounce.
    WallBounce {
        t_s: f64,
        position_m: [f64; 2],
        wall: WallSide,
        restitution: f64,
    },
    /// The ball was struck by (or pushed by) a robot's body.
    RobotContact { t_s: f64, robot_id: String },
    /// The ball came to rest.
    Stopped { t_s: f64, position_m: [f64; 2] },
}

impl BallEvent {
    pub fn t_s(&self) -> f64 {
        match self {
            BallEvent::Kick { t_s, .. }
            | BallEvent::WallBounce { t_s, .. }
            | BallEvent::RobotContact { t_s, .. }
            | BallEvent::Stopped { t_s, .. } => *t_s,
        }
    }
}

/// What an observation really was, known only to the world (the filter sees `obs` alone).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ObsKind {
    Ball,
    /// Another robot's white top mistaken for the ball.
    FalsePositive,
    /// A ball-like object at a fixed spot, reported by one robot.
    Phantom,
}

/// One observation and when it reaches the server (on the server's, i.e. true, clock).
#[derive(Debug, Clone, PartialEq)]
pub struct Delivery {
    pub arrival: Stamp,
    pub obs: Observation,
    pub kind: ObsKind,
}

/// One robot's true path, sampled at the truth rate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RobotTrack {
    pub id: String,
    pub observer: bool,
    pub poses: Vec<(f64, Pose2)>,
    /// Factor on the covariance this robot reports: 1 (honest), 0.25 or 4 (misreporting).
    pub cov_scale: f64,
    /// Offset of this robot's clock from true time (added to its capture stamps).
    pub clock_offset_s: f64,
    /// Capture instants (both cameras at once) this robot had, whether or not it saw anything.
    pub frames: u64,
    /// When its perception stalled (every image lost, a burst dropout): from and to,
    /// seconds. Absent in records from before they were kept.
    #[serde(default)]
    pub stalls: Vec<[f64; 2]>,
}

impl RobotTrack {
    /// Whether its perception stalled at any time in (`from_s`, `to_s`] (a stall holds
    /// from its start up to its end).
    pub fn stalled_within(&self, from_s: f64, to_s: f64) -> bool {
        self.stalls.iter().any(|[a, b]| *a <= to_s && *b > from_s)
    }

    /// The true pose at `t_s`, linearly interpolated (heading along the shorter arc), clamped
    /// to the recorded span.
    pub fn pose_at(&self, t_s: f64) -> Pose2 {
        let Some(&(t_first, first)) = self.poses.first() else {
            return Pose2::default();
        };
        if t_s <= t_first || self.poses.len() == 1 {
            return first;
        }
        let i = self.poses.partition_point(|(t, _)| *t <= t_s);
        if i >= self.poses.len() {
            return self.poses[self.poses.len() - 1].1;
        }
        let (t0, a) = self.poses[i - 1];
        let (t1, b) = self.poses[i];
        let f = if t1 > t0 { (t_s - t0) / (t1 - t0) } else { 0.0 };
        let p = lerp([a.x_m, a.y_m], [b.x_m, b.y_m], f);
        Pose2 {
            x_m: p[0],
            y_m: p[1],
            theta_rad: lerp_angle(a.theta_rad, b.theta_rad, f),
        }
    }
}

/// Counters of what the observers experienced, for tests and the evaluation's context.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SimStats {
    /// Camera images taken by observers (two per capture instant).
    pub camera_frames: u64,
    /// Camera images where the ball was within the field of view and range, before occlusion.
    pub ball_in_view: u64,
    /// ... of which another robot's body blocked the line of sight.
    pub occluded: u64,
    /// ... of which the line of sight grazed another robot (shifted, less confident detection).
    pub partially_occluded: u64,
    /// Camera images lost to random or burst dropouts.
    pub dropped: u64,
    pub ball_detections: u64,
    pub false_positives: u64,
    pub phantoms: u64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pose_interpolation_wraps_heading_and_clamps() {
        let track = RobotTrack {
            id: "miro1".into(),
            observer: true,
            poses: vec![
                (
                    0.0,
                    Pose2 {
                        x_m: 0.0,
                        y_m: 0.0,
                        theta_rad: 3.0,
                    },
                ),
                (
                    1.0,
                    Pose2 {
                        x_m: 1.0,
                        y_m: 2.0,
                        theta_rad: -3.0,
                    },
                ),
            ],
            cov_scale: 1.0,
            clock_offset_s: 0.0,
            frames: 0,
            stalls: vec![[0.2, 0.6]],
        };
        let p = track.pose_at(0.5);
        assert!((p.x_m - 0.5).abs() < 1e-12 && (p.y_m - 1.0).abs() < 1e-12);
        assert!(p.theta_rad.abs() > 3.1, "{}", p.theta_rad);
        assert_eq!(track.pose_at(-1.0).x_m, 0.0);
        assert_eq!(track.pose_at(5.0).y_m, 2.0);
        assert!(track.stalled_within(0.5, 0.7) && track.stalled_within(0.0, 0.3));
        assert!(!track.stalled_within(0.0, 0.15) && !track.stalled_within(0.6, 1.0));
    }
}
