//! Where a MiRo's cameras are: the kinematic chain from the robot's pose and head joints to
//! each camera's optical frame, following `proto::miro`'s definition.
//!
//! The chain is differentiable in every input, which is what the floor projection's
//! covariance needs: the pose and joint uncertainties move the camera, and with it the point
//! where a view ray meets the floor.

use nalgebra::{Matrix3, Rotation3, Vector3};
use proto::miro::{LIFT_JOINT_IN_BODY_M, NECK_LENGTH_M, camera_in_head_m, camera_yaw_in_head_rad};
use proto::{Camera, HeadJoints, Pose2};

/// A camera's optical frame in the field frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraPose {
    /// Rotates camera-frame vectors into the field frame.
    pub field_from_camera: Rotation3<f64>,
    /// The optical centre in the field frame, metres.
    pub centre_m: Vector3<f64>,
}

impl CameraPose {
    /// A camera-frame direction expressed in the field frame.
    pub fn direction_in_field(&self, ray_cam: [f64; 3]) -> Vector3<f64> {
        self.field_from_camera * Vector3::from(ray_cam)
    }

    /// A field-frame point expressed in the camera frame, metres.
    #[cfg(test)]
    pub fn point_in_camera(&self, p_field_m: Vector3<f64>) -> Vector3<f64> {
        self.field_from_camera.inverse() * (p_field_m - self.centre_m)
    }
}

/// The optical frame's axes in the head frame before the camera's outward turn: z along the
/// head's x, x along the head's −y, y along the head's −z.
fn head_from_optical() -> Rotation3<f64> {
    Rotation3::from_matrix_unchecked(Matrix3::new(
        0.0, 0.0, 1.0, //
        -1.0, 0.0, 0.0, //
        0.0, -1.0, 0.0,
    ))
}

/// The pose of `camera` in the field frame for a robot at `pose` with its head at `head`.
pub fn camera_pose(pose: &Pose2, head: &HeadJoints, camera: Camera) -> CameraPose {
    let z = Vector3::z_axis();
    let y = Vector3::y_axis();
    let body_r = Rotation3::from_axis_angle(&z, pose.theta_rad);
    let body_t = Vector3::new(pose.x_m, pose.y_m, 0.0);
    let lift_r = Rotation3::from_axis_angle(&y, head.lift_rad);
    let head_r = body_r
        * lift_r
        * Rotation3::from_axis_angle(&z, head.yaw_rad)
        * Rotation3::from_axis_angle(&y, head.pitch_rad);
    let head_t = body_t
        + body_r
            * (Vector3::from(LIFT_JOINT_IN_BODY_M)
                + lift_r * Vector3::new(0.0, 0.0, NECK_LENGTH_M));
    let camera_r = Rotation3::from_axis_angle(&z, camera_yaw_in_head_rad(camera));
    CameraPose {
        field_from_camera: head_r * camera_r * head_from_optical(),
        centre_m: head_t + head_r * Vector3::from(camera_in_head_m(camera)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proto::miro::{CAMERA_DIVERGENCE_RAD, DEFAULT_LIFT_RAD, DEFAULT_PITCH_RAD};

    fn default_head() -> HeadJoints {
        HeadJoints {
            lift_rad: DEFAULT_LIFT_RAD,
            yaw_rad: 0.0,
            pitch_rad: DEFAULT_PITCH_RAD,
        }
    }

    #[test]
    fn default_head_puts_the_cameras_high_ahead_and_looking_down_and_out() {
        let pose = Pose2::default();
        for (camera, side) in [(Camera::Left, 1.0), (Camera::Right, -1.0)] {
            let c = camera_pose(&pose, &default_head(), camera);
            // Worked by hand from proto::miro: head origin at (0.03, 0, 0.2466), the camera
            // offset turned 20° down.
            assert_relative_eq!(c.centre_m.z, 0.2466 + 0.0405, epsilon = 2e-4);
            assert_relative_eq!(c.centre_m.x, 0.03 + 0.0549, epsilon = 2e-4);
            assert_relative_eq!(c.centre_m.y, side * 0.0431, epsilon = 1e-12);
            let axis = c.direction_in_field([0.0, 0.0, 1.0]);
            // The outward turn happens in the head frame, after the head looks 20° down.
            let (down, out) = (20f64.to_radians(), CAMERA_DIVERGENCE_RAD);
            assert_relative_eq!(axis.z, -down.sin() * out.cos(), epsilon = 1e-12);
            let azimuth = axis.y.atan2(axis.x);
            assert_relative_eq!(
                azimuth,
                side * out.sin().atan2(out.cos() * down.cos()),
                epsilon = 1e-12
            );
            // Image right lies clockwise of the axis seen from above, image down points down.
            let right = c.direction_in_field([1.0, 0.0, 0.0]);
            assert!(axis.cross(&right).z < 0.0);
            assert!(c.direction_in_field([0.0, 1.0, 0.0]).z < 0.0);
        }
    }

    #[test]
    fn pose_and_yaw_rotate_the_cameras_about_vertical_axes() {
        let head = default_head();
        let base = camera_pose(&Pose2::default(), &head, Camera::Left);
        let moved = camera_pose(
            &Pose2 {
                x_m: 1.0,
                y_m: -0.5,
                theta_rad: 0.7,
            },
            &head,
            Camera::Left,
        );
        let rotated = Rotation3::from_axis_angle(&Vector3::z_axis(), 0.7) * base.centre_m
            + Vector3::new(1.0, -0.5, 0.0);
        assert_relative_eq!(moved.centre_m, rotated, epsilon = 1e-12);
        let yawed = camera_pose(
            &Pose2::default(),
            &HeadJoints {
                yaw_rad: 0.3,
                ..head
            },
            Camera::Left,
        );
        // Yawing the head to the left turns the optical axis to the left.
        let a = base.direction_in_field([0.0, 0.0, 1.0]);
        let b = yawed.direction_in_field([0.0, 0.0, 1.0]);
        assert!(b.y.atan2(b.x) > a.y.atan2(a.x));
    }

    #[test]
    fn camera_frame_round_trips() {
        let c = camera_pose(
            &Pose2 {
                x_m: 0.3,
                y_m: 0.2,
                theta_rad: -2.0,
            },
            &default_head(),
            Camera::Right,
        );
        let p = Vector3::new(1.0, 0.5, 0.04);
        let q = c.point_in_camera(p);
        assert_relative_eq!(c.field_from_camera * q + c.centre_m, p, epsilon = 1e-12);
    }
}
