//! Tests of the ROS message decoders: round trips through the separate test encoder in both
//! encodings, CDR alignment, big-endian CDR, and truncated, oversized and damaged
//! messages.

#![allow(clippy::unwrap_used)]

use super::*;
use crate::io::ros_msg_fixtures as fx;
use approx::assert_relative_eq;
use proptest::prelude::*;

/// A decoder run on bytes, saying whether it decoded them.
type Decodes = fn(Encoding, &[u8]) -> bool;

const BOTH: [(Encoding, bool); 2] = [(Encoding::Ros1, false), (Encoding::Cdr, true)];

#[test]
fn compressed_images_round_trip_in_both_encodings() {
    for (enc, cdr) in BOTH {
        // A frame id of odd length puts the next string off its 4-byte boundary in CDR.
        let bytes = fx::compressed_image(cdr, (1_700_000_000, 5), "caml", "jpeg", &[1, 2, 3]);
        let m = decode_compressed_image(enc, &bytes).unwrap();
        assert_eq!(m.header.stamp, Stamp(1_700_000_000_000_000_005));
        assert_eq!(m.header.frame_id, "caml");
        assert_eq!(m.format, "jpeg");
        assert_eq!(m.data, vec![1, 2, 3]);
    }
}

#[test]
fn cdr_strings_are_padded_to_the_next_length() {
    // "ab" + NUL is 3 bytes: one byte of padding before the format's length.
    let bytes = fx::compressed_image(true, (1, 2), "ab", "png", &[9]);
    assert_eq!(bytes.len(), 4 + 8 + 4 + 3 + 1 + 4 + 4 + 4 + 1);
    let m = decode_compressed_image(Encoding::Cdr, &bytes).unwrap();
    assert_eq!(
        (m.header.frame_id.as_str(), m.format.as_str()),
        ("ab", "png")
    );
}

#[test]
fn joint_states_round_trip_and_give_the_miro_head() {
    for (enc, cdr) in BOTH {
        // Three names of odd lengths: the float64 sequences start off their 8-byte
        // boundary in CDR.
        let names = ["tilt", "lift", "yaw", "pitch"];
        let bytes = fx::joint_state(cdr, (10, 20), &names, &[0.0, 0.6, -0.1, -0.2]);
        let m = decode_joint_state(enc, &bytes).unwrap();
        assert_eq!(m.header.stamp, Stamp(10_000_000_020));
        assert_eq!(m.name, names);
        assert_eq!(m.position, vec![0.0, 0.6, -0.1, -0.2]);
        assert_eq!(m.velocity, vec![0.0; 4]);
        assert!(m.effort.is_empty());
        let head = m.miro_head().unwrap();
        assert_eq!(
            (head.lift_rad, head.yaw_rad, head.pitch_rad),
            (0.6, -0.1, -0.2)
        );
    }
}

#[test]
fn a_joint_state_without_the_neck_joints_gives_no_head() {
    let bytes = fx::joint_state(false, (1, 0), &["lift", "yaw"], &[0.5, 0.0]);
    let m = decode_joint_state(Encoding::Ros1, &bytes).unwrap();
    assert_eq!(m.miro_head(), None);
    // Fewer positions than names: the unnamed one is absent, not a panic.
    let bytes = fx::joint_state(false, (1, 0), &["lift", "yaw", "pitch"], &[0.5]);
    let m = decode_joint_state(Encoding::Ros1, &bytes).unwrap();
    assert_eq!(m.position_of("lift"), Some(0.5));
    assert_eq!(m.miro_head(), None);
}

#[test]
fn poses_and_odometry_round_trip() {
    for (enc, cdr) in BOTH {
        let p = decode_pose2d(enc, &fx::pose2d(cdr, 1.5, -0.5, 2.0)).unwrap();
        assert_eq!((p.x_m, p.y_m, p.theta_rad), (1.5, -0.5, 2.0));
        let o = decode_odometry(enc, &fx::odometry(cdr, (3, 4), (0.25, 0.75, -2.5), 0.01)).unwrap();
        assert_eq!(o.header.stamp, Stamp(3_000_000_004));
        assert_eq!(
            (o.header.frame_id.as_str(), o.child_frame_id.as_str()),
            ("odom", "base_link")
        );
        assert_relative_eq!(o.x_m, 0.25);
        assert_relative_eq!(o.y_m, 0.75);
        assert_relative_eq!(o.yaw_rad, -2.5, epsilon = 1e-12);
        assert_eq!(
            o.planar_covariance(),
            [0.01, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.01]
        );
    }
}

#[test]
fn big_endian_cdr_is_read() {
    // Pose2D: three float64, big-endian after a 00 00 encapsulation header.
    let mut bytes = vec![0, 0, 0, 0];
    for v in [1.0f64, 2.0, 3.0] {
        bytes.extend_from_slice(&v.to_be_bytes());
    }
    let p = decode_pose2d(Encoding::Cdr, &bytes).unwrap();
    assert_eq!((p.x_m, p.y_m, p.theta_rad), (1.0, 2.0, 3.0));
}

