//! The labelling teacher through `robot-agent` as a process, on real photos with no label
//! files: `detect --teacher --write-labels` and `train` on photos nobody labelled, and
//! what a broken teacher file or an empty folder says.

#![allow(clippy::unwrap_used)]

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The `robot-agent` command line, built by this package from the product's source.
const LAB_CLI: &str = env!("CARGO_BIN_EXE_system-ball-lab");

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

fn agent(args: &[&str]) -> Output {
    Command::new(LAB_CLI).args(args).output().unwrap()
}

/// Real photos without labels: OpenCV's football photo and two onboard MSL photos.
fn unlabelled_photos(dir: &Path) -> PathBuf {
    let photos = dir.join("photos");
    std::fs::create_dir_all(photos.join("msl")).unwrap();
    std::fs::copy(
        repo("tests/data/real-balls/images/messi5.jpg"),
        photos.join("messi5.jpg"),
    )
    .unwrap();
    for f in [
        "20190606/r4/cam0_20190606_212540.jpg",
        "20240222/r14/cam0_20240222_201526.jpg",
    ] {
        let name = Path::new(f).file_name().unwrap();
        std::fs::copy(
            repo(&format!("tests/data/msl-balls/{f}")),
            photos.join("msl").join(name),
        )
        .unwrap();
    }
    photos
}

/// `detect --teacher` (its quick pass) on `photos`, YOLO labels into `labels`.
fn teacher_labels(photos: &Path, labels: &Path) -> Output {
    agent(&[
        "detect",
        "--images",
        photos.to_str().unwrap(),
        "--teacher",
        "--teacher-passes",
        "quick",
        "--write-labels",
        "yolo",
        labels.to_str().unwrap(),
    ])
}

#[test]
fn the_teacher_labels_real_photos_for_a_labelling_tool() {
    let dir = tempfile::tempdir().unwrap();
    let photos = unlabelled_photos(dir.path());
    let labels = dir.path().join("labels");
    let out = teacher_labels(&photos, &labels);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("the teacher labelled 3 photos"), "{stderr}");
    let lines: Vec<Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 3);
    // The football of messi5.jpg (548x342): our hand label is x 338-387, y 289-336.
    let yolo = std::fs::read_to_string(labels.join("messi5.txt")).unwrap();
    let ball: Vec<f64> = yolo
        .lines()
        .next()
        .expect("a ball line")
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(ball[0], 0.0);
    let (cx, cy) = (ball[1] * 548.0, ball[2] * 342.0);
    assert!(
        (338.0..387.0).contains(&cx) && (289.0..336.0).contains(&cy),
        "{yolo}"
    );
    assert_eq!(
        std::fs::read_to_string(labels.join("classes.txt")).unwrap(),
        "ball\n"
    );
    assert!(
        labels
            .join("msl")
            .join("cam0_20190606_212540.txt")
            .is_file()
    );
    assert!(labels.join("doubtful.txt").is_file());
    let sheet = std::fs::read(labels.join("contact-sheet.png")).unwrap();
    assert_eq!(&sheet[1..4], b"PNG");
    // A second run reuses the teacher's labels instead of asking it again.
    let again = teacher_labels(&photos, &labels);
    let stderr = String::from_utf8_lossy(&again.stderr);
    assert!(stderr.contains("(3 from an earlier run)"), "{stderr}");
}

