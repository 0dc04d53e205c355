//! ROS recordings written with the `mcap` writer and read back through `--source mcap:`:
//! both encodings, frame order and stamps, the joints and pose attached, the defaults
//! without them, and a corrupt message reported and passed over. (The ball found on a
//! rendered frame that went through a ROS 2 recording is a system test's.)

#![allow(clippy::unwrap_used)]

use super::*;
use crate::runtime::source::{FrameSource, McapSource};
use std::path::PathBuf;
use vision::image::RgbImage;

use crate::io::ros_msg_fixtures as fx;

const T0_S: u32 = 1_700_000_000;

fn ns(secs: u32, nsecs: u32) -> u64 {
    u64::from(secs) * 1_000_000_000 + u64::from(nsecs)
}

/// An orange disc on green, as PNG.
fn disc_png(cx: u32) -> Vec<u8> {
    let (w, h) = (64u32, 48u32);
    let mut rgb = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let inside = (x as f64 - f64::from(cx)).hypot(y as f64 - 24.0) < 8.0;
            rgb.extend_from_slice(if inside {
                &[250, 120, 20]
            } else {
                &[30, 140, 40]
            });
        }
    }
    crate::io::image_io::encode_png(&RgbImage::new(w, h, rgb).unwrap()).unwrap()
}

const LEFT: &str = "/miro/sensors/caml/compressed";
const RIGHT: &str = "/miro/sensors/camr/compressed";
const JOINTS: &str = "/miro/sensors/kinematic_joints";
const IMAGE: &str = "sensor_msgs/CompressedImage";

fn joints(cdr: bool, at: (u32, u32), lift: f64) -> Vec<u8> {
    fx::joint_state(
        cdr,
        at,
        &["tilt", "lift", "yaw", "pitch"],
        &[0.0, lift, 0.2, -0.1],
    )
}

fn image(cdr: bool, at: (u32, u32), frame_id: &str, cx: u32) -> Vec<u8> {
    fx::compressed_image(cdr, at, frame_id, "png", &disc_png(cx))
}

fn all_frames(path: PathBuf, topics: &RosTopics) -> Vec<crate::runtime::frame::StoredFrame> {
    let mut source = McapSource::open(path, topics).unwrap();
    let mut out = Vec::new();
    while let Some(c) = source.next_frame().unwrap() {
        out.push(c);
    }
    out
}

/// A MiRo's recording in either encoding: frames in capture order (not file order), header
/// stamps (the log time where the header's is zero), the latest joints and pose at or
/// before each frame, and a damaged image and an unused topic passed over.
#[test]
fn miro_recordings_are_read_in_both_encodings() {
    let dir = tempfile::tempdir().unwrap();
    for cdr in [false, true] {
        let path = dir.path().join(format!("miro-{cdr}.mcap"));
        let mut corrupt = image(cdr, (T0_S, 300), "caml", 20);
        corrupt.truncate(corrupt.len() / 2);
        let messages: Vec<fx::Msg> = vec![
            (
                "/miro/sensors/body_pose",
                "geometry_msgs/Pose2D",
                ns(T0_S, 0),
                fx::pose2d(cdr, 0.5, 0.0, 0.0),
            ),
            (
                JOINTS,
                "sensor_msgs/JointState",
                ns(T0_S, 0),
                joints(cdr, (T0_S, 0), 0.5),
            ),
            // Written after the later frame: the source orders by capture stamp.
            (
                RIGHT,
                IMAGE,
                ns(T0_S, 250),
                image(cdr, (T0_S, 200), "camr", 40),
            ),
            (
                LEFT,
                IMAGE,
                ns(T0_S, 150),
                image(cdr, (T0_S, 100), "caml", 20),
            ),
            (
                JOINTS,
                "sensor_msgs/JointState",
                ns(T0_S, 150),
                joints(cdr, (T0_S, 150), 0.6),
            ),
            (
                "/miro/sensors/body_pose",
                "geometry_msgs/Pose2D",
                ns(T0_S, 150),
                fx::pose2d(cdr, 0.7, 0.1, 0.2),
            ),
            (LEFT, IMAGE, ns(T0_S, 300), corrupt),
            // A zero header stamp: the log time is the capture time.
            (LEFT, IMAGE, ns(T0_S, 400), image(cdr, (0, 0), "caml", 30)),
            (
                "/miro/sensors/package",
                "std_msgs/UInt8",
                ns(T0_S, 400),
                vec![1, 2, 3],
            ),
        ];
        fx::write_bag(&path, cdr, &messages);
        let read = crate::runtime::frames_io::read_mcap(&path, &RosTopics::default()).unwrap();
        assert_eq!(read.skipped.len(), 1, "{:?}", read.skipped);
        assert!(
            read.skipped
                .keys()
                .all(|k| k.starts_with(LEFT) && k.contains("remain"))
        );
        assert_eq!(read.ros.ignored.get("/miro/sensors/package"), Some(&1));
        let frames = all_frames(path, &RosTopics::default());
        let stamps: Vec<u64> = frames.iter().map(|f| f.stamp.0).collect();
        assert_eq!(stamps, vec![ns(T0_S, 100), ns(T0_S, 200), ns(T0_S, 400)]);
        let cameras: Vec<Camera> = frames.iter().map(|f| f.camera).collect();
        assert_eq!(cameras, vec![Camera::Left, Camera::Right, Camera::Left]);
        assert_eq!(
            (frames[0].image.width(), frames[0].image.height()),
            (64, 48)
        );
        // The first frame predates the second joint state and pose; the others follow them.
        assert_eq!(frames[0].state.head.lift_rad, 0.5);
        assert_eq!(frames[0].state.pose.x_m, 0.5);
        assert_eq!(frames[1].state.head.lift_rad, 0.6);
        assert_eq!(frames[1].state.head.yaw_rad, 0.2);
        assert_eq!(frames[1].state.head.pitch_rad, -0.1);
        assert_eq!(frames[1].state.pose.x_m, 0.7);
        assert_eq!(frames[1].state.pose.theta_rad, 0.2);
        assert_eq!(frames[1].state.state_stamp, Some(Stamp(ns(T0_S, 150))));
        assert_eq!(frames[2].state.pose.y_m, 0.1);
        assert!(frames[2].state.pose_covariance[0] > 0.0);
    }
}

