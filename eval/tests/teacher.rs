//! `evaluate --labelled DIR --teacher` end to end, on real onboard photos of the repo
//! (`tests/data/msl-balls`): both pass sets are scored and written into a report's
//! section with its plot, and the labelling passes reach balls the whole-photo pass is
//! blind to; the robot's shipped detector is scored beside it.

use serde_json::Value;
use std::path::Path;
use std::process::Command;

#[test]
fn the_teacher_is_scored_on_real_photos_into_its_section() {
    let dir = tempfile::tempdir().expect("temp dir");
    let doc = dir.path().join("accuracy.md");
    std::fs::write(&doc, "# Report\n\nhand-written text\n").expect("doc");
    let json = dir.path().join("teacher.json");
    let photos = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/msl-balls");
    let out = Command::new(env!("CARGO_BIN_EXE_evaluate"))
        .args(["--labelled", photos.to_str().expect("utf-8")])
        .args(["--teacher", "--every", "3", "--beside", "shipped"])
        .args(["--teacher-json", json.to_str().expect("utf-8")])
        .args(["--doc", doc.to_str().expect("utf-8")])
        .args(["--plots", dir.path().to_str().expect("utf-8")])
        .output()
        .expect("evaluate runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let plot = std::fs::read(dir.path().join("teacher-pr.png")).expect("the plot");
    assert_eq!(&plot[1..4], b"PNG");
    let text = std::fs::read_to_string(&doc).expect("doc");
    assert!(text.contains("hand-written text"));
    assert!(text.contains("<!-- evaluate-teacher:begin -->"), "{text}");
    assert!(text.contains("| **all** | whole photo | 4 |"), "{text}");
    assert!(text.contains("at the labelling threshold 0.55"), "{text}");
    assert!(
        text.contains("| **all** | whole + tiles + 2× tiles | 4 |"),
        "{text}"
    );
    let rows: Vec<Value> =
        serde_json::from_slice(&std::fs::read(&json).expect("json")).expect("parses");
    let reach = |passes: &str| {
        rows.iter()
            .find(|r| r["event"] == "all" && r["passes"] == passes)
            .and_then(|r| r["report"]["reach"].as_f64())
            .expect("an all row")
    };
    let (whole, tiles) = (reach("whole photo"), reach("whole + tiles + 2× tiles"));
    // The robot's shipped detector is scored beside the teacher, on the same photos.
    assert!(text.contains("| **all** | robot: shipped | 4 |"), "{text}");
    assert!(reach("robot: shipped") > 0.0);
    // The photos' balls are mostly 10-20 px: the tiles reach more of them than the
    // whole photo shrunk to 416 px does.
    assert!(
        tiles > whole && tiles >= 0.5,
        "whole {whole}, tiles {tiles}"
    );
}
