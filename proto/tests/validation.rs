//! `validate()`: a sound message of each inbound type passes, and each way of being wrong
//! is rejected with its own `ValidationError` (and `reason()` label).

mod support;

use proto::{Pitch, Validate, ValidationError};
use std::collections::HashSet;
use support::checks::*;
use support::examples::{self, ctx};

#[test]
fn sound_messages_validate() {
    assert_accepted(&examples::observation(), &ctx());
    assert_accepted(&examples::robot_status(), &ctx());
    assert_accepted(&examples::prediction(), &ctx());
    assert_accepted(&examples::ball_state(), &ctx());
    assert_accepted(&examples::pitch(), &ctx());
    assert_accepted(&examples::camera_view(), &ctx());
    let mut no_pixel = examples::observation();
    no_pixel.pixel = None;
    assert_accepted(&no_pixel, &ctx());
}

mod observation {
    use super::*;
    use proto::Observation;

    fn base() -> Observation {
        examples::observation()
    }

    #[test]
    fn version() {
        check_version(&base(), |o, v| o.version = v);
    }

    #[test]
    fn robot_id() {
        check_robot_id(&base(), |o, id| o.robot_id = id);
    }

    #[test]
    fn non_finite() {
        check_non_finite::<Observation>(
            &base(),
            &[
                ("position_m", |o, v| o.position_m[0] = v),
                ("position_m", |o, v| o.position_m[1] = v),
                ("confidence", |o, v| o.confidence = v),
                ("robot_pose", |o, v| o.robot_pose.x_m = v),
                ("robot_pose", |o, v| o.robot_pose.y_m = v),
                ("robot_pose", |o, v| o.robot_pose.theta_rad = v),
                ("pixel", |o, v| o.pixel.as_mut().expect("pixel").u_px = v),
                ("pixel", |o, v| o.pixel.as_mut().expect("pixel").v_px = v),
                ("pixel", |o, v| {
                    o.pixel.as_mut().expect("pixel").radius_px = v
                }),
                ("covariance_m2", |o, v| o.covariance_m2[0] = v),
                ("covariance_m2", |o, v| o.covariance_m2[2] = v),
            ],
        );
    }

    fn cov(o: &mut Observation) -> &mut [f64] {
        &mut o.covariance_m2
    }

    #[test]
    fn covariance() {
        check_covariance(&base(), "covariance_m2", 2, cov);
    }

    #[test]
    fn confidence() {
        for bad in [-0.01, 1.01, -1e300] {
            let mut o = base();
            o.confidence = bad;
            assert_eq!(
                o.validate(&ctx()),
                Err(ValidationError::ConfidenceOutOfRange(bad))
            );
        }
        for good in [0.0, 1.0] {
            let mut o = base();
            o.confidence = good;
            assert_accepted(&o, &ctx());
        }
    }

    #[test]
    fn ball_position_outside_pitch() {
        check_position(&base(), |o, p| o.position_m = p);
    }

    #[test]
    fn robot_position_outside_pitch() {
        check_position(&base(), |o, p| {
            o.robot_pose.x_m = p[0];
            o.robot_pose.y_m = p[1];
        });
    }

    #[test]
    fn stamp() {
        check_stamp(&base(), |o, s| o.stamp = s);
    }
}

mod robot_status {
    use super::*;
    use proto::RobotStatus;

    fn base() -> RobotStatus {
        examples::robot_status()
    }

    #[test]
    fn version() {
        check_version(&base(), |m, v| m.version = v);
    }

    #[test]
    fn robot_id() {
        check_robot_id(&base(), |m, id| m.robot_id = id);
    }

    #[test]
    fn non_finite() {
        check_non_finite::<RobotStatus>(
            &base(),
            &[
                ("pose", |m, v| m.pose.x_m = v),
                ("pose", |m, v| m.pose.y_m = v),
                ("pose", |m, v| m.pose.theta_rad = v),
                ("head", |m, v| m.head.lift_rad = v),
                ("head", |m, v| m.head.yaw_rad = v),
                ("head", |m, v| m.head.pitch_rad = v),
                ("fps", |m, v| m.fps = v),
                ("timings", |m, v| m.timings[1].ms = v),
                ("footprints", |m, v| m.footprints[1].polygon_m[2][0] = v),
                ("footprints", |m, v| m.footprints[0].polygon_m[0][1] = v),
                ("pose_covariance", |m, v| m.pose_covariance[4] = v),
                ("pose_covariance", |m, v| m.pose_covariance[6] = v),
            ],
        );
    }

