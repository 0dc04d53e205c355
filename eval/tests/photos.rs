//! The detector on photos it was never trained on, as a test: a few randomised held-out
//! photos per kind of background and the real photographs. Floors are far looser than the
//! figures `evaluate --photos` reports in docs/accuracy.md; a regression in the candidate
//! stage or the shipped classifier fails here.

#![allow(clippy::unwrap_used)]

use eval::photo_eval::{PhotoEvalConfig, evaluate_photos};
use std::path::{Path, PathBuf};
use tools::photo_set::{PhotoSetSpec, write_photo_set};
use tools::progress::Progress;

fn data(dir: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/data")
        .join(dir)
}

#[test]
fn held_out_and_real_photos_clear_their_floors() {
    // Orange balls, plain or patched, for the colour path this test holds to its floors.
    let cfg = PhotoEvalConfig {
        count: 60,
        seed: 5,
        backgrounds: data("backgrounds/heldout"),
        real_balls: data("real-balls"),
        profile: sim::PhotoProfile {
            plain_neutral_chance: 0.0,
            ..sim::PhotoProfile::heldout()
        }
        .with_designs(&[sim::BallDesign::Plain, sim::BallDesign::Patches]),
    };
    let chosen = robot_agent::choose_detector(
        robot_agent::DetectorKind::Dissertation,
        &vision::DetectorConfig::default(),
        None,
    )
    .expect("the dissertation's detector");
    let results = evaluate_photos(
        &cfg,
        &chosen.detector,
        chosen.classifier.as_ref(),
        0.5,
        &Progress::hidden(0),
    )
    .expect("photo evaluation");
    let by_name = |n: &str| {
        results
            .iter()
            .find(|r| r.name == n)
            .unwrap_or_else(|| panic!("no set {n}"))
    };
    for (name, recall_floor, precision_floor) in [
        ("held-out carpets", 0.5, 0.9),
        ("held-out rendered pitch", 0.3, 0.8),
        ("held-out real backgrounds", 0.15, 0.5),
    ] {
        let r = &by_name(name).report;
        assert_eq!(r.images, 60);
        let recall = r.recall_published.expect("photos with a ball");
        let precision = r.precision.expect("something published");
        assert!(recall >= recall_floor, "{name}: recall {recall}");
        assert!(
            precision >= precision_floor,
            "{name}: precision {precision}"
        );
    }
    // The orange fruit and the orange sweets are found; nothing else of those photos is
    // mistaken for them.
    let real = &by_name("real photos with balls").report;
    assert_eq!(real.images, 5);
    assert!(real.found_published >= 2, "{real:?}");
    let empty = &by_name("real photos without a ball").report;
    assert_eq!(empty.balls, 0);
    assert!(
        empty.false_positives <= 4,
        "{} false",
        empty.false_positives
    );
}

#[test]
fn a_written_photo_set_reads_back_as_labelled_photos() {
    let dir = tempfile::tempdir().expect("temp dir");
    let spec = PhotoSetSpec {
        profile: sim::PhotoProfile::train(),
        count: 9,
        seed: 3,
        backgrounds: vec![data("backgrounds/train").join("home.jpg")],
        erase_class: None,
        rendered: 2,
        kinds: Vec::new(),
    };
    let with_ball = write_photo_set(&spec, dir.path(), &Progress::hidden(9)).expect("photo set");
    assert!(with_ball > 0 && with_ball <= 9);
    let classes = std::fs::read_to_string(dir.path().join("labels/classes.txt")).unwrap();
    let names = lab::labels::yolo::parse_classes_txt(&classes);
    let ids =
        lab::labels::yolo::BallClassIds::from_names(&names, &lab::labels::BallNames::default());
    let mut balls = 0;
    for i in 0..9 {
        let image = robot_agent::load_rgb(&dir.path().join(format!("images/{i:05}.jpg")))
            .expect("a JPEG photo");
        let text = std::fs::read_to_string(dir.path().join(format!("labels/{i:05}.txt"))).unwrap();
        let labels = lab::labels::yolo::parse_yolo(&text, "t", image.width(), image.height(), &ids)
            .expect("YOLO labels");
        balls += labels.balls.len();
    }
    assert_eq!(balls, with_ball);
    // A second set into the same folder is refused rather than mixed in.
    assert!(write_photo_set(&spec, dir.path(), &Progress::hidden(9)).is_err());
    let manifest = std::fs::read_to_string(dir.path().join("manifest.json")).unwrap();
    assert!(manifest.contains("\"profile\": \"train\""), "{manifest}");
}
