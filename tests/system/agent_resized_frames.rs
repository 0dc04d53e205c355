//! Frames of another size than the calibration: refused with a clear error, or played
//! with the calibration scaled to them when asked. The frames are the simulator's,
//! recorded by `sim_agent` and halved; `robot-agent run` plays them.

#![allow(clippy::unwrap_used)]

mod common;
use common::halved;
use robot_agent::{encode_png, load_rgb};
use std::path::Path;
use std::process::{Command, Output};

/// The `robot-agent` command line, built by this package from the product's source.
const AGENT_CLI: &str = env!("CARGO_BIN_EXE_system-robot-agent");

fn agent(args: &[&str]) -> Output {
    agent_process(Path::new(AGENT_CLI), args)
}

fn agent_process(bin: &Path, args: &[&str]) -> Output {
    Command::new(bin)
        .args(["run", "--robot-id", "miro1", "--offline"])
        .args(args)
        .env("RUST_LOG", "warn")
        .output()
        .unwrap()
}

#[test]
fn a_calibration_for_another_frame_size_is_refused_or_rescaled() {
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("frames");
    let recorded = agent_process(
        Path::new(env!("CARGO_BIN_EXE_system-sim-agent")),
        &[
            "--scenario",
            "seed-1-across",
            "--seed",
            "2",
            "--fast",
            "--record-frames",
            folder.to_str().unwrap(),
        ],
    );
    assert!(recorded.status.success());
    let mut n = 0;
    for entry in std::fs::read_dir(&folder).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "png") {
            let small = halved(&load_rgb(&path).unwrap());
            std::fs::write(&path, encode_png(&small).unwrap()).unwrap();
            n += 1;
        }
    }
    assert!(n >= 30, "{n} frames recorded");
    let source = format!("images:{}", folder.display());

    let refused = agent(&["--source", &source]);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success());
    assert!(
        stderr.contains("640×360") && stderr.contains("320×180"),
        "{stderr}"
    );
    assert!(stderr.contains("--rescale-calibration"), "{stderr}");

    let rescaled = agent(&["--source", &source, "--rescale-calibration"]);
    let stdout = String::from_utf8_lossy(&rescaled.stdout);
    let stderr = String::from_utf8_lossy(&rescaled.stderr);
    assert!(rescaled.status.success(), "{stdout}\n{stderr}");
    assert!(
        stderr.contains("scaled to the frames' 320×180 px"),
        "{stderr}"
    );
    let line = stdout.lines().find(|l| l.starts_with("miro1: ")).unwrap();
    let words: Vec<&str> = line.split_whitespace().collect();
    let observations: u64 = words[3].parse().unwrap();
    assert!(
        observations > 0,
        "no ball found in the half-size frames: {line}"
    );
}
