//! `ball-lab detect` as a process, on a folder of photos with no index: a ball rendered
//! by the simulator, the same view without it and a file that is not an image; camera
//! flags and a calibration of another size.

#![allow(clippy::unwrap_used)]

mod common;
use common::halved;
use proto::Pose2;
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};
use vision::RgbImage;

/// The `robot-agent` command line, built by this package from the product's source.
const LAB_CLI: &str = env!("CARGO_BIN_EXE_system-ball-lab");

/// The simulated MiRo's left camera at the centre spot, looking along the pitch, with the
/// ball `ball_m` ahead (or none): the photo and the ball's centre and radius in it.
fn rendered(ball_m: Option<[f64; 2]>) -> (RgbImage, Option<([f64; 2], f64)>) {
    let rig = sim::CameraRig::new(sim::LensModel::miro());
    let mut scene = sim::Scene::default();
    scene.ball_m = ball_m.map(|[x, y]| [x, y, scene.pitch.ball_radius_m]);
    let [(frame, truth), _] =
        sim::render_robot_cameras(&rig, &scene, Pose2::default(), sim::default_head(), 7);
    let truth = truth
        .filter(|t| t.in_frame && t.visible_fraction > 0.9)
        .and_then(|t| Some((t.center_px?, t.radius_px)));
    let image = RgbImage::new(frame.width, frame.height, frame.rgb).unwrap();
    (image, truth)
}

fn write_png(path: &Path, image: &RgbImage) {
    std::fs::write(path, robot_agent::encode_png(image).unwrap()).unwrap();
}

fn detect(args: &[&str]) -> Output {
    Command::new(LAB_CLI)
        .arg("detect")
        // Rendered MiRo frames: the dissertation's colour path, tuned to the simulated ball.
        .args(["--detector", "dissertation"])
        .args(args)
        .output()
        .unwrap()
}

