//! `replay` as a user runs it, on a small match log written here: states at the asked
//! times in the CSV, the grid on past the end of the log, the core's counts in the JSON
//! summary, and the pitch flags reaching the replayed engine.

mod support;

use fusion_server::RecorderConfig;
use fusion_server::RecorderSink;
use fusion_server::ReplaySink;
use proto::test_support::{isotropic, observation};
use proto::{Observation, Stamp};
use std::path::{Path, PathBuf};
use support::BIN;

/// 2026-11-23T23:59:59Z.
const T0: Stamp = Stamp(1_795_478_399_000_000_000);

/// Half a second of a ball rolling along x seen by two robots, and one sighting 0.39 m
/// beyond the x_max wall of the MiRo pitch; `dir` receives the log.
fn small_log(dir: &Path) -> PathBuf {
    let mut cfg = RecorderConfig::new(dir);
    cfg.file_prefix = "small".into();
    let mut sink = RecorderSink::create(cfg, T0).expect("log created");
    for i in 0..=50u64 {
        let log_s = 0.01 * i as f64;
        let robot = if i % 2 == 0 { "miro1" } else { "miro2" };
        let position_m = if i == 50 {
            [2.3, 0.0]
        } else {
            [0.5 * log_s, 0.2]
        };
        let at = T0.offset_secs(log_s);
        let obs = Observation {
            covariance_m2: isotropic(0.01),
            ..observation(robot, i, at.offset_secs(-0.02), position_m)
        };
        let topic = format!("rf/robots/{robot}/obs");
        sink.write(&topic, "Observation", at, &proto::encode(&obs));
    }
    let files = sink.finish().expect("log finished").files;
    assert_eq!(files.len(), 1, "{files:?}");
    files[0].clone()
}

/// Runs `replay --json --no-log ARGS LOG`; the JSON summary.
fn replay(log: &Path, args: &[&str]) -> serde_json::Value {
    let out = std::process::Command::new(BIN)
        .args(["replay", "--json", "--no-log"])
        .args(args)
        .arg(log)
        .output()
        .expect("replay runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    serde_json::from_str(stdout.trim()).expect("one JSON object")
}

/// The CSV's `t_ns` column and its `status` column.
fn csv_rows(path: &Path) -> Vec<(u64, String)> {
    let text = std::fs::read_to_string(path).expect("states CSV");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    assert_eq!(&header[..3], ["t_ns", "t_s", "status"]);
    lines
        .map(|l| {
            let cols: Vec<&str> = l.split(',').collect();
            assert_eq!(cols.len(), header.len(), "{l}");
            (cols[0].parse().expect("t_ns"), cols[2].to_string())
        })
        .collect()
}

#[test]
fn states_at_the_asked_times_and_the_core_counts() {
    let dir = tempfile::tempdir().expect("temp dir");
    let log = small_log(dir.path());
    let csv = dir.path().join("states.csv");
    let csv_arg = csv.to_string_lossy().into_owned();
    let absolute = T0.offset_secs(0.4).0.to_string();
    let at = format!("+0.25,{absolute},+2");
    let report = replay(&log, &["--at", &at, "--states-csv", &csv_arg]);
    let want: Vec<u64> = [0.25, 0.4, 2.0]
        .iter()
        .map(|s| T0.offset_secs(*s).0)
        .collect();
    let rows = csv_rows(&csv);
    let times: Vec<u64> = rows.iter().map(|(t, _)| *t).collect();
    assert_eq!(times, want);
    assert_eq!(
        rows[2].1, "coasting",
        "after the log the ball is predicted on"
    );
    assert_eq!(report["states_written"], 3);
    assert_eq!(report["states_csv"], csv_arg.as_str());
    assert_eq!(report["observations"], 51);
    assert_eq!(report["observations_accepted"], 51);
    assert_eq!(report["observations_outside_walls"], 1, "{report}");
    assert_eq!(report["observations_reordered"], 0);

    // On a longer pitch the last sighting lies inside the walls.
    let longer = replay(&log, &["--pitch-length-m", "5", "--at", "+0.3"]);
    assert_eq!(longer["observations_outside_walls"], 0, "{longer}");
}

#[test]
fn a_grid_through_a_stamp_on_past_the_end_of_the_log() {
    let dir = tempfile::tempdir().expect("temp dir");
    let log = small_log(dir.path());
    let csv = dir.path().join("grid.csv");
    let csv_arg = csv.to_string_lossy().into_owned();
    let align = T0.offset_secs(0.005).0.to_string();
    let report = replay(
        &log,
        &[
            "--rate-hz",
            "10",
            "--align",
            &align,
            "--until",
            "+1",
            "--states-csv",
            &csv_arg,
        ],
    );
    let want: Vec<u64> = (0..10)
        .map(|k| T0.offset_secs(0.005).offset_secs(0.1 * k as f64).0)
        .collect();
    let rows = csv_rows(&csv);
    assert_eq!(rows.iter().map(|(t, _)| *t).collect::<Vec<_>>(), want);
    assert_eq!(rows[0].1, "none", "one sighting is no ball yet");
    assert_eq!(report["states_without_estimate"], 1);
    assert_eq!(report["states_written"], 9);
}

#[test]
fn asked_times_must_be_stamps_or_seconds_after_the_first_message() {
    let out = std::process::Command::new(BIN)
        .args(["replay", "--no-log", "--at", "1.5", "x.mcap"])
        .output()
        .expect("replay runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("nor +SECONDS after the first message"),
        "{err}"
    );
    let out = std::process::Command::new(BIN)
        .args(["replay", "--at", "+1", "--until", "+2", "x.mcap"])
        .output()
        .expect("replay runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cannot be used with"), "{err}");
}
