//! One sound example of every message, as a receiver at [`NOW`] on the default pitch would
//! accept it. The same values appear in `docs/protocol.md`.

use proto::{
    BallState, BallStatus, BounceEvent, Camera, CameraFootprint, CameraPerception, CameraView,
    CandidateOutcome, CandidateStage, HeadJoints, Intercept, ModelParams, Observation, PathSample,
    Pitch, PixelBall, Pose2, Prediction, RobotStatus, StageTiming, Stamp, StopPoint, VERSION,
    ValidationContext, ValidationError, ViewCandidate, WallSide,
};

/// The receiver's clock in the examples: 2023-11-14T22:13:20Z.
pub const NOW: Stamp = Stamp(1_700_000_000_000_000_000);

/// The receiver's context: default pitch and tolerances, clock at [`NOW`].
pub fn ctx() -> ValidationContext {
    ValidationContext::new(Pitch::default(), NOW)
}

pub fn observation() -> Observation {
    Observation {
        version: VERSION,
        robot_id: "miro1".to_string(),
        seq: 1842,
        camera: Camera::Left,
        stamp: NOW.offset_secs(-0.035),
        position_m: [0.85, -0.32],
        covariance_m2: [0.0025, 0.0004, 0.0004, 0.0016],
        confidence: 0.93,
        robot_pose: Pose2 {
            x_m: -0.6,
            y_m: -0.4,
            theta_rad: 0.35,
        },
        pixel: Some(PixelBall {
            u_px: 412.5,
            v_px: 301.0,
            radius_px: 18.2,
        }),
    }
}

pub fn robot_status() -> RobotStatus {
    RobotStatus {
        version: VERSION,
        robot_id: "miro1".to_string(),
        stamp: NOW.offset_secs(-0.02),
        pose: Pose2 {
            x_m: -0.6,
            y_m: -0.4,
            theta_rad: 0.35,
        },
        pose_covariance: [
            0.0004, 0.0001, 0.0, //
            0.0001, 0.0004, 0.0, //
            0.0, 0.0, 0.0025,
        ],
        head: HeadJoints {
            lift_rad: 0.6,
            yaw_rad: -0.1,
            pitch_rad: 0.2,
        },
        fps: 14.8,
        timings: vec![
            StageTiming {
                stage: "capture".to_string(),
                ms: 3.1,
            },
            StageTiming {
                stage: "detect".to_string(),
                ms: 21.4,
            },
            StageTiming {
                stage: "project".to_string(),
                ms: 0.2,
            },
        ],
        footprints: vec![
            CameraFootprint {
                camera: Camera::Left,
                polygon_m: vec![[-0.35, -0.2], [0.4, 0.05], [0.2, 0.6], [-0.4, 0.0]],
            },
            CameraFootprint {
                camera: Camera::Right,
                polygon_m: vec![[-0.3, -0.35], [0.55, -0.6], [0.6, 0.0], [-0.25, -0.15]],
            },
        ],
        cameras: vec![CameraPerception {
            camera: Camera::Left,
            frames: 5321,
            candidates: 9870,
            balls: 3012,
            rejections: [
                ("low_probability".to_string(), 6410),
                ("off_pitch".to_string(), 448),
            ]
            .into_iter()
            .collect(),
            frames_per_s: 14.8,
            candidates_per_frame: 1.9,
            balls_per_s: 8.7,
            detector_ms: 21.4,
        }],
    }
}

/// A 16×9 JPEG: green with a yellow square (`proto::test_support::TINY_JPEG_BASE64`).
pub const TINY_JPEG_BASE64: &str = "/9j/4AAQSkZJRgABAQAAAQABAAD/2wBDABALDA4MChAODQ4SERATGCgaGBYWGDEjJR0oOjM9PDkzODdASFxOQERXRTc4UG1RV19iZ2hnPk1xeXBkeFxlZ2P/2wBDARESEhgVGC8aGi9jQjhCY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2P/wAARCAAJABADASIAAhEBAxEB/8QAFgABAQEAAAAAAAAAAAAAAAAAAAME/8QAHBAAAgICAwAAAAAAAAAAAAAAAgMBEQAEEiFh/8QAFAEBAAAAAAAAAAAAAAAAAAAABP/EABcRAQADAAAAAAAAAAAAAAAAABEAARL/2gAMAwEAAhEDEQA/AMOmtTdoAefBc3ZXEV17jcWpW0YIPmuKorib68yGMAXpYFrIT//Z";

pub fn camera_view() -> CameraView {
    CameraView {
        version: VERSION,
        robot_id: "miro1".to_string(),
        seq: 57,
        camera: Camera::Left,
        stamp: NOW.offset_secs(-0.05),
        width_px: 16,
        height_px: 9,
        source_width_px: 640,
        source_height_px: 360,
        detector_ms: 6.3,
        candidates: vec![
            ViewCandidate {
                u_px: 8.0,
                v_px: 5.0,
                radius_px: 2.0,
                score: 0.94,
                stage: CandidateStage::Network,
                outcome: CandidateOutcome::Ball,
                reason: None,
            },
            ViewCandidate {
                u_px: 2.5,
                v_px: 1.0,
                radius_px: 1.0,
                score: 0.21,
                stage: CandidateStage::Appearance,
                outcome: CandidateOutcome::Rejected,
                reason: Some("low_probability".to_string()),
            },
        ],
        jpeg_base64: TINY_JPEG_BASE64.to_string(),
    }
}

