//! A MiRo's ROS recordings in MCAP (ROS 2 bags, or ROS 1 bags converted): which channels
//! are used, and the robot's state at each frame from the joint and pose messages.
//!
//! A channel is a ROS one when its message encoding is `ros1` or `cdr`; it is used when its
//! topic is one of [`RosTopics`] and its schema is the type that topic should carry. The
//! messages' header stamps are the capture stamps (the log time when a header stamp is
//! zero). Each frame takes the latest joints and pose at or before it (or else the first
//! ones); a recording without them uses the MiRo's default head and `--pose-origin`, with a
//! warning.

use crate::io::ros_msg::{self, Encoding, MessageType};
use anyhow::{Context, Result, bail};
use proto::{Camera, HeadJoints, Pose2, Stamp};
use std::collections::BTreeMap;

use crate::runtime::frame::{McapImage, RobotState};

/// The topics of a MiRo's ROS recording.
#[derive(Debug, Clone, clap::Args)]
pub struct RosTopics {
    /// In a ROS recording: the left camera's `sensor_msgs/CompressedImage` topic.
    #[arg(long, default_value = "/miro/sensors/caml/compressed")]
    pub left_topic: String,
    /// In a ROS recording: the right camera's `sensor_msgs/CompressedImage` topic.
    #[arg(long, default_value = "/miro/sensors/camr/compressed")]
    pub right_topic: String,
    /// In a ROS recording: the `sensor_msgs/JointState` topic with the neck joints
    /// (`lift`, `yaw`, `pitch`).
    #[arg(long, default_value = "/miro/sensors/kinematic_joints")]
    pub joints_topic: String,
    /// In a ROS recording: body pose topics (`geometry_msgs/Pose2D` or `nav_msgs/Odometry`),
    /// comma-separated in order of preference; the first one the recording holds is used.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "/miro/sensors/body_pose,/miro/sensors/odom"
    )]
    pub pose_topic: Vec<String>,
    /// In a ROS recording: where the odometry's origin lies on the field, `X,Y,THETA`
    /// (metres, radians); the robot's pose when the recording has none.
    #[arg(long, value_parser = parse_pose, default_value = "0,0,0", allow_hyphen_values = true)]
    pub pose_origin: Pose2,
    /// With `--source ros1`: the ROS master's URI (default: `ROS_MASTER_URI`, else
    /// http://localhost:11311).
    #[arg(long, value_name = "URI")]
    pub ros_master_uri: Option<String>,
}

impl Default for RosTopics {
    fn default() -> Self {
        RosTopics {
            left_topic: "/miro/sensors/caml/compressed".into(),
            right_topic: "/miro/sensors/camr/compressed".into(),
            joints_topic: "/miro/sensors/kinematic_joints".into(),
            pose_topic: vec![
                "/miro/sensors/body_pose".into(),
                "/miro/sensors/odom".into(),
            ],
            pose_origin: Pose2 {
                x_m: 0.0,
                y_m: 0.0,
                theta_rad: 0.0,
            },
            ros_master_uri: None,
        }
    }
}

fn parse_pose(s: &str) -> Result<Pose2> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{s:?} is not X,Y,THETA"))?;
    match v[..] {
        [x_m, y_m, theta_rad] if v.iter().all(|x| x.is_finite()) => Ok(Pose2 {
            x_m,
            y_m,
            theta_rad,
        }),
        _ => bail!("{s:?} is not X,Y,THETA (three finite numbers)"),
    }
}

/// Odometry without a covariance (`Pose2D`, or an `Odometry` whose covariance is unset)
/// is taken as this uncertain: dead reckoning over a match drifts by centimetres.
const ODOMETRY_SIGMA_XY_M: f64 = 0.05;
const ODOMETRY_SIGMA_THETA_RAD: f64 = 0.05;

pub fn default_pose_covariance() -> [f64; 9] {
    let (xy, th) = (
        ODOMETRY_SIGMA_XY_M * ODOMETRY_SIGMA_XY_M,
        ODOMETRY_SIGMA_THETA_RAD * ODOMETRY_SIGMA_THETA_RAD,
    );
    [xy, 0.0, 0.0, 0.0, xy, 0.0, 0.0, 0.0, th]
}

/// The head a MiRo holds when not scanning, for recordings without joint states.
fn default_head() -> HeadJoints {
    HeadJoints {
        lift_rad: proto::miro::DEFAULT_LIFT_RAD,
        yaw_rad: 0.0,
        pitch_rad: proto::miro::DEFAULT_PITCH_RAD,
    }
}

/// A pose in the odometry frame (a body pose, with its covariance).
#[derive(Debug, Clone, Copy)]
pub struct OdomPose {
    pub pose: Pose2,
    pub covariance: [f64; 9],
}

