//! Where a MiRo's cameras are: the kinematic chain of `proto::miro`, computed here with the
//! simulator's own code (only the constants are shared with the agent).

use crate::vec3::{Mat3, V3, add, mul, mul_vec, rot_y, rot_z};
use proto::miro::{LIFT_JOINT_IN_BODY_M, NECK_LENGTH_M, camera_in_head_m, camera_yaw_in_head_rad};
use proto::{Camera, HeadJoints, Pose2};

/// A rigid pose in the field frame: `field_from_local` rotates local vectors into the
/// field frame, `origin_m` is the local origin in field coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldPose {
    pub field_from_local: Mat3,
    pub origin_m: V3,
}

impl FieldPose {
    /// A point given in the local frame, in field coordinates.
    pub fn point(&self, local_m: V3) -> V3 {
        add(self.origin_m, mul_vec(&self.field_from_local, local_m))
    }

    /// This pose followed by `local`: the pose of a frame given relative to this one.
    pub fn then(&self, local: &FieldPose) -> FieldPose {
        FieldPose {
            field_from_local: mul(&self.field_from_local, &local.field_from_local),
            origin_m: self.point(local.origin_m),
        }
    }
}

/// The head pose robots hold when not scanning (cameras' centres 20° down).
pub fn default_head() -> HeadJoints {
    HeadJoints {
        lift_rad: proto::miro::DEFAULT_LIFT_RAD,
        yaw_rad: 0.0,
        pitch_rad: proto::miro::DEFAULT_PITCH_RAD,
    }
}

/// The robot's body frame (origin on the floor between the wheels, x forward, z up).
pub fn body_pose(pose: Pose2) -> FieldPose {
    FieldPose {
        field_from_local: rot_z(pose.theta_rad),
        origin_m: [pose.x_m, pose.y_m, 0.0],
    }
}

/// The head frame: lift joint, up the neck, then yaw and pitch.
pub fn head_pose(pose: Pose2, head: HeadJoints) -> FieldPose {
    let lift = FieldPose {
        field_from_local: rot_y(head.lift_rad),
        origin_m: LIFT_JOINT_IN_BODY_M,
    };
    let neck = FieldPose {
        field_from_local: mul(&rot_z(head.yaw_rad), &rot_y(head.pitch_rad)),
        origin_m: [0.0, 0.0, NECK_LENGTH_M],
    };
    body_pose(pose).then(&lift).then(&neck)
}

/// Turns optical-frame axes (x right, y down, z forward) into the head's (x forward,
/// y left, z up): columns are the optical axes in head coordinates.
const HEAD_AXES_FROM_OPTICAL: Mat3 = [[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]];

/// The camera's optical frame in the field: `field_from_local` is field←camera, `origin_m`
/// the optical centre.
pub fn camera_pose(pose: Pose2, head: HeadJoints, camera: Camera) -> FieldPose {
    let cam = FieldPose {
        field_from_local: mul(
            &rot_z(camera_yaw_in_head_rad(camera)),
            &HEAD_AXES_FROM_OPTICAL,
        ),
        origin_m: camera_in_head_m(camera),
    };
    head_pose(pose, head).then(&cam)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis(p: &FieldPose) -> V3 {
        mul_vec(&p.field_from_local, [0.0, 0.0, 1.0])
    }

    #[test]
    fn default_cameras_sit_above_and_ahead_looking_down_and_outward() {
        let pose = Pose2::default();
        for (camera, sign) in [(Camera::Left, 1.0), (Camera::Right, -1.0)] {
            let p = camera_pose(pose, default_head(), camera);
            let [x, y, z] = p.origin_m;
            assert!((0.28..0.29).contains(&z), "height {z}");
            assert!((0.075..0.09).contains(&x), "ahead {x}");
            assert!((y * sign - 0.0431).abs() < 1e-12);
            // The head's x axis looks 20° down; each camera is turned 27° about the
            // head's tilted z, so its axis is a little less steep and a little wider.
            let head_x = mul_vec(
                &head_pose(pose, default_head()).field_from_local,
                [1.0, 0.0, 0.0],
            );
            assert!(((-head_x[2]).asin().to_degrees() - 20.0).abs() < 1e-9);
            let (d, t) = (27f64.to_radians(), 20f64.to_radians());
            let a = axis(&p);
            let down = (-a[2]).asin();
            assert!((down - (d.cos() * t.sin()).asin()).abs() < 1e-9, "{down}");
            assert!((17.0..19.0).contains(&down.to_degrees()));
            let out = a[1].atan2(a[0]) * sign;
            assert!(
                (out - d.sin().atan2(d.cos() * t.cos())).abs() < 1e-9,
                "{out}"
            );
            assert!((27.0..29.0).contains(&out.to_degrees()));
            // Image x points right (tipped a little by the head tilt), image y down.
            let right = mul_vec(&p.field_from_local, [1.0, 0.0, 0.0]);
            assert!(right[1] < 0.0 && right[2].abs() < 0.2);
            let down_img = mul_vec(&p.field_from_local, [0.0, 1.0, 0.0]);
            assert!(down_img[2] < -0.9);
        }
        let l = camera_pose(pose, default_head(), Camera::Left);
        let r = camera_pose(pose, default_head(), Camera::Right);
        assert!((l.origin_m[0] - r.origin_m[0]).abs() < 1e-12);
        assert!((l.origin_m[2] - r.origin_m[2]).abs() < 1e-12);
    }

    #[test]
    fn the_chain_follows_the_robot_pose_and_the_head_yaw() {
        let pose = Pose2 {
            x_m: 1.0,
            y_m: -0.5,
            theta_rad: std::f64::consts::FRAC_PI_2,
        };
        let p = camera_pose(pose, default_head(), Camera::Left);
        let p0 = camera_pose(Pose2::default(), default_head(), Camera::Left);
        assert!((p.origin_m[0] - (1.0 - p0.origin_m[1])).abs() < 1e-12);
        assert!((p.origin_m[1] - (-0.5 + p0.origin_m[0])).abs() < 1e-12);
        // With the neck upright and no pitch, the azimuth is yaw ± divergence.
        let head = HeadJoints {
            lift_rad: 0.0,
            yaw_rad: 0.3,
            pitch_rad: 0.0,
        };
        let a = axis(&camera_pose(Pose2::default(), head, Camera::Right));
        let yaw = a[1].atan2(a[0]);
        assert!((yaw - (0.3 - 27f64.to_radians())).abs() < 1e-9, "{yaw}");
        assert!(a[2].abs() < 1e-12);
    }
}