#[test]
fn every_truncation_is_an_error() {
    let messages: Vec<(Encoding, Vec<u8>, Decodes)> = BOTH
        .iter()
        .flat_map(|&(enc, cdr)| {
            [
                (
                    enc,
                    fx::compressed_image(cdr, (1, 2), "camr", "png", &[1, 2, 3, 4, 5]),
                    (|e, b: &[u8]| decode_compressed_image(e, b).is_ok()) as Decodes,
                ),
                (
                    enc,
                    fx::joint_state(cdr, (1, 2), &["lift", "yaw", "pitch"], &[0.1, 0.2, 0.3]),
                    |e, b| decode_joint_state(e, b).is_ok(),
                ),
                (enc, fx::pose2d(cdr, 1.0, 2.0, 3.0), |e, b| {
                    decode_pose2d(e, b).is_ok()
                }),
                (
                    enc,
                    fx::odometry(cdr, (1, 2), (1.0, 2.0, 0.5), 0.1),
                    |e, b| decode_odometry(e, b).is_ok(),
                ),
            ]
        })
        .collect();
    for (enc, bytes, decodes) in messages {
        assert!(decodes(enc, &bytes), "{enc:?} whole message");
        for cut in 0..bytes.len() {
            assert!(
                !decodes(enc, &bytes[..cut]),
                "{enc:?} cut at {cut} of {}",
                bytes.len()
            );
        }
    }
}

#[test]
fn an_absurd_length_is_refused_before_allocating() {
    for (enc, cdr) in BOTH {
        let mut e = fx::Enc::new(cdr);
        e.header(1, 2, "caml").string("jpeg").u32(u32::MAX);
        let err = decode_compressed_image(enc, &e.done()).unwrap_err();
        assert!(
            matches!(err, RosDecodeError::Truncated { field: "data", needed, .. } if needed == u64::from(u32::MAX)),
            "{err}"
        );
        let mut e = fx::Enc::new(cdr);
        e.header(1, 2, "").u32(u32::MAX);
        let err = decode_joint_state(enc, &e.done()).unwrap_err();
        assert!(
            matches!(err, RosDecodeError::Truncated { field: "name", .. }),
            "{err}"
        );
        let mut e = fx::Enc::new(cdr);
        e.header(1, 2, "").string_seq(&[]).u32(u32::MAX);
        let err = decode_joint_state(enc, &e.done()).unwrap_err();
        assert!(
            matches!(
                err,
                RosDecodeError::Truncated {
                    field: "position",
                    ..
                }
            ),
            "{err}"
        );
    }
}

#[test]
fn damaged_messages_say_what_is_wrong() {
    let mut image = fx::compressed_image(true, (1, 2), "caml", "jpeg", &[1]);
    image[1] = 3; // parameter-list CDR
    assert_eq!(
        decode_compressed_image(Encoding::Cdr, &image),
        Err(RosDecodeError::Encapsulation([0, 3]))
    );
    let mut image = fx::compressed_image(true, (1, 2), "caml", "jpeg", &[1]);
    image[4 + 8 + 4 + 4] = b'x'; // the frame id's NUL
    assert_eq!(
        decode_compressed_image(Encoding::Cdr, &image),
        Err(RosDecodeError::MissingNul {
            field: "header.frame_id"
        })
    );
    let mut image = fx::compressed_image(false, (1, 2), "caml", "jpeg", &[1]);
    image[4 * 4] = 0xff; // the frame id's first byte
    assert_eq!(
        decode_compressed_image(Encoding::Ros1, &image),
        Err(RosDecodeError::NotUtf8 {
            field: "header.frame_id"
        })
    );
    let mut pose = fx::pose2d(false, 1.0, 2.0, 3.0);
    pose.push(0);
    assert_eq!(
        decode_pose2d(Encoding::Ros1, &pose),
        Err(RosDecodeError::TrailingBytes(1))
    );
    let mut e = fx::Enc::new(true);
    e.u32(u32::MAX).u32(0).string("").string("jpeg").bytes(&[]);
    assert_eq!(
        decode_compressed_image(Encoding::Cdr, &e.done()),
        Err(RosDecodeError::NegativeStamp(-1))
    );
}

#[test]
fn schema_and_encoding_names() {
    for name in [
        "sensor_msgs/CompressedImage",
        "sensor_msgs/msg/CompressedImage",
    ] {
        assert_eq!(
            MessageType::of_schema_name(name),
            Some(MessageType::CompressedImage)
        );
    }
    assert_eq!(
        MessageType::of_schema_name("nav_msgs/msg/Odometry"),
        Some(MessageType::Odometry)
    );
    assert_eq!(MessageType::of_schema_name("sensor_msgs/Image"), None);
    assert_eq!(MessageType::of_schema_name("CompressedImage"), None);
    assert_eq!(Encoding::of_mcap("cdr"), Some(Encoding::Cdr));
    assert_eq!(Encoding::of_mcap("ros1"), Some(Encoding::Ros1));
    assert_eq!(Encoding::of_mcap("json"), None);
}

proptest! {
    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..200)) {
        for enc in [Encoding::Ros1, Encoding::Cdr] {
            let _ = decode_compressed_image(enc, &bytes);
            let _ = decode_joint_state(enc, &bytes);
            let _ = decode_pose2d(enc, &bytes);
            let _ = decode_odometry(enc, &bytes);
        }
    }

    #[test]
    fn images_round_trip(
        secs in 0u32..i32::MAX as u32,
        nsecs in 0u32..1_000_000_000,
        frame_id in "[a-z_/]{0,12}",
        format in "[a-z0-9; ]{0,20}",
        data in proptest::collection::vec(any::<u8>(), 0..64),
        cdr in any::<bool>(),
    ) {
        let enc = if cdr { Encoding::Cdr } else { Encoding::Ros1 };
        let bytes = fx::compressed_image(cdr, (secs, nsecs), &frame_id, &format, &data);
        let m = decode_compressed_image(enc, &bytes).unwrap();
        prop_assert_eq!(m.header.stamp, Stamp(u64::from(secs) * 1_000_000_000 + u64::from(nsecs)));
        prop_assert_eq!(m.header.frame_id, frame_id);
        prop_assert_eq!(m.format, format);
        prop_assert_eq!(m.data, data);
    }
}