    fn cov(m: &mut RobotStatus) -> &mut [f64] {
        &mut m.pose_covariance
    }

    #[test]
    fn covariance() {
        check_covariance(&base(), "pose_covariance", 3, cov);
    }

    #[test]
    fn out_of_range() {
        check_out_of_range::<RobotStatus>(
            &base(),
            &[
                ("fps", -1.0, |m, v| m.fps = v),
                ("fps", 2e4, |m, v| m.fps = v),
                ("timings", -0.5, |m, v| m.timings[0].ms = v),
                ("timings", 2e6, |m, v| m.timings[2].ms = v),
            ],
        );
    }

    /// Every variable-length field is capped, so a huge status is refused whole.
    #[test]
    fn sizes_are_capped() {
        use proto::{
            CameraFootprint, MAX_FOOTPRINT_POINTS, MAX_STAGE_NAME_BYTES, MAX_STATUS_FOOTPRINTS,
            MAX_STATUS_TIMINGS, StageTiming,
        };
        let timing = |stage: String| StageTiming { stage, ms: 1.0 };
        let mut m = base();
        m.timings = vec![timing("s".into()); MAX_STATUS_TIMINGS];
        assert_accepted(&m, &ctx());
        m.timings.push(timing("s".into()));
        assert_rejected(&m, &ctx(), "too_many");
        let mut m = base();
        m.timings[0].stage = "x".repeat(MAX_STAGE_NAME_BYTES);
        assert_accepted(&m, &ctx());
        m.timings[0].stage.push('x');
        assert_rejected(&m, &ctx(), "too_long");
        let mut m = base();
        let f = m.footprints[0].clone();
        m.footprints = vec![f.clone(); MAX_STATUS_FOOTPRINTS];
        assert_accepted(&m, &ctx());
        m.footprints.push(f);
        assert_rejected(&m, &ctx(), "too_many");
        let mut m = base();
        m.footprints[0] = CameraFootprint {
            camera: m.footprints[0].camera,
            polygon_m: vec![[0.0, 0.0]; MAX_FOOTPRINT_POINTS + 1],
        };
        assert_rejected(&m, &ctx(), "too_many");
    }

    #[test]
    fn pose_outside_pitch() {
        check_position(&base(), |m, p| {
            m.pose.x_m = p[0];
            m.pose.y_m = p[1];
        });
    }

    #[test]
    fn stamp() {
        check_stamp(&base(), |m, s| m.stamp = s);
    }
}

mod prediction {
    use super::*;
    use proto::Prediction;

    fn base() -> Prediction {
        examples::prediction()
    }

    #[test]
    fn version() {
        check_version(&base(), |m, v| m.version = v);
    }

    #[test]
    fn non_finite() {
        check_non_finite::<Prediction>(
            &base(),
            &[
                ("horizon_s", |m, v| m.horizon_s = v),
                ("samples", |m, v| m.samples[1].t_s = v),
                ("samples", |m, v| m.samples[1].position_m[0] = v),
                ("samples", |m, v| m.samples[2].position_m[1] = v),
                ("samples", |m, v| m.samples[0].velocity_mps[1] = v),
                ("bounces", |m, v| m.bounces[0].t_s = v),
                ("bounces", |m, v| m.bounces[0].position_m[1] = v),
                ("stop", |m, v| m.stop.as_mut().expect("stop").t_s = v),
                ("stop", |m, v| {
                    m.stop.as_mut().expect("stop").position_m[0] = v
                }),
            ],
        );
    }

    #[test]
    fn out_of_range() {
        check_out_of_range::<Prediction>(
            &base(),
            &[
                ("horizon_s", -0.1, |m, v| m.horizon_s = v),
                ("horizon_s", 3601.0, |m, v| m.horizon_s = v),
                ("stop.t_s", -1.0, |m, v| {
                    m.stop.as_mut().expect("stop").t_s = v
                }),
            ],
        );
    }

