//! Valid messages the targets start from, and the finiteness checks on what the fusion
//! core publishes.

use fusion_server::{BallQuery, QueryReply};
use fusion_server::{Engine, EngineConfig};
use proto::{
    BallState, Camera, CameraFootprint, HeadJoints, Observation, PixelBall, Pose2, Prediction,
    RobotStatus, StageTiming, Stamp,
};

/// The receiver's clock at the first input; seeds are captured around it.
pub const BASE: Stamp = Stamp(1_800_000_000_000_000_000);

/// A valid observation of robot `robot_id` seeing the ball at `position_m`, captured
/// `dt_s` after [`BASE`].
pub fn observation(robot_id: &str, seq: u64, dt_s: f64, position_m: [f64; 2]) -> Observation {
    Observation {
        version: proto::VERSION,
        robot_id: robot_id.to_owned(),
        seq,
        camera: if seq.is_multiple_of(2) {
            Camera::Left
        } else {
            Camera::Right
        },
        stamp: BASE.offset_secs(dt_s),
        position_m,
        covariance_m2: [4e-4, 1e-5, 1e-5, 4e-4],
        confidence: 0.9,
        robot_pose: Pose2 {
            x_m: -1.0,
            y_m: 0.5,
            theta_rad: 0.3,
        },
        pixel: seq.is_multiple_of(3).then_some(PixelBall {
            u_px: 320.5,
            v_px: 240.25,
            radius_px: 12.0,
        }),
    }
}

/// Observations of a ball rolling along x by three robots, 30 ms apart.
pub fn rolling_ball(n: usize) -> Vec<Observation> {
    (0..n)
        .map(|i| {
            let t_s = i as f64 * 0.03;
            let robot = ["miro1", "miro2", "miro3"][i % 3];
            observation(robot, i as u64, t_s, [-1.0 + 0.8 * t_s, 0.2 - 0.1 * t_s])
        })
        .collect()
}

/// A valid status of robot `robot_id` at [`BASE`].
pub fn status(robot_id: &str) -> RobotStatus {
    let mut pose_covariance = [0.0; 9];
    pose_covariance[0] = 1e-3;
    pose_covariance[4] = 1e-3;
    pose_covariance[8] = 1e-2;
    RobotStatus {
        version: proto::VERSION,
        robot_id: robot_id.to_owned(),
        stamp: BASE,
        pose: Pose2 {
            x_m: 0.5,
            y_m: -0.25,
            theta_rad: 1.0,
        },
        pose_covariance,
        head: HeadJoints {
            lift_rad: 0.5,
            yaw_rad: -0.1,
            pitch_rad: 0.05,
        },
        fps: 14.5,
        timings: vec![StageTiming {
            stage: "detect".to_owned(),
            ms: 12.5,
        }],
        footprints: vec![CameraFootprint {
            camera: Camera::Left,
            polygon_m: vec![[0.6, 0.0], [1.5, -0.6], [1.5, 0.6]],
        }],
        cameras: Vec::new(),
    }
}

/// An engine that has fused [`rolling_ball`] (received 20 ms after capture) and the
/// statuses of its robots.
pub fn engine_with_estimate() -> Engine {
    let mut engine = Engine::new(EngineConfig::default());
    for robot in ["miro1", "miro2", "miro3"] {
        let payload = proto::encode(&status(robot));
        engine.status(Some(robot), &payload, BASE).ok();
    }
    for obs in rolling_ball(30) {
        let received = obs.stamp.offset_secs(0.02);
        let payload = proto::encode(&obs);
        engine
            .observation(Some(&obs.robot_id), &payload, received)
            .ok();
    }
    engine
}

/// The engine's state, prediction and an intercept, encoded: seeds for their decoders.
pub fn fusion_outputs() -> Vec<(&'static str, Vec<u8>)> {
    let engine = engine_with_estimate();
    let at = BASE.offset_secs(1.0);
    let mut out = Vec::new();
    if let Some(state) = engine.ball_state(at) {
        out.push(("BallState", proto::encode(&state)));
        out.push(("Prediction", proto::encode(&state.prediction)));
    }
    let q = BallQuery::Intercept {
        robot_id: "miro1".to_owned(),
        speed_mps: Some(0.3),
    };
    if let Ok(QueryReply::Intercept(i)) = engine.query(&q, at) {
        out.push(("Intercept", proto::encode(&i)));
    }
    out
}

/// Asserts every number of a published state is finite.
pub fn assert_finite_state(state: &BallState) {
    let numbers = state
        .position_m
        .iter()
        .chain(&state.velocity_mps)
        .chain(&state.covariance)
        .chain([
            &state.model.rolling_decel_mps2,
            &state.model.wall_restitution,
        ]);
    for v in numbers {
        assert!(v.is_finite(), "non-finite ball state: {state:?}");
    }
    assert_finite_prediction(&state.prediction);
}

/// Asserts every number of a prediction is finite.
pub fn assert_finite_prediction(p: &Prediction) {
    let samples = p.samples.iter().flat_map(|s| {
        [
            s.t_s,
            s.position_m[0],
            s.position_m[1],
            s.velocity_mps[0],
            s.velocity_mps[1],
        ]
    });
    let bounces = p
        .bounces
        .iter()
        .flat_map(|b| [b.t_s, b.position_m[0], b.position_m[1]]);
    let stop = p
        .stop
        .iter()
        .flat_map(|s| [s.t_s, s.position_m[0], s.position_m[1]]);
    for v in samples.chain(bounces).chain(stop).chain([p.horizon_s]) {
        assert!(v.is_finite(), "non-finite prediction: {p:?}");
    }
}
