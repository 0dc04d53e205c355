//! `ball-lab evaluate` and `train --images --labels` as processes on a labelled folder
//! written here: frames rendered by the simulator (not photographs) with the renderer's
//! ball boxes as Pascal VOC and as YOLO labels.

#![allow(clippy::unwrap_used)]

use lab::labels::BallBox;
use sim::CameraRig;
use sim::LensModel;
use sim::{CameraWorld, CameraWorldConfig};
use sim::{SimConfig, run_scenario};
use std::path::Path;
use std::process::Command;
use vision::RgbImage;

/// The `robot-agent` command line, built by this package from the product's source.
const LAB_CLI: &str = env!("CARGO_BIN_EXE_system-ball-lab");

/// Renders frames of a simulated match into `dir/images`, with VOC labels in `dir/voc` and
/// YOLO labels (and a classes.txt) in `dir/yolo`; returns (frames with a ball, without).
fn write_folder(dir: &Path) -> (usize, usize) {
    for sub in ["images", "voc", "yolo"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
    }
    std::fs::write(dir.join("yolo/classes.txt"), "robot\nsports ball\n").unwrap();
    let cfg = SimConfig {
        duration_s: Some(6.0),
        ..SimConfig::default()
    };
    let run = run_scenario("match", 3, &cfg).unwrap();
    let rig = CameraRig::new(LensModel::miro());
    let cam = CameraWorldConfig {
        frame_rate_hz: 2.0,
        ..CameraWorldConfig::default()
    };
    let world = CameraWorld::new(&run, &rig, cam, 3);
    let (mut with_ball, mut without) = (0, 0);
    let ids: Vec<String> = run.robots.iter().map(|r| r.id.clone()).collect();
    for (k, t) in world.frame_times().enumerate() {
        for id in &ids {
            let capture = world.capture(id, t, k as u64);
            for (side, (frame, truth)) in capture.frames.iter().enumerate() {
                let ball = truth
                    .as_ref()
                    .and_then(|t| t.full_view_box_px(frame.width, frame.height))
                    .map(|[x0, y0, x1, y1]| BallBox {
                        x_min_px: x0,
                        y_min_px: y0,
                        x_max_px: x1,
                        y_max_px: y1,
                    });
                // A partly seen ball would be an unfair label: such frames are left out.
                let partly = truth.as_ref().is_some_and(|t| t.in_frame) && ball.is_none();
                if partly || (ball.is_none() && without >= 4) {
                    continue;
                }
                let name = format!("{id}-{k:03}-{side}");
                let image = RgbImage::new(frame.width, frame.height, frame.rgb.clone()).unwrap();
                let png = robot_agent::encode_png(&image).unwrap();
                std::fs::write(dir.join(format!("images/{name}.png")), png).unwrap();
                let balls: Vec<BallBox> = ball.into_iter().collect();
                let voc = lab::labels::voc::write_voc(
                    &format!("{name}.png"),
                    frame.width,
                    frame.height,
                    &balls,
                );
                std::fs::write(dir.join(format!("voc/{name}.xml")), voc).unwrap();
                let yolo: String = balls
                    .iter()
                    .map(|b| lab::labels::yolo::yolo_line(1, b, frame.width, frame.height) + "\n")
                    .collect();
                std::fs::write(dir.join(format!("yolo/{name}.txt")), yolo).unwrap();
                if ball.is_some() {
                    with_ball += 1;
                } else {
                    without += 1;
                }
            }
        }
    }
    std::fs::write(
        dir.join("sim.toml"),
        robot_agent::builtin::SIM_CALIBRATION_TOML,
    )
    .unwrap();
    (with_ball, without)
}

fn agent(args: &[&str]) -> String {
    let out = Command::new(LAB_CLI).args(args).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{args:?} failed: {stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

#[test]
fn evaluate_and_train_on_a_labelled_folder() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (with_ball, without) = write_folder(d);
    assert!(with_ball >= 12 && without >= 2, "{with_ball} {without}");
    let p = |s: &str| d.join(s).to_str().unwrap().to_owned();
    let mut recalls = Vec::new();
    for labels in ["voc", "yolo"] {
        let json = p(&format!("{labels}.json"));
        let plot = p(&format!("{labels}.png"));
        let stdout = agent(&[
            "evaluate",
            "--detector",
            "dissertation",
            "--images",
            &p("images"),
            "--labels",
            &p(labels),
            "--calibration",
            &p("sim.toml"),
            "--json",
            &json,
            "--plot",
            &plot,
        ]);
        assert!(
            stdout.contains("recall") && stdout.contains("20–40 px"),
            "{stdout}"
        );
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        assert_eq!(report["images_with_ball"], with_ball);
        assert_eq!(report["images"], with_ball + without);
        assert_eq!(report["bands"].as_array().unwrap().len(), 4);
        let recall = report["recall_published"].as_f64().unwrap();
        let precision = report["precision"].as_f64().unwrap();
        // The shipped detector finds rendered balls in well over 90 % of the frames where
        // the whole ball is seen; the floors leave room.
        assert!(recall >= 0.8, "recall {recall}: {stdout}");
        assert!(precision >= 0.8, "precision {precision}: {stdout}");
        let median = report["timing_ms"]["median"].as_f64().unwrap();
        assert!(median > 0.0);
        let png = std::fs::read(&plot).unwrap();
        assert!(png.starts_with(&[0x89, b'P', b'N', b'G']));
        recalls.push(recall);
    }
    // Both label formats describe the same boxes.
    assert_eq!(recalls[0], recalls[1]);

    // Without a names list, YOLO labels need --ball-class.
    std::fs::remove_file(d.join("yolo/classes.txt")).unwrap();
    let out = Command::new(LAB_CLI)
        .args(["evaluate", "--images", &p("images"), "--labels", &p("yolo")])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--ball-class"), "{stderr}");

    let model = p("model.json");
    let stdout = agent(&[
        "train",
        "--model",
        "hog-svm",
        "--images",
        &p("images"),
        "--labels",
        &p("yolo"),
        "--ball-class",
        "1",
        "--calibration",
        &p("sim.toml"),
        "--out",
        &model,
    ]);
    assert!(stdout.contains("held out"), "{stdout}");
    let m =
        vision::stages::svm::Model::from_json(&std::fs::read_to_string(&model).unwrap()).unwrap();
    assert_eq!(m.dim(), vision::stages::hog::HOG_LEN);

    // The trained model is used through --classifier, by evaluate and detect alike.
    let json = p("own-model.json");
    agent(&[
        "evaluate",
        "--detector",
        "dissertation",
        "--images",
        &p("images"),
        "--labels",
        &p("voc"),
        "--calibration",
        &p("sim.toml"),
        "--classifier",
        &model,
        "--json",
        &json,
    ]);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let recall = report["recall_published"].as_f64().unwrap();
    assert!(recall >= 0.5, "recall with the trained model {recall}");
    let lines = agent(&[
        "detect",
        "--detector",
        "dissertation",
        "--images",
        &p("images"),
        "--classifier",
        &model,
    ]);
    assert_eq!(lines.lines().count(), with_ball + without, "{lines}");

    // A file that is not a model is refused, naming it.
    std::fs::write(d.join("broken.json"), "{\"not\": \"a model\"}").unwrap();
    let out = Command::new(LAB_CLI)
        .args([
            "detect",
            "--images",
            &p("images"),
            "--classifier",
            &p("broken.json"),
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("broken.json") && stderr.contains("not a model"),
        "{stderr}"
    );
}
