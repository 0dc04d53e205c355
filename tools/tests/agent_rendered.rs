//! The agent's recording and detection paths on frames the simulator rendered: a frame
//! recorded as a MiRo's ROS 2 bag would hold it and read back through the agent's MCAP
//! source, and the patterned ball found as the plain one is.

#![allow(clippy::unwrap_used)]

use proto::{Camera, Stamp};
use robot_agent::RosTopics;
use robot_agent::StageTimer;
use robot_agent::StoredFrame;
use robot_agent::ros_msg_fixtures as fx;
use robot_agent::{DetectorKind, choose_detector, load_models};
use robot_agent::{FrameSource, McapSource};
use std::path::PathBuf;
use tools::sim_source::{SimArgs, SimSource};
use vision::Detector;
use vision::DetectorConfig;
use vision::NoClock;
use vision::RgbImage;

const T0_S: u32 = 1_700_000_000;
const LEFT: &str = "/miro/sensors/caml/compressed";
const RIGHT: &str = "/miro/sensors/camr/compressed";
const JOINTS: &str = "/miro/sensors/kinematic_joints";
const IMAGE: &str = "sensor_msgs/CompressedImage";

fn ns(secs: u32, nsecs: u32) -> u64 {
    u64::from(secs) * 1_000_000_000 + u64::from(nsecs)
}

fn all_frames(path: PathBuf, topics: &RosTopics) -> Vec<StoredFrame> {
    let mut source = McapSource::open(path, topics).unwrap();
    let mut out = Vec::new();
    while let Some(f) = source.next_frame().unwrap() {
        out.push(f);
    }
    out
}

/// The pixel where a fresh agent finds the ball in `f`, if it does.
fn found_at(f: &StoredFrame) -> Option<[f64; 2]> {
    let models = load_models(None, None).unwrap();
    let config = robot_agent::PipelineConfig::default();
    let chosen = choose_detector(DetectorKind::Dissertation, &config.detector, None).unwrap();
    let mut agent =
        robot_agent::Agent::new("miro1", proto::Pitch::default(), config, models, chosen);
    let input = robot_agent::FrameInput {
        stamp: f.stamp,
        camera: f.camera,
        image: &f.image,
        pose: f.state.pose,
        pose_covariance: f.state.pose_covariance,
        head: f.state.head,
    };
    let mut timer = StageTimer::new();
    timer.start();
    let outcome = agent.on_frame(&input, &mut timer).unwrap();
    outcome
        .observation
        .and_then(|o| o.pixel)
        .map(|p| [p.u_px, p.v_px])
}