    #[test]
    fn sample_outside_pitch() {
        check_position(&base(), |m, p| m.samples[2].position_m = p);
    }

    #[test]
    fn stamp() {
        check_stamp(&base(), |m, s| m.stamp = s);
    }
}

mod ball_state {
    use super::*;
    use proto::BallState;

    fn base() -> BallState {
        examples::ball_state()
    }

    #[test]
    fn version() {
        check_version(&base(), |m, v| m.version = v);
        // The inner prediction's version is checked too.
        check_version(&base(), |m, v| m.prediction.version = v);
    }

    #[test]
    fn contributor_id() {
        check_robot_id(&base(), |m, id| m.contributors[1] = id);
    }

    #[test]
    fn non_finite() {
        check_non_finite::<BallState>(
            &base(),
            &[
                ("position_m", |m, v| m.position_m[1] = v),
                ("velocity_mps", |m, v| m.velocity_mps[0] = v),
                ("covariance", |m, v| m.covariance[15] = v),
                ("covariance", |m, v| m.covariance[7] = v),
                ("model", |m, v| m.model.rolling_decel_mps2 = v),
                ("model", |m, v| m.model.wall_restitution = v),
                ("model", |m, v| m.model.tangential_retention = v),
                ("model", |m, v| m.model.slide_decel_mps2 = v),
                ("existence", |m, v| m.existence = v),
                ("horizon_s", |m, v| m.prediction.horizon_s = v),
                ("samples", |m, v| m.prediction.samples[0].t_s = v),
            ],
        );
    }

    fn cov(m: &mut BallState) -> &mut [f64] {
        &mut m.covariance
    }

    #[test]
    fn covariance() {
        check_covariance(&base(), "covariance", 4, cov);
    }

    #[test]
    fn out_of_range() {
        check_out_of_range::<BallState>(
            &base(),
            &[
                ("model.wall_restitution", 1.2, |m, v| {
                    m.model.wall_restitution = v
                }),
                ("model.wall_restitution", -0.1, |m, v| {
                    m.model.wall_restitution = v
                }),
                ("model.rolling_decel_mps2", -0.2, |m, v| {
                    m.model.rolling_decel_mps2 = v
                }),
                ("model.rolling_decel_mps2", 150.0, |m, v| {
                    m.model.rolling_decel_mps2 = v
                }),
                ("horizon_s", -2.0, |m, v| m.prediction.horizon_s = v),
                ("model.tangential_retention", 1.5, |m, v| {
                    m.model.tangential_retention = v
                }),
                ("model.slide_decel_mps2", -1.0, |m, v| {
                    m.model.slide_decel_mps2 = v
                }),
                ("existence", 1.5, |m, v| m.existence = v),
                ("existence", -0.5, |m, v| m.existence = v),
            ],
        );
    }

    #[test]
    fn position_outside_pitch() {
        check_position(&base(), |m, p| m.position_m = p);
        check_position(&base(), |m, p| m.prediction.samples[1].position_m = p);
    }

    #[test]
    fn stamp() {
        check_stamp(&base(), |m, s| m.stamp = s);
        check_stamp(&base(), |m, s| m.prediction.stamp = s);
    }
}

mod pitch {
    use super::*;

    #[test]
    fn version() {
        check_version(&Pitch::default(), |m, v| m.version = v);
    }

    #[test]
    fn non_finite() {
        check_non_finite::<Pitch>(
            &Pitch::default(),
            &[
                ("pitch", |m, v| m.length_m = v),
                ("pitch", |m, v| m.width_m = v),
                ("pitch", |m, v| m.wall_restitution = v),
                ("pitch", |m, v| m.ball_radius_m = v),
            ],
        );
    }

