//! MiRo geometry: where the cameras sit on the robot, as numbers.
//!
//! The agent (projecting detections onto the floor) and the simulator (rendering camera
//! frames) each compute the kinematic chain from these constants with their own code; only
//! the numbers are shared. The lens is not here: a camera's intrinsics and distortion are
//! found by calibration.
//!
//! The chain, from the field frame to a camera:
//!
//! 1. **Body**: origin on the floor midway between the wheels, x forward, y left, z up.
//!    `T_field_body = Trans(x, y, 0) · Rz(θ)` for the robot's pose `(x, y, θ)`.
//! 2. **Lift joint** at [`LIFT_JOINT_IN_BODY_M`]. The neck tips forward by the lift angle
//!    and the head tips with it: `Trans(LIFT_JOINT_IN_BODY_M) · Ry(lift)`.
//! 3. **Head**: [`NECK_LENGTH_M`] up the neck, then yaw about the head's z and pitch about
//!    its y: `Trans(0, 0, NECK_LENGTH_M) · Rz(yaw) · Ry(pitch)`. A positive rotation about
//!    y turns x towards −z, so positive lift and pitch look down.
//! 4. **Cameras** at [`CAMERA_IN_HEAD_M`] (left; the right camera mirrors y), turned
//!    outward by [`CAMERA_DIVERGENCE_RAD`] about the head's z (left +, right −). The
//!    optical frame follows the usual camera convention: z along the optical axis (the
//!    turned head x), x to the image's right (−y of the head), y down the image (−z).

use crate::Camera;

/// Lift joint position in the body frame.
pub const LIFT_JOINT_IN_BODY_M: [f64; 3] = [-0.02, 0.0, 0.16];
/// Lift joint to the head frame's origin, along the neck.
pub const NECK_LENGTH_M: f64 = 0.10;
/// Left camera's optical centre in the head frame.
pub const CAMERA_IN_HEAD_M: [f64; 3] = [0.0377, 0.0431, 0.0568];
/// Each camera looks this far outward of the head's x axis.
pub const CAMERA_DIVERGENCE_RAD: f64 = 27.0 * std::f64::consts::PI / 180.0;
/// Joint ranges, radians.
pub const LIFT_RANGE_RAD: (f64, f64) = (8.0 * DEG, 60.0 * DEG);
pub const YAW_RANGE_RAD: (f64, f64) = (-55.0 * DEG, 55.0 * DEG);
pub const PITCH_RANGE_RAD: (f64, f64) = (-22.0 * DEG, 8.0 * DEG);
/// The head pose robots hold when not scanning: the cameras' centres look 20° down.
pub const DEFAULT_LIFT_RAD: f64 = 30.0 * DEG;
pub const DEFAULT_PITCH_RAD: f64 = -10.0 * DEG;
/// Camera frames as the robot delivers them.
pub const IMAGE_WIDTH_PX: u32 = 640;
pub const IMAGE_HEIGHT_PX: u32 = 360;
/// Nominal horizontal field of view of each camera.
pub const HORIZONTAL_FOV_RAD: f64 = 120.0 * DEG;
/// Wheel track and diameter.
pub const WHEEL_TRACK_M: f64 = 0.164;
pub const WHEEL_DIAMETER_M: f64 = 0.090;

const DEG: f64 = std::f64::consts::PI / 180.0;

/// The camera's optical centre in the head frame: the left one at +y, the right at −y.
pub fn camera_in_head_m(camera: Camera) -> [f64; 3] {
    let [x, y, z] = CAMERA_IN_HEAD_M;
    [x, y * camera_sign(camera), z]
}

/// The camera's outward turn about the head's z axis: +27° left, −27° right.
pub fn camera_yaw_in_head_rad(camera: Camera) -> f64 {
    CAMERA_DIVERGENCE_RAD * camera_sign(camera)
}

fn camera_sign(camera: Camera) -> f64 {
    match camera {
        Camera::Left => 1.0,
        Camera::Right => -1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cameras_mirror_each_other() {
        let l = camera_in_head_m(Camera::Left);
        let r = camera_in_head_m(Camera::Right);
        assert_eq!(l[0], r[0]);
        assert_eq!(l[1], -r[1]);
        assert!(l[1] > 0.0);
        assert_eq!(
            camera_yaw_in_head_rad(Camera::Left),
            -camera_yaw_in_head_rad(Camera::Right)
        );
    }

    #[test]
    fn default_head_pose_is_within_the_joint_ranges() {
        assert!((LIFT_RANGE_RAD.0..=LIFT_RANGE_RAD.1).contains(&DEFAULT_LIFT_RAD));
        assert!((PITCH_RANGE_RAD.0..=PITCH_RANGE_RAD.1).contains(&DEFAULT_PITCH_RAD));
    }
}