/// What a recording's ROS channels hold besides the images.
#[derive(Debug, Default)]
pub struct RosStates {
    pub joints: Vec<(Stamp, HeadJoints)>,
    /// Poses by topic: the preferred topic present is chosen once the file is read.
    pub poses: BTreeMap<String, Vec<(Stamp, OdomPose)>>,
    /// Messages on ROS topics the agent does not use, by topic.
    pub ignored: BTreeMap<String, u64>,
}

/// One ROS message of a recording.
#[derive(Debug)]
pub struct RosMessage<'a> {
    pub encoding: Encoding,
    pub topic: &'a str,
    pub schema_name: &'a str,
    pub log_time: Stamp,
    pub data: &'a [u8],
}

/// The header stamp, or the log time when the publisher left the stamp at zero.
fn stamp_or(header: &ros_msg::Header, log_time: Stamp) -> Stamp {
    if header.stamp.0 == 0 {
        log_time
    } else {
        header.stamp
    }
}

/// Takes one ROS message: an image is returned, a state is kept in `states`, a message on
/// an unused topic is counted. An error says why a message on a used topic is unusable.
pub fn take(
    topics: &RosTopics,
    states: &mut RosStates,
    m: &RosMessage<'_>,
) -> Result<Option<(Stamp, Camera, McapImage)>> {
    let ty = MessageType::of_schema_name(m.schema_name);
    let expect = |wanted: &[MessageType]| -> Result<MessageType> {
        ty.filter(|t| wanted.contains(t)).with_context(|| {
            format!(
                "schema {:?} is not {}",
                m.schema_name,
                wanted
                    .iter()
                    .map(|t| format!("{t:?}"))
                    .collect::<Vec<_>>()
                    .join(" or ")
            )
        })
    };
    let camera = if m.topic == topics.left_topic {
        Some(Camera::Left)
    } else if m.topic == topics.right_topic {
        Some(Camera::Right)
    } else {
        None
    };
    if let Some(camera) = camera {
        expect(&[MessageType::CompressedImage])?;
        let image = ros_msg::decode_compressed_image(m.encoding, m.data)?;
        let stamp = stamp_or(&image.header, m.log_time);
        return Ok(Some((stamp, camera, McapImage::Compressed(image.data))));
    }
    if m.topic == topics.joints_topic {
        expect(&[MessageType::JointState])?;
        let joints = ros_msg::decode_joint_state(m.encoding, m.data)?;
        let head = joints
            .miro_head()
            .context("no finite lift, yaw and pitch joint positions")?;
        states
            .joints
            .push((stamp_or(&joints.header, m.log_time), head));
        return Ok(None);
    }
    if topics.pose_topic.iter().any(|t| t == m.topic) {
        let pose = match expect(&[MessageType::Pose2D, MessageType::Odometry])? {
            MessageType::Pose2D => {
                let p = ros_msg::decode_pose2d(m.encoding, m.data)?;
                let pose = OdomPose {
                    pose: p.pose(),
                    covariance: default_pose_covariance(),
                };
                (m.log_time, pose)
            }
            _ => {
                let o = ros_msg::decode_odometry(m.encoding, m.data)?;
                let c = o.planar_covariance();
                let set = [c[0], c[4], c[8]].iter().all(|v| v.is_finite() && *v > 0.0);
                let pose = OdomPose {
                    pose: o.pose(),
                    covariance: if set { c } else { default_pose_covariance() },
                };
                (stamp_or(&o.header, m.log_time), pose)
            }
        };
        if !pose.1.pose.x_m.is_finite()
            || !pose.1.pose.y_m.is_finite()
            || !pose.1.pose.theta_rad.is_finite()
        {
            bail!("pose is not finite");
        }
        states
            .poses
            .entry(m.topic.to_string())
            .or_default()
            .push(pose);
        return Ok(None);
    }
    *states.ignored.entry(m.topic.to_string()).or_default() += 1;
    Ok(None)
}

/// A recording's ROS states ready for lookup by frame stamp.
#[derive(Debug)]
pub struct RosTrack {
    joints: Vec<(Stamp, HeadJoints)>,
    poses: Vec<(Stamp, OdomPose)>,
    origin: Pose2,
}

