//! The agent fed live by a robot's ROS topics over Zenoh, as a Zenoh ROS bridge publishes
//! them: a rendered MiRo frame as a ROS 2 `CompressedImage` (CDR), the head's
//! `JointState` and the body's `Pose2D`, published on a real loopback session; the agent
//! (`--source zenoh:ros2`) finds and projects the ball, and counts what it cannot decode.

#![allow(clippy::unwrap_used)]

use proto::net::{NetConfig, free_loopback_port};
use robot_agent::ros_msg_fixtures as fx;
use sim::CameraRig;
use sim::LensModel;
use sim::{CameraWorld, CameraWorldConfig};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The `robot-agent` command line, built by this package from the product's source.
const AGENT_CLI: &str = env!("CARGO_BIN_EXE_system-robot-agent");

#[tokio::test(flavor = "multi_thread")]
async fn a_live_robot_over_a_zenoh_ros_bridge_feeds_the_agent() {
    // A rendered frame with the ball in view, and the robot's readings at that moment.
    let cfg = sim::SimConfig {
        duration_s: Some(2.0),
        ..sim::SimConfig::default()
    };
    let run = sim::run_scenario("seed-1-across", 1, &cfg).unwrap();
    let rig = CameraRig::new(LensModel::miro());
    let world = CameraWorld::new(&run, &rig, CameraWorldConfig::default(), 1);
    let id = run.robots[0].id.clone();
    let capture = world.capture(&id, 1.0, 0);
    let (frame, truth) = &capture.frames[0];
    assert!(
        truth.as_ref().is_some_and(|t| t.in_frame),
        "the ball is in view"
    );
    let image = vision::RgbImage::new(frame.width, frame.height, frame.rgb.clone()).unwrap();
    let png = robot_agent::encode_png(&image).unwrap();
    let r = capture.reading;

    let port = free_loopback_port().unwrap();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let mut agent = Command::new(AGENT_CLI)
        .args([
            "run",
            "--robot-id",
            "miro1",
            "--source",
            "zenoh:ros2",
            "--offline",
            "--fast",
            "--listen",
            &endpoint,
            "--duration",
            "1.0",
        ])
        .env("RUST_LOG", "info,zenoh=warn")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let session = NetConfig::connecting(&endpoint).open().await.unwrap();
    let t0_s: u32 = 1_800_000_000;
    let started = Instant::now();
    let mut k: u32 = 0;
    // Publish until the agent has seen a second of frames and stops (bounded).
    while agent.try_wait().unwrap().is_none() && started.elapsed() < Duration::from_secs(60) {
        let stamp = (t0_s + k / 10, (k % 10) * 100_000_000);
        let joints = fx::joint_state(
            true,
            stamp,
            &["tilt", "lift", "yaw", "pitch"],
            &[0.0, r.head.lift_rad, r.head.yaw_rad, r.head.pitch_rad],
        );
        session
            .put("miro/sensors/kinematic_joints", joints)
            .await
            .unwrap();
        let pose = fx::pose2d(true, r.pose.x_m, r.pose.y_m, r.pose.theta_rad);
        session.put("miro/sensors/body_pose", pose).await.unwrap();
        let msg = fx::compressed_image(true, stamp, "caml", "png", &png);
        session
            .put("miro/sensors/caml/compressed", msg)
            .await
            .unwrap();
        // Something that is not a ROS message on the right camera's key: counted, skipped.
        session
            .put("miro/sensors/camr/compressed", vec![1u8, 2, 3])
            .await
            .unwrap();
        k += 1;
        tokio::time::sleep(Duration::from_millis(30)).await;
    }
    if agent.try_wait().unwrap().is_none() {
        agent.kill().unwrap();
        panic!("the agent did not stop after a second of frames");
    }
    let out = agent.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    let line = stdout
        .lines()
        .find(|l| l.starts_with("miro1: "))
        .unwrap_or_else(|| panic!("no summary: {stdout}\n{stderr}"));
    let words: Vec<&str> = line.split_whitespace().collect();
    let frames: u64 = words[1].parse().unwrap();
    let observations: u64 = words[3].parse().unwrap();
    assert!(frames >= 5, "{line}");
    // The same frame each time, with the readings it was rendered at: the ball is found
    // and projected onto the pitch in (nearly) every frame.
    assert!(observations * 10 >= frames * 8, "{line}\n{stderr}");
    // The right camera's garbage was counted, not taken for frames.
    let bad: u64 = stderr
        .lines()
        .find_map(|l| {
            l.split(" messages not decodable")
                .next()
                .filter(|_| l.contains("messages not decodable"))
        })
        .and_then(|head| head.rsplit(", ").next())
        .and_then(|n| n.trim().parse().ok())
        .unwrap_or_else(|| panic!("no count of undecodable messages: {stderr}"));
    assert!(bad >= frames, "{bad} undecodable, {frames} frames");
    session.close().await.unwrap();
}