    #[test]
    fn out_of_range() {
        check_out_of_range::<Pitch>(
            &Pitch::default(),
            &[
                ("length_m", 0.05, |m, v| m.length_m = v),
                ("length_m", 2000.0, |m, v| m.length_m = v),
                ("width_m", -1.0, |m, v| m.width_m = v),
                ("wall_restitution", 1.1, |m, v| m.wall_restitution = v),
                ("ball_radius_m", 0.0001, |m, v| m.ball_radius_m = v),
                ("ball_radius_m", 0.6, |m, v| m.ball_radius_m = v),
            ],
        );
        // A ball wider than the pitch: the diameter is what is out of range.
        let tiny = Pitch {
            length_m: 0.3,
            width_m: 0.15,
            ball_radius_m: 0.1,
            ..Pitch::default()
        };
        assert_eq!(
            tiny.validate(&ctx()),
            Err(ValidationError::OutOfRange {
                field: "ball_radius_m",
                value: 0.2
            })
        );
    }

    #[test]
    fn walls_may_be_missing() {
        let open = Pitch {
            walls: Vec::new(),
            ..Pitch::default()
        };
        assert_accepted(&open, &ctx());
    }
}

#[test]
fn reason_labels_are_distinct_and_stable() {
    let reasons: Vec<&str> = examples::one_error_of_each_kind()
        .iter()
        .map(ValidationError::reason)
        .collect();
    let distinct: HashSet<&str> = reasons.iter().copied().collect();
    assert_eq!(distinct.len(), reasons.len(), "{reasons:?}");
    assert_eq!(
        reasons,
        [
            "version",
            "non_finite",
            "robot_id",
            "covariance_asymmetric",
            "covariance_not_pd",
            "confidence",
            "outside_pitch",
            "stamp",
            "out_of_range",
            "too_many",
            "too_long",
            "not_jpeg",
        ]
    );
    for e in examples::one_error_of_each_kind() {
        assert!(!e.to_string().is_empty());
    }
}

mod camera_view {
    use super::*;
    use proto::{CameraView, MAX_VIEW_CANDIDATES, MAX_VIEW_JPEG_BYTES, jpeg_base64};

    fn base() -> CameraView {
        examples::camera_view()
    }

    fn reason(v: &CameraView) -> Option<&'static str> {
        v.validate(&ctx()).err().map(|e| e.reason())
    }

    #[test]
    fn the_image_must_be_a_jpeg_of_the_stated_size() {
        let mut v = base();
        v.jpeg_base64 = "not base64!".into();
        assert_eq!(reason(&v), Some("not_jpeg"));
        let mut v = base();
        v.jpeg_base64 = jpeg_base64(b"\x89PNG\r\n\x1a\n0000000000");
        assert_eq!(reason(&v), Some("not_jpeg"));
        let mut v = base();
        v.width_px = 17;
        assert_eq!(reason(&v), Some("not_jpeg"));
        assert_eq!(base().jpeg().map(|j| j.len()).ok(), Some(330));
    }

    #[test]
    fn sizes_are_capped_before_the_image_is_read() {
        let mut v = base();
        v.jpeg_base64 = "A".repeat(MAX_VIEW_JPEG_BYTES / 3 * 4 + 8);
        assert_eq!(reason(&v), Some("too_long"));
        let mut v = base();
        v.width_px = 321;
        assert_eq!(reason(&v), Some("out_of_range"));
        let mut v = base();
        let c = v.candidates[0].clone();
        v.candidates = vec![c; MAX_VIEW_CANDIDATES + 1];
        assert_eq!(reason(&v), Some("too_many"));
    }

    #[test]
    fn annotations_stay_inside_the_image() {
        for (set, why) in [
            (
                (|v: &mut CameraView| v.candidates[0].u_px = 16.5) as fn(&mut CameraView),
                "out_of_range",
            ),
            (|v| v.candidates[0].v_px = -0.1, "out_of_range"),
            (|v| v.candidates[0].radius_px = 40.0, "out_of_range"),
            (|v| v.candidates[0].score = 1.5, "out_of_range"),
            (|v| v.candidates[1].u_px = f64::NAN, "non_finite"),
            (
                |v| v.candidates[1].reason = Some("Not A Reason".into()),
                "too_long",
            ),
            (|v| v.robot_id = "a/b".into(), "robot_id"),
            (|v| v.stamp = v.stamp.offset_secs(60.0), "stamp"),
        ] {
            let mut v = base();
            set(&mut v);
            assert_eq!(reason(&v), Some(why), "{v:?}");
        }
    }
}