pub fn prediction() -> Prediction {
    Prediction {
        version: VERSION,
        stamp: NOW,
        horizon_s: 2.0,
        samples: vec![
            PathSample {
                t_s: 0.0,
                position_m: [1.2, 0.4],
                velocity_mps: [1.1, 0.3],
                covariance_m2: Some([0.0004, 0.0001, 0.0001, 0.0003]),
            },
            PathSample {
                t_s: 1.0,
                position_m: [1.83, 0.64],
                velocity_mps: [-0.35, 0.2],
                covariance_m2: Some([0.004, 0.001, 0.001, 0.002]),
            },
            PathSample {
                t_s: 2.0,
                position_m: [1.62, 0.76],
                velocity_mps: [-0.08, 0.04],
                covariance_m2: Some([0.012, 0.002, 0.002, 0.006]),
            },
        ],
        bounces: vec![BounceEvent {
            t_s: 0.62,
            position_m: [1.91, 0.58],
            wall: WallSide::XMax,
        }],
        stop: Some(StopPoint {
            t_s: 2.4,
            position_m: [1.6, 0.77],
            covariance_m2: Some([0.015, 0.002, 0.002, 0.007]),
        }),
    }
}

pub fn ball_state() -> BallState {
    BallState {
        version: VERSION,
        stamp: NOW,
        position_m: [1.2, 0.4],
        velocity_mps: [1.1, 0.3],
        covariance: [
            0.0009, 0.0001, 0.0005, 0.0, //
            0.0001, 0.0009, 0.0, 0.0005, //
            0.0005, 0.0, 0.01, 0.001, //
            0.0, 0.0005, 0.001, 0.01,
        ],
        status: BallStatus::Tracking,
        last_seen: Some(NOW.offset_secs(-0.035)),
        contributors: vec!["miro1".to_string(), "miro3".to_string()],
        existence: 0.97,
        model: ModelParams {
            rolling_decel_mps2: 0.45,
            wall_restitution: 0.55,
            tangential_retention: 0.9,
            slide_decel_mps2: 2.8,
            bounces_seen: 9,
            kicks_inferred: 2,
            decel_samples: 12,
            restitution_samples: 4,
        },
        prediction: prediction(),
    }
}

pub fn intercept() -> Intercept {
    Intercept {
        version: VERSION,
        robot_id: "miro2".to_string(),
        stamp: NOW,
        reachable_in_motion: true,
        t_s: 1.35,
        point_m: [1.78, 0.69],
        probability: Some(0.82),
    }
}

pub fn pitch() -> Pitch {
    Pitch::default()
}

/// Every message's example as pretty JSON (fields in declaration order), named and ordered
/// like `proto::schema::all()`.
pub fn all_pretty() -> Vec<(&'static str, String)> {
    fn pretty<T: serde::Serialize>(msg: &T) -> String {
        serde_json::to_string_pretty(msg).expect("examples serialise")
    }
    vec![
        ("Observation", pretty(&observation())),
        ("RobotStatus", pretty(&robot_status())),
        ("BallState", pretty(&ball_state())),
        ("Prediction", pretty(&prediction())),
        ("Intercept", pretty(&intercept())),
        ("CameraView", pretty(&camera_view())),
        ("Pitch", pretty(&pitch())),
    ]
}

/// Every message's example as a JSON value, named and ordered like `proto::schema::all()`.
pub fn all_json() -> Vec<(&'static str, serde_json::Value)> {
    all_pretty()
        .into_iter()
        .map(|(name, text)| (name, serde_json::from_str(&text).expect("valid JSON")))
        .collect()
}

/// One value of every `ValidationError` variant. The `match` makes this fail to compile
/// when a variant is added, so the tests that use it cannot silently miss one.
pub fn one_error_of_each_kind() -> Vec<ValidationError> {
    let all = vec![
        ValidationError::UnsupportedVersion {
            found: 2,
            expected: 1,
        },
        ValidationError::NonFinite { field: "f" },
        ValidationError::BadRobotId(String::new()),
        ValidationError::CovarianceNotSymmetric { field: "c" },
        ValidationError::CovarianceNotPositiveDefinite { field: "c" },
        ValidationError::ConfidenceOutOfRange(2.0),
        ValidationError::OutsidePitch {
            x_m: 9.0,
            y_m: 0.0,
            outside_m: 7.0,
        },
        ValidationError::StampOutOfRange {
            skew_s: 11.0,
            limit_s: 10.0,
        },
        ValidationError::OutOfRange {
            field: "f",
            value: -1.0,
        },
        ValidationError::TooMany {
            field: "f",
            count: 9,
            limit: 8,
        },
        ValidationError::TooLong {
            field: "f",
            bytes: 9,
            limit: 8,
        },
        ValidationError::NotAnImage("jpeg_base64 is not a JPEG"),
    ];
    for e in &all {
        match e {
            ValidationError::UnsupportedVersion { .. }
            | ValidationError::NonFinite { .. }
            | ValidationError::BadRobotId(_)
            | ValidationError::CovarianceNotSymmetric { .. }
            | ValidationError::CovarianceNotPositiveDefinite { .. }
            | ValidationError::ConfidenceOutOfRange(_)
            | ValidationError::OutsidePitch { .. }
            | ValidationError::StampOutOfRange { .. }
            | ValidationError::OutOfRange { .. }
            | ValidationError::TooMany { .. }
            | ValidationError::TooLong { .. }
            | ValidationError::NotAnImage(_) => {}
        }
    }
    all
}
