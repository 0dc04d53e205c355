//! A simulated match log scored back: `simulate` writes observations and ground truth,
//! `score_log` reads them and scores the fusion core the evaluation's way.

use std::path::PathBuf;
use std::process::Command;

fn run(bin: &str, args: &[&str]) -> String {
    let out = Command::new(bin).args(args).output().expect("runs");
    assert!(
        out.status.success(),
        "{bin} {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn a_simulated_log_is_scored_from_its_ground_truth() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().to_string_lossy().into_owned();
    let printed = run(
        env!("CARGO_BIN_EXE_simulate"),
        &[
            "--scenario",
            "team-rally",
            "--seed",
            "2",
            "--duration-s",
            "12",
            "--out",
            &out,
        ],
    );
    let file: PathBuf = printed.trim().into();
    assert!(file.is_file(), "{printed}");
    let file = file.to_string_lossy().into_owned();
    let json = run(env!("CARGO_BIN_EXE_score_log"), &["--json", &file]);
    let v: serde_json::Value = serde_json::from_str(&json).expect("JSON");
    let coverage = v["coverage"].as_f64().expect("coverage");
    let median_m = v["position_median_m"].as_f64().expect("median");
    assert!(coverage > 0.8, "{v}");
    assert!(median_m < 0.1, "{v}");
    // A file that is no match log is refused with a message.
    let empty = dir.path().join("empty.mcap");
    std::fs::write(&empty, b"not a log").expect("written");
    let out = Command::new(env!("CARGO_BIN_EXE_score_log"))
        .arg(&empty)
        .output()
        .expect("runs");
    assert!(!out.status.success());
    assert!(!String::from_utf8_lossy(&out.stderr).is_empty());
}
