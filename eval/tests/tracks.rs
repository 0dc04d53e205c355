//! `evaluate --tracks` end to end: a hand-made roll with a wall bounce, written as a CSV in
//! millimetres from the pitch's corner with times in milliseconds, is scored by the binary;
//! the floors are loose (the core clearly meets them), so a regression fails here.

use fusion_server::Bounds;
use proto::Pitch;
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};
use tools::track_fixtures::Roll;

fn evaluate(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_evaluate"))
        .args(args)
        .output()
        .expect("evaluate runs")
}

/// The default roll (one bounce off the +x wall) as `t_ms,x,y` in mm from the corner.
fn write_roll(path: &Path) -> f64 {
    let pitch = Pitch::default();
    let (samples, bounces) = Roll::default().run(&Bounds::from_pitch(&pitch));
    assert_eq!(bounces.len(), 1);
    let mut csv =
        String::from("# source: hand-made roll written by the system test\nframe,t_ms,x,y\n");
    for (k, s) in samples.iter().enumerate() {
        csv.push_str(&format!(
            "{k},{:.1},{:.2},{:.2}\n",
            s.t_s * 1e3,
            (s.position_m[0] + pitch.half_length_m()) * 1e3,
            (s.position_m[1] + pitch.half_width_m()) * 1e3
        ));
    }
    std::fs::write(path, csv).expect("write the track");
    bounces[0]
}

fn num(v: &Value, path: &[&str]) -> f64 {
    let mut x = v;
    for p in path {
        x = &x[*p];
    }
    x.as_f64()
        .unwrap_or_else(|| panic!("{} is not a number: {x}", path.join(".")))
}

#[test]
fn a_roll_with_a_wall_bounce_is_scored_for_every_method() {
    let dir = tempfile::tempdir().expect("temp dir");
    let csv = dir.path().join("roll.csv");
    write_roll(&csv);
    let (json, doc, plots) = (
        dir.path().join("out.json"),
        dir.path().join("accuracy.md"),
        dir.path().join("plots"),
    );
    std::fs::write(&doc, "# Accuracy\n\nHand-written text.\n").expect("write the doc");
    let s = |p: &Path| p.display().to_string();
    let out = evaluate(&[
        "--tracks",
        &s(&csv),
        "--scale",
        "0.001",
        "--origin",
        "corner",
        "--seeds",
        "2",
        "--json",
        &s(&json),
        "--doc",
        &s(&doc),
        "--plots",
        &s(&plots),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("| fusion |") && stdout.contains("| constant-velocity |"));
    let rep: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json written")).expect("json");
    assert_eq!(rep["files"][0]["time_unit"], "milliseconds");
    assert_eq!(rep["tracks"][0]["wall_bounces"], 1);
    assert_eq!(rep["tracks"][0]["samples_outside_pitch"], 0);
    let methods = rep["methods"].as_array().expect("methods");
    let names: Vec<&str> = methods
        .iter()
        .filter_map(|m| m["method"].as_str())
        .collect();
    assert_eq!(
        names,
        [
            "fusion",
            "fixed-physics",
            "constant-velocity",
            "cv-reflected"
        ]
    );
    let (fusion, fixed, cv, reflected) = (&methods[0], &methods[1], &methods[2], &methods[3]);
    let h1 = num(fusion, &["horizon_error_m", "1.0", "median"]);
    assert!(h1 < 0.1, "fusion median error at 1 s {h1} m");
    let h2 = num(fusion, &["horizon_error_m", "2.0", "median"]);
    let cv2 = num(cv, &["horizon_error_m", "2.0", "median"]);
    assert!(
        h2 < 0.5 * cv2,
        "2 s: fusion {h2} m, constant velocity {cv2} m"
    );
    assert!(num(fixed, &["horizon_error_m", "1.0", "median"]) < 0.12);
    let bounce = num(fusion, &["bounce_time_error_s", "median"]);
    assert!(bounce < 0.1, "bounce time error {bounce} s");
    assert!(num(fusion, &["first_estimate_s", "median"]) < 0.3);
    assert_eq!(num(fixed, &["final_decel_mps2", "median"]), 0.3);
    assert!(cv["bounce_time_error_s"].is_null());
    let reflected2 = num(reflected, &["horizon_error_m", "2.0", "median"]);
    assert!(
        reflected2 < cv2,
        "2 s: reflected at the wall {reflected2} m, constant velocity {cv2} m"
    );
    let text = std::fs::read_to_string(&doc).expect("doc");
    assert!(text.starts_with("# Accuracy\n\nHand-written text.\n"));
    assert!(text.contains("<!-- evaluate-tracks:begin -->"));
    assert!(text.contains("--tracks "), "{text}");
    assert!(text.contains("hand-made roll written by the system test"));
    assert!(plots.join("tracks_horizon_error.png").exists());
}

#[test]
fn a_malformed_track_fails_naming_its_file_and_line() {
    let dir = tempfile::tempdir().expect("temp dir");
    let csv = dir.path().join("bad.csv");
    let mut text = String::from("time,x,y\n");
    for k in 0..20 {
        let t = if k == 12 { 0.05 } else { 0.1 * k as f64 };
        text.push_str(&format!("{t},0,0\n"));
    }
    std::fs::write(&csv, text).expect("write");
    let out = evaluate(&["--tracks", &csv.display().to_string()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("{}:14: time goes backwards", csv.display())),
        "{err}"
    );
}