impl RosTrack {
    /// Sorts the states and picks the preferred pose topic; warns about what is missing.
    pub fn new(mut states: RosStates, topics: &RosTopics, name: &str) -> RosTrack {
        states.joints.sort_by_key(|(s, _)| *s);
        let chosen = topics
            .pose_topic
            .iter()
            .find_map(|t| states.poses.remove(t).map(|p| (t, p)));
        let poses = match chosen {
            Some((topic, mut poses)) => {
                tracing::info!("{name}: body pose from {topic} ({} messages)", poses.len());
                poses.sort_by_key(|(s, _)| *s);
                poses
            }
            None => {
                let o = topics.pose_origin;
                tracing::warn!(
                    "{name}: no body pose on {}: every frame is taken with the robot at \
                     x {} m, y {} m, heading {} rad (--pose-origin)",
                    topics.pose_topic.join(" or "),
                    o.x_m,
                    o.y_m,
                    o.theta_rad
                );
                Vec::new()
            }
        };
        if states.joints.is_empty() {
            tracing::warn!(
                "{name}: no joint states on {}: every frame is taken with the MiRo's default \
                 head (lift {:.0}°, yaw 0°, pitch {:.0}°)",
                topics.joints_topic,
                proto::miro::DEFAULT_LIFT_RAD.to_degrees(),
                proto::miro::DEFAULT_PITCH_RAD.to_degrees()
            );
        }
        RosTrack {
            joints: states.joints,
            poses,
            origin: topics.pose_origin,
        }
    }

    /// The robot's state for a frame at `stamp`: the latest joints and pose at or before
    /// it (or else the first ones), the pose placed on the field by the origin.
    pub fn state_at(&self, stamp: Stamp) -> RobotState {
        robot_state(
            latest(&self.joints, stamp).map(|(_, h)| h),
            latest(&self.poses, stamp),
            self.origin,
        )
    }
}

/// The robot's state from its latest head joints and odometry pose (the defaults where
/// there are none), the odometry placed on the field at `origin`.
pub fn robot_state(
    head: Option<HeadJoints>,
    pose: Option<(Stamp, OdomPose)>,
    origin: Pose2,
) -> RobotState {
    let head = head.unwrap_or_else(default_head);
    let (state_stamp, odom) = match pose {
        Some((s, p)) => (Some(s), p),
        None => (
            None,
            OdomPose {
                pose: Pose2 {
                    x_m: 0.0,
                    y_m: 0.0,
                    theta_rad: 0.0,
                },
                covariance: default_pose_covariance(),
            },
        ),
    };
    RobotState {
        state_stamp,
        pose: on_field(origin, odom.pose),
        pose_covariance: rotate_covariance(origin.theta_rad, odom.covariance),
        head,
    }
}

fn latest<T: Copy>(v: &[(Stamp, T)], stamp: Stamp) -> Option<(Stamp, T)> {
    let i = v.partition_point(|(s, _)| *s <= stamp);
    v.get(i.saturating_sub(1)).copied()
}

/// An odometry-frame pose on the field, for the odometry origin at `origin`.
fn on_field(origin: Pose2, p: Pose2) -> Pose2 {
    let (s, c) = origin.theta_rad.sin_cos();
    Pose2 {
        x_m: origin.x_m + c * p.x_m - s * p.y_m,
        y_m: origin.y_m + s * p.x_m + c * p.y_m,
        theta_rad: origin.theta_rad + p.theta_rad,
    }
}

/// The (x, y, θ) covariance turned by `theta_rad` with the frame: R Σ Rᵀ.
fn rotate_covariance(theta_rad: f64, c: [f64; 9]) -> [f64; 9] {
    let (s, co) = theta_rad.sin_cos();
    let r = [[co, -s, 0.0], [s, co, 0.0], [0.0, 0.0, 1.0]];
    let mut out = [0.0; 9];
    for i in 0..3 {
        for j in 0..3 {
            out[3 * i + j] = (0..3)
                .flat_map(|k| (0..3).map(move |l| (k, l)))
                .map(|(k, l)| r[i][k] * c[3 * k + l] * r[j][l])
                .sum();
        }
    }
    out
}

#[cfg(test)]
#[path = "ros_frames_tests.rs"]
mod recording_tests;

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn poses_are_placed_on_the_field_by_the_origin() {
        let origin = Pose2 {
            x_m: 1.0,
            y_m: 2.0,
            theta_rad: std::f64::consts::FRAC_PI_2,
        };
        let p = on_field(
            origin,
            Pose2 {
                x_m: 0.5,
                y_m: 0.0,
                theta_rad: 0.1,
            },
        );
        assert!((p.x_m - 1.0).abs() < 1e-12 && (p.y_m - 2.5).abs() < 1e-12);
        assert!((p.theta_rad - (std::f64::consts::FRAC_PI_2 + 0.1)).abs() < 1e-12);
        let c = rotate_covariance(
            std::f64::consts::FRAC_PI_2,
            [4.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.5],
        );
        assert!((c[0] - 1.0).abs() < 1e-12 && (c[4] - 4.0).abs() < 1e-12 && c[8] == 0.5);
    }

    #[test]
    fn the_pose_origin_flag_parses() {
        let p = parse_pose("-1.5, 2, 3.1").unwrap();
        assert_eq!((p.x_m, p.y_m, p.theta_rad), (-1.5, 2.0, 3.1));
        assert!(parse_pose("1,2").is_err());
        assert!(parse_pose("1,2,x").is_err());
        assert!(parse_pose("1,2,inf").is_err());
    }
}