#[test]
fn train_on_photos_nobody_labelled_asks_the_teacher() {
    let dir = tempfile::tempdir().unwrap();
    let photos = unlabelled_photos(dir.path());
    let model = dir.path().join("ours.safetensors");
    let out = agent(&[
        "train",
        "--model",
        "detector",
        "--images",
        photos.to_str().unwrap(),
        "--teacher-passes",
        "quick",
        "--hold-out",
        "none",
        "--candidate-epochs",
        "1",
        "--checker-epochs",
        "1",
        "--student-rounds",
        "1",
        "--out",
        model.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("holds no label files: the teacher labels"),
        "{stderr}"
    );
    // The student trained on the teacher's labels had its word on them before the last
    // training.
    assert!(
        stderr.contains("student round 1 of 1")
            && stderr.contains("the student settled the teacher's labels"),
        "{stderr}"
    );
    let labels = dir.path().join("ours.safetensors.labels");
    assert!(labels.join("teacher-labels.jsonl").is_file(), "{stderr}");
    assert!(labels.join("contact-sheet.png").is_file());
    // The file is a detector the commands take.
    let chosen = robot_agent::choose_detector(
        robot_agent::DetectorKind::TwoStage,
        &vision::DetectorConfig::default(),
        Some(&model),
    )
    .expect("the robot's detector takes the file");
    assert_eq!(chosen.weights, model.display().to_string());
}

#[test]
fn the_ball_network_learns_from_the_teacher_and_labelled_photos_beside() {
    let dir = tempfile::tempdir().unwrap();
    let photos = unlabelled_photos(dir.path());
    let model = dir.path().join("net.safetensors");
    let also = repo("tests/data/real-balls");
    let train = |model_kind: &str| {
        agent(&[
            "train",
            "--model",
            model_kind,
            "--images",
            photos.to_str().unwrap(),
            "--teacher-passes",
            "quick",
            "--also",
            also.to_str().unwrap(),
            "--hold-out",
            "none",
            "--epochs",
            "1",
            "--student-rounds",
            "1",
            "--out",
            model.to_str().unwrap(),
        ])
    };
    // Labelled photos beside train the ball network only.
    let refused = train("detector");
    assert!(!refused.status.success());
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(
        stderr.contains("--also trains the ball network"),
        "{stderr}"
    );
    let out = train("cnn");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    // The real-balls folder (images/ and labels/ inside) joined the teacher's photos.
    assert!(stderr.contains("more training photos: "), "{stderr}");
    assert!(stderr.contains("student round 1 of 1"), "{stderr}");
    assert!(dir.path().join("net.round1.safetensors").is_file());
    let net = vision::stages::ballnet::BallNet::from_safetensors(&std::fs::read(&model).unwrap());
    assert!(net.is_ok(), "not a ball network");
}

#[test]
fn the_teachers_labels_are_held_against_the_label_files_there() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("net.safetensors");
    let out = agent(&[
        "train",
        "--model",
        "cnn",
        "--teacher",
        "--images",
        repo("tests/data/real-balls/images").to_str().unwrap(),
        "--labels",
        repo("tests/data/real-balls/labels").to_str().unwrap(),
        "--teacher-passes",
        "quick",
        "--hold-out",
        "none",
        "--epochs",
        "1",
        "--student-rounds",
        "0",
        "--out",
        model.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    // The football of messi5 is the one ball the teacher is sure of, and a person
    // labelled it too.
    assert!(
        stderr.contains(
            "against the label files beside the photos, in the 1 photos kept for training: \
             1 of the teacher's 1 balls are on theirs (100.0 %)"
        ),
        "{stderr}"
    );
}

#[test]
fn a_broken_teacher_or_an_empty_folder_says_so_and_keeps_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let photos = unlabelled_photos(dir.path());
    let model = dir.path().join("ours.safetensors");
    std::fs::write(&model, b"an earlier model").unwrap();
    let broken = dir.path().join("teacher.safetensors");
    std::fs::write(&broken, &teacher_bytes()[..1000]).unwrap();
    let out = agent(&[
        "train",
        "--images",
        photos.to_str().unwrap(),
        "--teacher-weights",
        broken.to_str().unwrap(),
        "--out",
        model.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("teacher.safetensors is not a teacher weights file"),
        "{stderr}"
    );
    assert_eq!(std::fs::read(&model).unwrap(), b"an earlier model");

    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let out = agent(&[
        "detect",
        "--images",
        empty.to_str().unwrap(),
        "--teacher",
        "--write-labels",
        "yolo",
        dir.path().join("l").to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("hold no PNG or JPEG files"), "{stderr}");
}

fn teacher_bytes() -> Vec<u8> {
    std::fs::read(repo("teacher/data/nanodet-g.safetensors")).unwrap()
}

#[test]
fn train_on_a_recording_lends_labels_between_frames() {
    let dir = tempfile::tempdir().unwrap();
    let mcap = dir.path().join("frames.mcap");
    let out = Command::new(env!("CARGO_BIN_EXE_system-sim-agent"))
        .args(["run", "--robot-id", "miro1", "--offline", "--fast"])
        .args([
            "--scenario",
            "seed-1-across",
            "--seed",
            "2",
            "--duration-s",
            "2",
        ])
        .args(["--record-frames", mcap.to_str().unwrap()])
        .env("RUST_LOG", "warn")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let model = dir.path().join("from-frames.safetensors");
    // The rendered ball is small for the teacher's quick pass: lower thresholds.
    let out = agent(&[
        "train",
        "--model",
        "detector",
        "--source",
        &format!("mcap:{}", mcap.display()),
        "--frame-step",
        "4",
        "--teacher-passes",
        "quick",
        "--teacher-accept",
        "0.25",
        "--teacher-doubt",
        "0.1",
        "--student-rounds",
        "0",
        "--hold-out",
        "none",
        "--candidate-epochs",
        "1",
        "--checker-epochs",
        "1",
        "--out",
        model.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let lent = stderr
        .lines()
        .find(|l| l.starts_with("frames lent each other labels: "))
        .unwrap_or_else(|| panic!("{stderr}"));
    let promoted: usize = lent["frames lent each other labels: ".len()..]
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(promoted >= 1, "{lent}");
    let frames = dir.path().join("from-frames.safetensors.labels/frames");
    assert!(frames.join("left").is_dir() && frames.join("right").is_dir());
    assert!(model.is_file());
}