/// Odometry instead of `Pose2D`, topics renamed on the command line, and the odometry's
/// origin placed on the field.
#[test]
fn odometry_and_configured_topics_are_used() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("odom.mcap");
    let messages: Vec<fx::Msg> = vec![
        (
            "/r1/odom",
            "nav_msgs/Odometry",
            ns(T0_S, 0),
            fx::odometry(true, (T0_S, 0), (1.0, 0.0, 0.5), 0.04),
        ),
        (
            "/r1/left",
            IMAGE,
            ns(T0_S, 10),
            image(true, (T0_S, 10), "l", 20),
        ),
        (
            "/r1/right",
            IMAGE,
            ns(T0_S, 10),
            image(true, (T0_S, 10), "r", 20),
        ),
        // Not a configured topic any more.
        (
            LEFT,
            IMAGE,
            ns(T0_S, 20),
            image(true, (T0_S, 20), "caml", 20),
        ),
    ];
    fx::write_bag(&path, true, &messages);
    let topics = RosTopics {
        left_topic: "/r1/left".into(),
        right_topic: "/r1/right".into(),
        pose_topic: vec!["/r1/pose".into(), "/r1/odom".into()],
        pose_origin: Pose2 {
            x_m: -2.0,
            y_m: 1.0,
            theta_rad: std::f64::consts::PI,
        },
        ..RosTopics::default()
    };
    let frames = all_frames(path, &topics);
    assert_eq!(frames.len(), 2);
    let s = frames[0].state;
    assert!((s.pose.x_m + 3.0).abs() < 1e-9 && (s.pose.y_m - 1.0).abs() < 1e-9);
    assert!((s.pose.theta_rad - (std::f64::consts::PI + 0.5)).abs() < 1e-9);
    assert!((s.pose_covariance[0] - 0.04).abs() < 1e-12);
    // No joint states: the default head.
    assert_eq!(s.head.lift_rad, proto::miro::DEFAULT_LIFT_RAD);
}

/// A recording with images only: the default head and the origin pose, not a refusal.
#[test]
fn images_alone_use_the_defaults() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("images.mcap");
    fx::write_bag(
        &path,
        false,
        &[(
            LEFT,
            IMAGE,
            ns(T0_S, 0),
            image(false, (T0_S, 5), "caml", 20),
        )],
    );
    let frames = all_frames(path, &RosTopics::default());
    assert_eq!(frames.len(), 1);
    assert_eq!(frames[0].stamp, Stamp(ns(T0_S, 5)));
    assert_eq!(frames[0].state.state_stamp, None);
    assert_eq!(frames[0].state.pose.x_m, 0.0);
    assert_eq!(
        frames[0].state.head.pitch_rad,
        proto::miro::DEFAULT_PITCH_RAD
    );
}

/// A topic with the wrong type is reported, not misread.
#[test]
fn a_camera_topic_of_another_type_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("wrong.mcap");
    fx::write_bag(
        &path,
        true,
        &[(LEFT, "sensor_msgs/Image", ns(T0_S, 0), vec![0; 40])],
    );
    let read = crate::runtime::frames_io::read_mcap(&path, &RosTopics::default()).unwrap();
    assert!(read.images.is_empty());
    let why: Vec<&String> = read.skipped.keys().collect();
    assert_eq!(why.len(), 1);
    assert!(why[0].contains("sensor_msgs/msg/Image"), "{why:?}");
}

/// The project's own JSON layout reads as before, unaffected by the ROS topics.
#[test]
fn json_recordings_still_read() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("json.mcap");
    let png = disc_png(20);
    let frame = crate::runtime::frame::StoredFrame {
        stamp: Stamp(ns(T0_S, 9)),
        camera: Camera::Right,
        image: crate::io::image_io::decode_rgb(&png).unwrap(),
        state: crate::runtime::frame::RobotState {
            state_stamp: Some(Stamp(ns(T0_S, 9))),
            pose: Pose2 {
                x_m: 1.0,
                y_m: 2.0,
                theta_rad: 0.5,
            },
            pose_covariance: [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-4],
            head: fx_head(),
        },
    };
    let mut w = crate::runtime::frames_io::McapFrameWriter::create(&path).unwrap();
    w.write(&frame).unwrap();
    w.finish().unwrap();
    let back = all_frames(path, &RosTopics::default());
    assert_eq!(back.len(), 1);
    assert_eq!((back[0].stamp, back[0].camera), (frame.stamp, frame.camera));
    assert_eq!(back[0].state, frame.state);
}

fn fx_head() -> HeadJoints {
    HeadJoints {
        lift_rad: 0.4,
        yaw_rad: 0.1,
        pitch_rad: -0.2,
    }
}