fn lines(stdout: &[u8]) -> Vec<Value> {
    String::from_utf8_lossy(stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn published(line: &Value) -> Vec<&Value> {
    line["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["published"] == true)
        .collect()
}

#[test]
fn a_folder_of_photos_gives_a_line_per_photo_and_counts_the_bad_one() {
    let dir = tempfile::tempdir().unwrap();
    let photos = dir.path().join("photos");
    std::fs::create_dir(&photos).unwrap();
    let (ball, truth) = rendered(Some([0.8, 0.05]));
    let (centre, radius) = truth.expect("the ball is in the left camera's view");
    write_png(&photos.join("ball.png"), &ball);
    write_png(&photos.join("empty.png"), &rendered(None).0);
    std::fs::write(photos.join("broken.png"), b"not an image at all").unwrap();
    std::fs::write(photos.join("notes.txt"), b"left alone").unwrap();
    let overlays = dir.path().join("overlays");
    let calibration = dir.path().join("sim.toml");
    std::fs::write(&calibration, robot_agent::builtin::SIM_CALIBRATION_TOML).unwrap();
    let photos_arg = photos.to_str().unwrap();

    for camera in [
        vec![],
        vec!["--calibration", calibration.to_str().unwrap()],
        // The fisheye's pinhole part: close enough near the image centre, where the ball is.
        vec!["--camera", "pinhole:344.7,343.7,322.2,177.9"],
    ] {
        let mut args = vec![
            "--images",
            photos_arg,
            "--overlays",
            overlays.to_str().unwrap(),
        ];
        args.extend(&camera);
        let out = detect(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "a bad photo fails the run: {stderr}");
        assert!(stderr.contains("1 of 3 photos"), "{stderr}");
        let lines = lines(&out.stdout);
        let files: Vec<&str> = lines.iter().map(|l| l["file"].as_str().unwrap()).collect();
        assert_eq!(files, ["ball.png", "broken.png", "empty.png"], "{camera:?}");
        let found = &lines[0];
        assert_eq!(
            (found["width_px"].as_u64(), found["height_px"].as_u64()),
            (Some(640), Some(360))
        );
        assert!(found["time_ms"].as_f64().unwrap() > 0.0);
        let ball = published(found);
        assert_eq!(ball.len(), 1, "{camera:?}: {found}");
        let (u, v) = (
            ball[0]["u_px"].as_f64().unwrap(),
            ball[0]["v_px"].as_f64().unwrap(),
        );
        assert!(
            (u - centre[0]).hypot(v - centre[1]) < 0.3 * radius.max(4.0),
            "{camera:?}: found at ({u}, {v}), the ball is at {centre:?}"
        );
        let r = ball[0]["radius_px"].as_f64().unwrap();
        assert!(
            (r - radius).abs() < 0.35 * radius,
            "{camera:?}: radius {r}, truly {radius}"
        );
        assert!(ball[0]["probability"].as_f64().unwrap() >= 0.5);
        assert!(ball[0]["rejection"].is_null());
        for c in found["candidates"].as_array().unwrap() {
            assert_eq!(c["published"] == true, c["rejection"].is_null(), "{c}");
        }
        assert!(lines[1]["error"].as_str().unwrap().contains("broken.png"));
        assert!(published(&lines[2]).is_empty(), "{camera:?}: {}", lines[2]);
        assert!(overlays.join("ball.png").is_file() && overlays.join("empty.png").is_file());
    }

    // Without the bad photo the run succeeds, writing to a file.
    std::fs::remove_file(photos.join("broken.png")).unwrap();
    let jsonl = dir.path().join("out.jsonl");
    let out = detect(&["--images", photos_arg, "--out", jsonl.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.stdout.is_empty());
    assert_eq!(lines(&std::fs::read(&jsonl).unwrap()).len(), 2);
    // The overlays may not go into the photos' folder.
    let out = detect(&["--images", photos_arg, "--overlays", photos_arg]);
    assert!(!out.status.success());
}

#[test]
fn photos_in_event_folders_become_label_files_to_correct() {
    let dir = tempfile::tempdir().unwrap();
    let photos = dir.path().join("photos");
    for event in ["e1", "e2"] {
        std::fs::create_dir_all(photos.join(event)).unwrap();
    }
    let (ball, truth) = rendered(Some([0.8, 0.05]));
    let (centre, radius) = truth.expect("the ball is in the left camera's view");
    write_png(&photos.join("e1/ball.png"), &ball);
    write_png(&photos.join("e2/empty.png"), &rendered(None).0);
    let yolo = dir.path().join("yolo");
    let out = detect(&[
        "--images",
        photos.to_str().unwrap(),
        "--write-labels",
        "yolo",
        yolo.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let files: Vec<String> = lines(&out.stdout)
        .iter()
        .map(|l| l["file"].as_str().unwrap().to_string())
        .collect();
    assert_eq!(
        files,
        ["e1/ball.png", "e2/empty.png"],
        "subfolders are searched"
    );
    // The ball's label: class 0, its box centred on the ball.
    let label = std::fs::read_to_string(yolo.join("e1/ball.txt")).unwrap();
    let v: Vec<f64> = label
        .split_whitespace()
        .map(|x| x.parse().unwrap())
        .collect();
    assert_eq!(v.len(), 5, "{label}");
    assert_eq!(v[0], 0.0);
    let (u, w) = (v[1] * 640.0 - 0.5, v[3] * 640.0);
    assert!((u - centre[0]).abs() < 0.3 * radius.max(4.0), "{label}");
    assert!((0.5 * w - radius).abs() < 0.35 * radius, "{label}");
    assert_eq!(
        std::fs::read_to_string(yolo.join("e2/empty.txt")).unwrap(),
        ""
    );
    assert_eq!(
        std::fs::read_to_string(yolo.join("classes.txt")).unwrap(),
        "ball\n"
    );
    let review = std::fs::read_to_string(yolo.join("review.csv")).unwrap();
    let rows: Vec<&str> = review.lines().collect();
    assert_eq!(rows.len(), 3, "{review}");
    assert!(rows[0].starts_with("photo,uncertainty"));

    // VOC into a folder where a person already corrected one photo: theirs is kept.
    let voc = dir.path().join("voc");
    std::fs::create_dir_all(voc.join("e2")).unwrap();
    std::fs::write(voc.join("e2/empty.xml"), "corrected by hand").unwrap();
    let out = detect(&[
        "--images",
        photos.to_str().unwrap(),
        "--write-labels",
        "voc",
        voc.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("1 existing one kept"), "{stderr}");
    let xml = std::fs::read_to_string(voc.join("e1/ball.xml")).unwrap();
    assert!(xml.contains("<filename>ball.png</filename>") && xml.contains("<name>ball</name>"));
    assert_eq!(
        std::fs::read_to_string(voc.join("e2/empty.xml")).unwrap(),
        "corrected by hand"
    );
    // A format nobody reads is refused before any photo is looked at.
    let out = detect(&[
        "--images",
        photos.to_str().unwrap(),
        "--write-labels",
        "coco",
        voc.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("yolo or voc"));
}

#[test]
fn a_calibration_of_another_size_is_an_error_unless_rescaled() {
    let dir = tempfile::tempdir().unwrap();
    let photos = dir.path().join("photos");
    std::fs::create_dir(&photos).unwrap();
    let (ball, truth) = rendered(Some([0.8, 0.05]));
    let (centre, _) = truth.unwrap();
    write_png(&photos.join("half.png"), &halved(&ball));
    let calibration = dir.path().join("sim.toml");
    std::fs::write(&calibration, robot_agent::builtin::SIM_CALIBRATION_TOML).unwrap();
    let base = [
        "--images",
        photos.to_str().unwrap(),
        "--calibration",
        calibration.to_str().unwrap(),
    ];
    let out = detect(&base);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("640×360") && stderr.contains("320×180") && stderr.contains("rescale"),
        "{stderr}"
    );
    let out = detect(&[&base[..], &["--rescale-calibration"]].concat());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning") && stderr.contains("scaled to 320×180"),
        "{stderr}"
    );
    let lines = lines(&out.stdout);
    let ball = published(&lines[0]);
    assert_eq!(ball.len(), 1, "{}", lines[0]);
    let (u, v) = (
        ball[0]["u_px"].as_f64().unwrap(),
        ball[0]["v_px"].as_f64().unwrap(),
    );
    let (cu, cv) = ((centre[0] + 0.5) / 2.0 - 0.5, (centre[1] + 0.5) / 2.0 - 0.5);
    assert!(
        (u - cu).hypot(v - cv) < 2.0,
        "({u}, {v}) against ({cu}, {cv})"
    );
    // A malformed camera flag is refused before anything runs.
    let out = detect(&[
        "--images",
        photos.to_str().unwrap(),
        "--camera",
        "pinhole:1,2",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("pinhole:FX,FY,CX,CY"));
}
