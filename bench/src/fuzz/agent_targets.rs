//! robot-agent: the ROS 1 and ROS 2 message decoders, the VOC and YOLO label parsers, and
//! PNG and JPEG decoding, each on mutated valid inputs.

use vision::RgbImage;

use lab::labels::BallBox;
use lab::labels::BallNames;
use lab::labels::voc::{parse_voc, write_voc};
use lab::labels::yolo::{
    BallClassIds, parse_classes_txt, parse_data_yaml_names, parse_yolo, yolo_line,
};
use robot_agent::ros_msg::{self, Encoding};
use robot_agent::ros_msg_fixtures as ros;

use super::{Target, Verdict};

pub fn targets() -> Vec<Target> {
    vec![
        ros_target("agent_ros1", Encoding::Ros1),
        ros_target("agent_ros2", Encoding::Cdr),
        voc_target(),
        yolo_target(),
        image_target("agent_png", png_seeds()),
        image_target("agent_jpeg", jpeg_seeds()),
    ]
}

/// Every message type's decoder on each input; accepted when one of them decodes it.
fn ros_target(name: &'static str, encoding: Encoding) -> Target {
    let cdr = encoding == Encoding::Cdr;
    let seeds = vec![
        ros::compressed_image(
            cdr,
            (12, 500),
            "camera_left",
            "jpeg",
            &[0xff, 0xd8, 1, 2, 3],
        ),
        ros::joint_state(
            cdr,
            (12, 7),
            &["tilt", "lift", "yaw", "pitch"],
            &[0.0, 0.5, -0.1, 0.05],
        ),
        ros::pose2d(cdr, 0.5, -0.25, 1.0),
        ros::odometry(cdr, (13, 0), (0.5, -0.25, 1.0), 1e-3),
    ];
    Target::new(name, seeds, move |bytes| {
        let image = ros_msg::decode_compressed_image(encoding, bytes).is_ok();
        let joints = ros_msg::decode_joint_state(encoding, bytes);
        if let Ok(j) = &joints {
            j.miro_head();
        }
        let pose = ros_msg::decode_pose2d(encoding, bytes);
        if let Ok(p) = &pose {
            p.pose();
        }
        let odometry = ros_msg::decode_odometry(encoding, bytes);
        if let Ok(o) = &odometry {
            o.pose();
            o.planar_covariance();
        }
        Verdict::of(image || joints.is_ok() || pose.is_ok() || odometry.is_ok())
    })
}

fn ball(x_min_px: f64, y_min_px: f64, size_px: f64) -> BallBox {
    BallBox {
        x_min_px,
        y_min_px,
        x_max_px: x_min_px + size_px,
        y_max_px: y_min_px + size_px,
    }
}

fn voc_target() -> Target {
    let balls = [ball(10.5, 20.5, 30.0), ball(300.5, 200.5, 12.0)];
    let seeds = vec![
        write_voc("frame_0001.jpg", 640, 480, &balls).into_bytes(),
        write_voc("empty.png", 320, 240, &[]).into_bytes(),
    ];
    let names = BallNames::default();
    Target::new("agent_voc", seeds, move |bytes| {
        let text = String::from_utf8_lossy(bytes);
        Verdict::of(parse_voc(&text, "fuzz.xml", &names).is_ok())
    })
}

/// A label file, or a class list, or a data.yaml: the first byte picks which.
fn yolo_target() -> Target {
    let b = ball(10.5, 20.5, 30.0);
    let labels = format!(
        "{}\n{}\n",
        yolo_line(0, &b, 640, 480),
        yolo_line(2, &b, 640, 480)
    );
    let seeds = vec![
        [b"0".as_slice(), labels.as_bytes()].concat(),
        b"1ball\nperson\nsports ball\n".to_vec(),
        b"2names:\n  0: ball\n  1: goal\n".to_vec(),
        b"2names: ['ball', 'goal']\nnc: 2\n".to_vec(),
    ];
    let names = BallNames::default();
    let ids = BallClassIds::from_names(&["ball".to_owned(), "goal".to_owned()], &names);
    Target::new("agent_yolo", seeds, move |bytes| {
        let Some((&kind, rest)) = bytes.split_first() else {
            return Verdict::Rejected;
        };
        let text = String::from_utf8_lossy(rest);
        match kind % 3 {
            0 => Verdict::of(parse_yolo(&text, "fuzz.txt", 640, 480, &ids).is_ok()),
            1 => {
                let classes = parse_classes_txt(&text);
                BallClassIds::from_names(&classes, &names);
                Verdict::of(!classes.is_empty())
            }
            _ => Verdict::of(parse_data_yaml_names(&text).is_some_and(|n| {
                BallClassIds::from_names(&n, &names);
                true
            })),
        }
    })
}

/// A small test card: a gradient with a bright disc.
fn card(width: u32, height: u32) -> Vec<u8> {
    let mut data = Vec::with_capacity((width * height * 3) as usize);
    for y in 0..height {
        for x in 0..width {
            let (dx, dy) = (x as f64 - 6.0, y as f64 - 5.0);
            let disc = dx * dx + dy * dy < 9.0;
            let g = (x * 255 / width.max(1)) as u8;
            data.extend_from_slice(&if disc {
                [250, 200, 20]
            } else {
                [g, 90, 255 - g]
            });
        }
    }
    data
}

fn png_seeds() -> Vec<Vec<u8>> {
    [(16, 12), (3, 2)]
        .into_iter()
        .filter_map(|(w, h)| RgbImage::new(w, h, card(w, h)).ok())
        .filter_map(|img| robot_agent::encode_png(&img).ok())
        .collect()
}

fn jpeg_seeds() -> Vec<Vec<u8>> {
    [(16u16, 12u16, 90u8), (9, 7, 40)]
        .into_iter()
        .filter_map(|(w, h, q)| {
            let mut bytes = Vec::new();
            let rgb = card(u32::from(w), u32::from(h));
            jpeg_encoder::Encoder::new(&mut bytes, q)
                .encode(&rgb, w, h, jpeg_encoder::ColorType::Rgb)
                .ok()
                .map(|()| bytes)
        })
        .collect()
}

fn image_target(name: &'static str, seeds: Vec<Vec<u8>>) -> Target {
    Target::new(name, seeds, |bytes| {
        let rgb = robot_agent::decode_rgb(bytes).is_ok();
        let gray = robot_agent::decode_gray(bytes).is_ok();
        assert_eq!(rgb, gray, "RGB and grey decoding disagree");
        Verdict::of(rgb)
    })
}
