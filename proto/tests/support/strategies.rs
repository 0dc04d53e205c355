//! Proptest strategies for every message: any finite floats (including subnormals and
//! signed zero), any strings, any lengths up to a few elements. Versions are always
//! [`proto::VERSION`], the only one `decode` accepts.

use proptest::collection::vec;
use proptest::prelude::*;
use proto::{
    BallState, BallStatus, BounceEvent, Camera, CameraFootprint, HeadJoints, Intercept,
    ModelParams, Observation, PathSample, Pitch, PixelBall, Pose2, Prediction, RobotStatus,
    StageTiming, Stamp, StopPoint, VERSION, WallSide,
};

/// Any finite `f64`: normal, subnormal or zero, of either sign.
pub fn finite() -> impl Strategy<Value = f64> {
    use proptest::num::f64 as f;
    f::POSITIVE | f::NEGATIVE | f::NORMAL | f::SUBNORMAL | f::ZERO
}

pub fn pair() -> impl Strategy<Value = [f64; 2]> {
    [finite(), finite()]
}

pub fn stamp() -> impl Strategy<Value = Stamp> {
    any::<u64>().prop_map(Stamp)
}

pub fn camera() -> impl Strategy<Value = Camera> {
    prop_oneof![Just(Camera::Left), Just(Camera::Right)]
}

pub fn wall_side() -> impl Strategy<Value = WallSide> {
    proptest::sample::select(WallSide::ALL.to_vec())
}

pub fn ball_status() -> impl Strategy<Value = BallStatus> {
    prop_oneof![
        Just(BallStatus::Tracking),
        Just(BallStatus::Coasting),
        Just(BallStatus::Stopped),
        Just(BallStatus::Lost),
    ]
}

prop_compose! {
    pub fn pose2()(x_m in finite(), y_m in finite(), theta_rad in finite()) -> Pose2 {
        Pose2 { x_m, y_m, theta_rad }
    }
}

prop_compose! {
    pub fn pixel_ball()(u_px in finite(), v_px in finite(), radius_px in finite()) -> PixelBall {
        PixelBall { u_px, v_px, radius_px }
    }
}

prop_compose! {
    pub fn observation()(
        robot_id in any::<String>(),
        seq in any::<u64>(),
        camera in camera(),
        stamp in stamp(),
        position_m in pair(),
        covariance_m2 in [finite(), finite(), finite(), finite()],
        confidence in finite(),
        robot_pose in pose2(),
        pixel in proptest::option::of(pixel_ball()),
    ) -> Observation {
        Observation {
            version: VERSION,
            robot_id,
            seq,
            camera,
            stamp,
            position_m,
            covariance_m2,
            confidence,
            robot_pose,
            pixel,
        }
    }
}

prop_compose! {
    pub fn head_joints()(lift_rad in finite(), yaw_rad in finite(), pitch_rad in finite())
        -> HeadJoints {
        HeadJoints { lift_rad, yaw_rad, pitch_rad }
    }
}

prop_compose! {
    pub fn stage_timing()(stage in any::<String>(), ms in finite()) -> StageTiming {
        StageTiming { stage, ms }
    }
}

prop_compose! {
    pub fn camera_footprint()(camera in camera(), polygon_m in vec(pair(), 0..6))
        -> CameraFootprint {
        CameraFootprint { camera, polygon_m }
    }
}

prop_compose! {
    pub fn robot_status()(
        robot_id in any::<String>(),
        stamp in stamp(),
        pose in pose2(),
        pose_covariance in proptest::array::uniform9(finite()),
        head in head_joints(),
        fps in finite(),
        timings in vec(stage_timing(), 0..4),
        footprints in vec(camera_footprint(), 0..3),
    ) -> RobotStatus {
        RobotStatus {
            version: VERSION,
            robot_id,
            stamp,
            pose,
            pose_covariance,
            head,
            fps,
            timings,
            footprints,
            cameras: Vec::new(),
        }
    }
}

pub fn covariance_2() -> impl Strategy<Value = Option<[f64; 4]>> {
    proptest::option::of([finite(), finite(), finite(), finite()])
}

prop_compose! {
    pub fn path_sample()(
        t_s in finite(),
        position_m in pair(),
        velocity_mps in pair(),
        covariance_m2 in covariance_2(),
    ) -> PathSample {
        PathSample { t_s, position_m, velocity_mps, covariance_m2 }
    }
}

prop_compose! {
    pub fn bounce_event()(t_s in finite(), position_m in pair(), wall in wall_side())
        -> BounceEvent {
        BounceEvent { t_s, position_m, wall }
    }
}

prop_compose! {
    pub fn stop_point()(t_s in finite(), position_m in pair(), covariance_m2 in covariance_2())
        -> StopPoint {
        StopPoint { t_s, position_m, covariance_m2 }
    }
}

prop_compose! {
    pub fn prediction()(
        stamp in stamp(),
        horizon_s in finite(),
        samples in vec(path_sample(), 0..6),
        bounces in vec(bounce_event(), 0..3),
        stop in proptest::option::of(stop_point()),
    ) -> Prediction {
        Prediction { version: VERSION, stamp, horizon_s, samples, bounces, stop }
    }
}

prop_compose! {
    pub fn model_params()(
        rolling_decel_mps2 in finite(),
        wall_restitution in finite(),
        decel_samples in any::<u32>(),
        restitution_samples in any::<u32>(),
    ) -> ModelParams {
        ModelParams {
            rolling_decel_mps2,
            wall_restitution,
            decel_samples,
            restitution_samples,
            tangential_retention: 0.85,
            slide_decel_mps2: 3.0,
            bounces_seen: 0,
            kicks_inferred: 0,
        }
    }
}

prop_compose! {
    pub fn ball_state()(
        stamp in stamp(),
        position_m in pair(),
        velocity_mps in pair(),
        covariance in proptest::array::uniform16(finite()),
        status in ball_status(),
        last_seen in proptest::option::of(stamp()),
        contributors in vec(any::<String>(), 0..4),
        model in model_params(),
        prediction in prediction(),
    ) -> BallState {
        BallState {
            version: VERSION,
            stamp,
            position_m,
            velocity_mps,
            covariance,
            status,
            last_seen,
            contributors,
            existence: 1.0,
            model,
            prediction,
        }
    }
}

prop_compose! {
    pub fn intercept()(
        robot_id in any::<String>(),
        stamp in stamp(),
        reachable_in_motion in any::<bool>(),
        t_s in finite(),
        point_m in pair(),
    ) -> Intercept {
        Intercept { version: VERSION, robot_id, stamp, reachable_in_motion, t_s, point_m, probability: None }
    }
}

prop_compose! {
    pub fn pitch()(
        length_m in finite(),
        width_m in finite(),
        walls in vec(wall_side(), 0..5),
        wall_restitution in finite(),
        ball_radius_m in finite(),
    ) -> Pitch {
        Pitch { version: VERSION, length_m, width_m, walls, wall_restitution, ball_radius_m }
    }
}
