//! The `robot-agent` binary as a process: bad sources and files give clear errors, and it
//! holds the robot's commands only. (The agent on the simulator's cameras, recorded and
//! played back, and live over Zenoh, is the system tests' `sim_agent` and its tests.)

#![allow(clippy::unwrap_used)]

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_robot-agent");

#[test]
fn bad_sources_and_files_give_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        let out = Command::new(BIN)
            .args(["run", "--robot-id", "miro1", "--offline"])
            .args(args)
            .output()
            .unwrap();
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    assert!(
        run(&["--source", "camera:0"])
            .contains("is not images:DIR, mcap:FILE, ros1, zenoh:ros2 or zenoh:ros1")
    );
    let missing = format!("images:{}", dir.path().display());
    assert!(run(&["--source", &missing]).contains("frames.jsonl"));
    let garbage = dir.path().join("garbage.mcap");
    std::fs::write(&garbage, b"not an mcap file").unwrap();
    assert!(
        run(&["--source", &format!("mcap:{}", garbage.display())]).contains("not an MCAP file")
    );
    let bad_cal = dir.path().join("cal.toml");
    std::fs::write(&bad_cal, "model = 3").unwrap();
    assert!(
        run(&[
            "--source",
            &missing,
            "--calibration",
            bad_cal.to_str().unwrap()
        ])
        .contains("cal.toml")
    );
    // The simulator's cameras are the tools' (`sim_agent`), not a source of the product.
    assert!(run(&["--source", "sim"]).contains("is not images:DIR"));
}

#[test]
fn the_robots_program_has_no_laptop_commands() {
    for command in [
        "train",
        "calibrate",
        "calibrate-colour",
        "evaluate",
        "detect",
    ] {
        let out = Command::new(BIN).arg(command).output().unwrap();
        assert!(!out.status.success(), "{command}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            stderr.contains("unrecognized subcommand"),
            "{command}: {stderr}"
        );
    }
}
