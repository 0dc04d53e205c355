//! Message types carried over Zenoh, HTTP and MCAP.

use crate::{Stamp, WallSide};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Which of a MiRo's two cameras took the image.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Camera {
    Left,
    Right,
}

/// A robot's pose on the field: position and heading (rad, counter-clockwise from +x).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Pose2 {
    pub x_m: f64,
    pub y_m: f64,
    pub theta_rad: f64,
}

/// Where the ball was found in the image (optional: simulated observers have no image).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PixelBall {
    pub u_px: f64,
    pub v_px: f64,
    pub radius_px: f64,
}

/// One ball sighting by one camera of one robot, projected onto the floor.
/// Published on `{prefix}/robots/{robot_id}/obs`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Observation {
    pub version: u32,
    pub robot_id: String,
    /// Per-robot sequence number, increasing by one per published observation.
    pub seq: u64,
    pub camera: Camera,
    /// Capture time of the image.
    pub stamp: Stamp,
    /// Ball centre on the floor, field frame.
    pub position_m: [f64; 2],
    /// 2×2 covariance of `position_m`, row-major, symmetric positive definite.
    pub covariance_m2: [f64; 4],
    /// Detector confidence that this is the ball, 0..1.
    pub confidence: f64,
    /// The observing robot's pose at capture time.
    pub robot_pose: Pose2,
    pub pixel: Option<PixelBall>,
}

/// Head joint angles of a MiRo.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HeadJoints {
    pub lift_rad: f64,
    pub yaw_rad: f64,
    pub pitch_rad: f64,
}

/// Time spent in one stage of the robot's perception pipeline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StageTiming {
    pub stage: String,
    pub ms: f64,
}

/// The floor area one camera can see, as a polygon in the field frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CameraFootprint {
    pub camera: Camera,
    pub polygon_m: Vec<[f64; 2]>,
}

impl CameraFootprint {
    /// Whether the floor point `p` lies inside the footprint ([`polygon_contains`]).
    pub fn contains(&self, p: [f64; 2]) -> bool {
        polygon_contains(&self.polygon_m, p)
    }
}

/// Whether `p` lies inside the polygon of `corners`, by the even–odd rule (so that a
/// folded outline is still answered); never for fewer than three corners.
pub fn polygon_contains(corners: &[[f64; 2]], p: [f64; 2]) -> bool {
    if corners.len() < 3 {
        return false;
    }
    let mut inside = false;
    let mut j = corners.len() - 1;
    for (i, a) in corners.iter().enumerate() {
        let c = corners[j];
        if (a[1] > p[1]) != (c[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (c[1] - a[1]) * (c[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}

/// A robot's periodic status. Published on `{prefix}/robots/{robot_id}/status`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RobotStatus {
    pub version: u32,
    pub robot_id: String,
    pub stamp: Stamp,
    pub pose: Pose2,
    /// 3×3 covariance of (x, y, θ), row-major.
    pub pose_covariance: [f64; 9],
    pub head: HeadJoints,
    /// Frames per second processed by the perception loop.
    pub fps: f64,
    pub timings: Vec<StageTiming>,
    pub footprints: Vec<CameraFootprint>,
    /// Each camera's perception counters. Absent in statuses from before they existed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub cameras: Vec<crate::CameraPerception>,
}

/// The fused ball's motion state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum BallStatus {
    /// Seen recently and moving.
    Tracking,
    /// Not seen for a while; the estimate is a prediction.
    Coasting,
    /// Seen recently and at rest.
    Stopped,
    /// No usable estimate.
    Lost,
}

/// The motion-model parameters in use, estimated online from the data.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ModelParams {
    /// Constant rolling deceleration opposite to the velocity.
    pub rolling_decel_mps2: f64,
    /// Wall coefficient of restitution (normal speed out / in).
    pub wall_restitution: f64,
    /// Number of observations that informed the deceleration estimate.
    pub decel_samples: u32,
    /// Number of bounces that informed the restitution estimate.
    pub restitution_samples: u32,
    /// Wall tangential retention (tangential speed out / in), learned from the same
    /// bounces. Absent in states from before it was learned (read as 0.85).
    #[serde(default = "default_tangential_retention")]
    pub tangential_retention: f64,
    /// Deceleration while the ball slides just after a kick (the two-phase model), learned
    /// from kicks. Absent in states from before it existed (read as 3.0).
    #[serde(default = "default_slide_decel")]
    pub slide_decel_mps2: f64,
    /// Wall bounces the estimate went through since the server started: foreseen by its
    /// flight, or found at a wall where surprising sightings would otherwise have been a
    /// kick. Absent in states from before it was counted (read as 0).
    #[serde(default)]
    pub bounces_seen: u32,
    /// Kicks nobody reported that the server inferred from the estimate's sightings since
    /// it started. Absent in states from before it was counted (read as 0).
    #[serde(default)]
    pub kicks_inferred: u32,
}

fn default_tangential_retention() -> f64 {
    0.85
}

fn default_slide_decel() -> f64 {
    3.0
}

/// A point on the predicted path.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PathSample {
    /// Seconds after the prediction's stamp.
    pub t_s: f64,
    pub position_m: [f64; 2],
    pub velocity_mps: [f64; 2],
    /// 2×2 covariance of the predicted position, row-major, m²: the estimate's own
    /// uncertainty and that of the learned motion parameters flown through the motion
    /// model (bounces included), plus the process noise of the flight. Absent from
    /// servers that do not predict it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub covariance_m2: Option<[f64; 4]>,
}

/// A predicted wall bounce.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BounceEvent {
    /// Seconds after the prediction's stamp.
    pub t_s: f64,
    pub position_m: [f64; 2],
    pub wall: WallSide,
}