/// A frame rendered by the simulator in which the pipeline finds the ball where the
/// renderer put it, recorded as a MiRo's ROS 2 bag would hold it (PNG, joints, body pose)
/// and read back: the same image, stamp and state, and the ball found at the same pixel.
#[test]
fn the_pipeline_finds_the_ball_in_a_recorded_rendered_frame() {
    let start = Stamp(ns(T0_S, 0));
    let args = SimArgs {
        game: tools::sim_args::MatchArgs {
            scenario: "match".into(),
            seed: 1,
            team_size: None,
            duration_s: Some(20.0),
            start_ns: Some(start.0),
        },
        patterned_ball: false,
        camera_hz: 15.0,
        repeat: false,
    };
    let mut sim = SimSource::new("miro1", &args, start).unwrap();
    let truths = sim.truths();
    let (frame, pixel) = loop {
        let frame = sim
            .next_frame()
            .unwrap()
            .expect("a rendered frame with the ball found");
        let (_, _, truth) = truths.lock().unwrap().pop_front().unwrap();
        let Some(t) = truth else { continue };
        if !(t.in_frame && t.visible_fraction > 0.9 && t.radius_px > 6.0) {
            continue;
        }
        let (Some(centre), Some(p)) = (t.center_px, found_at(&frame)) else {
            continue;
        };
        if (p[0] - centre[0]).hypot(p[1] - centre[1]) <= t.radius_px {
            break (frame, p);
        }
    };
    let (secs, nsecs) = (
        (frame.stamp.0 / 1_000_000_000) as u32,
        (frame.stamp.0 % 1_000_000_000) as u32,
    );
    let png = robot_agent::encode_png(&frame.image).unwrap();
    let (topic, id) = match frame.camera {
        Camera::Left => (LEFT, "caml"),
        Camera::Right => (RIGHT, "camr"),
    };
    let (h, p) = (frame.state.head, frame.state.pose);
    let messages: Vec<fx::Msg> = vec![
        (
            JOINTS,
            "sensor_msgs/JointState",
            frame.stamp.0,
            fx::joint_state(
                true,
                (secs, nsecs),
                &["lift", "yaw", "pitch"],
                &[h.lift_rad, h.yaw_rad, h.pitch_rad],
            ),
        ),
        (
            "/miro/sensors/body_pose",
            "geometry_msgs/Pose2D",
            frame.stamp.0,
            fx::pose2d(true, p.x_m, p.y_m, p.theta_rad),
        ),
        (
            topic,
            IMAGE,
            frame.stamp.0,
            fx::compressed_image(true, (secs, nsecs), id, "png", &png),
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rendered.mcap");
    fx::write_bag(&path, true, &messages);
    let back = all_frames(path, &RosTopics::default());
    assert_eq!(back.len(), 1);
    let f = &back[0];
    assert_eq!((f.stamp, f.camera), (frame.stamp, frame.camera));
    assert_eq!(f.image.data(), frame.image.data());
    assert_eq!(
        (f.state.pose, f.state.head),
        (frame.state.pose, frame.state.head)
    );
    assert_eq!(found_at(f), Some(pixel));
}

/// Frames of the simulator's `seed-1-across` through miro1's cameras, with the ball's
/// centre and radius where it is in view.
fn rendered_frames(patterned: bool, captures: usize) -> Vec<(RgbImage, [f64; 2], f64)> {
    use sim::{CameraWorld, CameraWorldConfig, patterned_ball};
    let run = sim::run_scenario("seed-1-across", 1, &sim::SimConfig::default()).unwrap();
    let rig = sim::CameraRig::new(sim::LensModel::miro());
    let mut cfg = CameraWorldConfig::default();
    if patterned {
        cfg.ball_look = patterned_ball();
    }
    let world = CameraWorld::new(&run, &rig, cfg, 1);
    let times: Vec<f64> = world.frame_times().collect();
    let step = (times.len() / captures).max(1);
    let mut out = Vec::new();
    for (k, &t) in times.iter().enumerate().step_by(step).take(captures) {
        for (frame, truth) in world.capture("miro1", t, k as u64).frames {
            let Some(t) = truth.filter(|t| t.in_frame && t.visible_fraction > 0.9) else {
                continue;
            };
            let Some(c) = t.center_px else { continue };
            let image = RgbImage::new(frame.width, frame.height, frame.rgb).unwrap();
            out.push((image, c, t.radius_px));
        }
    }
    out
}

/// How many frames' most probable candidate is the ball.
fn found(frames: &[(RgbImage, [f64; 2], f64)], config: DetectorConfig) -> usize {
    let model = robot_agent::builtin::sim_calibration().unwrap().model;
    let detector = Detector::new(config).unwrap();
    let classifier = robot_agent::builtin::classifier(&config).unwrap();
    frames
        .iter()
        .filter(|(image, c, r)| {
            let found = detector
                .detect(image, Some(&model), classifier.as_ref(), &mut NoClock)
                .unwrap();
            found.first().is_some_and(|b| {
                let p = b.circle.center_px;
                b.probability >= 0.5 && (p[0] - c[0]).hypot(p[1] - c[1]) < 0.3 * r.max(4.0)
            })
        })
        .count()
}

#[test]
fn a_rendered_patterned_ball_is_found_as_the_plain_one_is() {
    let patterned = rendered_frames(true, 6);
    assert!(patterned.len() >= 10, "{} frames", patterned.len());
    let n = patterned.len();
    let config = DetectorConfig::default();
    assert!(found(&patterned, config) >= n - 1, "{n} frames");
    // Without the two-colour mask it is not found.
    let mut plain_only = config;
    plain_only.pattern.enabled = false;
    assert!(found(&patterned, plain_only) <= n / 4);
    // The plain ball is found as it always was.
    let plain = rendered_frames(false, 6);
    assert_eq!(found(&plain, config), plain.len());
}

/// The agent draws the random negative windows of labelled photos from its own copy of the
/// simulator's generator (the windows were first drawn from `sim::rng`): the simulator's
/// stream gives the values the agent's copy is tested against.
#[test]
fn the_simulators_stream_draws_what_the_agents_copy_draws() {
    let mut r = sim::Rng::stream(1, "labelled-negatives", 0);
    let got: Vec<u64> = (0..3).map(|_| r.next_u64()).collect();
    assert_eq!(
        got,
        [
            0xd1de_d22f_7406_6fc5,
            0x2f11_ae16_6ea6_7bb0,
            0x8b19_279b_f4bb_c944
        ]
    );
}