/// Where and when the ball is predicted to come to rest.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StopPoint {
    /// Seconds after the prediction's stamp.
    pub t_s: f64,
    pub position_m: [f64; 2],
    /// 2×2 covariance of the stop point, row-major, m² (as a sample's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub covariance_m2: Option<[f64; 4]>,
}

/// The ball's predicted path from `stamp` on, through wall bounces, to its stop.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Prediction {
    pub version: u32,
    pub stamp: Stamp,
    pub horizon_s: f64,
    pub samples: Vec<PathSample>,
    pub bounces: Vec<BounceEvent>,
    pub stop: Option<StopPoint>,
}

/// The shared ball estimate. Published on `{prefix}/ball/state`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BallState {
    pub version: u32,
    /// Time the estimate refers to.
    pub stamp: Stamp,
    pub position_m: [f64; 2],
    pub velocity_mps: [f64; 2],
    /// 4×4 covariance of (x, y, vx, vy), row-major.
    pub covariance: [f64; 16],
    pub status: BallStatus,
    /// Capture time of the newest observation that updated the estimate.
    pub last_seen: Option<Stamp>,
    /// Robots whose observations updated the estimate recently.
    pub contributors: Vec<String>,
    /// Probability, 0 to 1, that the ball is where the estimate says: near 1 while it is
    /// seen, falling while robots' cameras look at its place and do not see it. Absent in
    /// states from before it existed (read as 1).
    #[serde(default = "certain")]
    pub existence: f64,
    pub model: ModelParams,
    pub prediction: Prediction,
}

fn certain() -> f64 {
    1.0
}

/// The earliest point on the predicted path a robot can reach.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Intercept {
    pub version: u32,
    pub robot_id: String,
    pub stamp: Stamp,
    /// False when the robot cannot reach the ball before it stops (then `t_s` and
    /// `point_m` are where it can meet the ball at rest).
    pub reachable_in_motion: bool,
    /// Seconds after `stamp`.
    pub t_s: f64,
    pub point_m: [f64; 2],
    /// How likely, 0 to 1, the ball is within the robot's reach at `point_m` and `t_s`, given
    /// how sure the predicted path is there. Absent from servers that do not say.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub probability: Option<f64>,
}

#[cfg(test)]
mod polygon_tests {
    use super::*;

    #[test]
    fn a_point_is_inside_a_polygon_by_the_even_odd_rule() {
        let square = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        assert!(polygon_contains(&square, [1.0, 1.0]));
        assert!(!polygon_contains(&square, [2.5, 1.0]));
        assert!(!polygon_contains(&square, [1.0, -0.1]));
        // A wedge, as a camera's footprint is.
        let wedge = CameraFootprint {
            camera: Camera::Left,
            polygon_m: vec![[0.0, 0.0], [3.0, -1.0], [3.0, 1.0]],
        };
        assert!(wedge.contains([2.0, 0.0]));
        assert!(!wedge.contains([0.5, 0.5]));
        assert!(!polygon_contains(&square[..2], [1.0, 0.0]), "no area");
    }
}
