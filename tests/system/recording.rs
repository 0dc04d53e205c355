//! Match logs from a live server process: a clean stop leaves a complete log whose replay
//! reproduces every published state; `kill -9` loses at most what the server accepted in
//! the last flush interval (250 ms) before it died, and the replay says how the log ended.

mod support;

use fusion_server::read_log;
use proto::Stamp;
use std::path::Path;
use std::time::Duration;
use support::*;

/// A server recording into `dir` and a process of simulated robots feeding it.
fn recorded_match(dir: &Path, seconds: f64) -> (Proc, Proc, String) {
    let dir = dir.to_string_lossy().into_owned();
    let (server, endpoint, addr) = start_server(&["--record", &dir, "--rate-hz", "20"]);
    let start = Stamp(now_ns()).offset_secs(1.0).0.to_string();
    let robots = Proc::robots(&[
        "--connect",
        &endpoint,
        "--scenario",
        "team-rally",
        "--seed",
        "4",
        "--duration-s",
        &seconds.to_string(),
        "--start-ns",
        &start,
    ]);
    (server, robots, addr)
}

fn states_recorded(addr: &str) -> u64 {
    metric(addr, "rf_states_published_total") as u64
}

#[test]
fn a_recorded_match_replays_to_identical_states() {
    let dir = temp_dir("record");
    let (mut server, mut robots, addr) = recorded_match(&dir, 6.0);
    wait_for("robots to finish", Duration::from_secs(60), || {
        robots.child.try_wait().ok().flatten()
    });
    assert!(states_recorded(&addr) > 20, "the server published states");
    assert!(server.terminate(Duration::from_secs(20)).success());
    drop(robots);

    let files = mcap_files(&dir);
    assert_eq!(files.len(), 1, "{files:?}");
    let log = read_log(&files[0]).expect("readable log");
    assert!(log.complete, "{:?}", log.problem);
    let count = |schema: &str| {
        log.messages
            .iter()
            .filter(|m| m.schema_name == schema)
            .count()
    };
    assert!(count("Observation") > 100, "{}", count("Observation"));
    assert!(count("RobotStatus") > 10);
    assert!(count("BallState") > 20);

    let replayed_dir = dir.join("replayed");
    let out = std::process::Command::new(server_bin())
        .args(["replay", "--json", "--out"])
        .arg(&replayed_dir)
        .arg(&files[0])
        .output()
        .expect("replay");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let report: serde_json::Value = serde_json::from_str(stdout.trim()).expect("JSON summary");
    let recorded = report["states_recorded"].as_u64().expect("states_recorded");
    assert_eq!(recorded as usize, count("BallState"));
    assert_eq!(
        report["states_identical"].as_u64(),
        Some(recorded),
        "{stdout}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn kill_9_while_recording_loses_at_most_the_last_flush_interval() {
    let dir = temp_dir("kill9");
    let (mut server, robots, addr) = recorded_match(&dir, 30.0);
    wait_for("a few seconds of states", Duration::from_secs(60), || {
        (states_recorded(&addr) > 60).then_some(())
    });
    let killed_at = Stamp(now_ns());
    server.child.kill().expect("kill -9");
    let _ = server.child.wait();
    drop(robots);

    let files = mcap_files(&dir);
    assert_eq!(files.len(), 1, "{files:?}");
    let log = read_log(&files[0]).expect("a crashed log is still readable");
    assert!(!log.complete, "no footer after kill -9");
    assert!(log.messages.len() > 100, "{}", log.messages.len());
    // Every message whole: the wire messages are JSON, the scene protobuf.
    for m in log
        .messages
        .iter()
        .filter(|m| !m.schema_name.starts_with("foxglove."))
    {
        assert!(serde_json::from_slice::<serde_json::Value>(&m.data).is_ok());
    }
    assert!(
        log.messages
            .iter()
            .any(|m| m.schema_name == "foxglove.SceneUpdate")
    );
    let last = log
        .messages
        .iter()
        .map(|m| m.log_time)
        .max()
        .expect("messages");
    let lost_s = killed_at.secs_since(last);
    println!("the killed server's log ends {lost_s:.3} s before the kill");
    // Messages are written in the order accepted: everything accepted before the last one
    // is in. The window is the flush interval (250 ms); the rest of the margin is for a
    // busy test machine (the writer thread and the kill itself).
    assert!(lost_s < 0.6, "the log ends {lost_s:.2} s before the kill");
    let out = std::process::Command::new(server_bin())
        .args(["replay", "--no-log"])
        .arg(&files[0])
        .output()
        .expect("replay");
    assert!(out.status.success());
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(
        said.contains("stopped without closing it"),
        "the replay says how the log ended: {said}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_simulated_log_plays_back_as_if_live() {
    let dir = temp_dir("realtime");
    let out = std::process::Command::new(SIMULATE)
        .args([
            "--scenario",
            "team-rally",
            "--seed",
            "2",
            "--duration-s",
            "8",
            "--out",
        ])
        .arg(&dir)
        .output()
        .expect("simulate");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let files = mcap_files(&dir);
    assert_eq!(files.len(), 1, "{files:?}");
    let port = proto::net::free_loopback_port().expect("port");
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let file = files[0].to_string_lossy().into_owned();
    let mut player = Proc::spawn(&[
        "replay",
        "--realtime",
        "--speed",
        "4",
        "--http",
        "127.0.0.1:0",
        "--listen",
        &endpoint,
        &file,
    ]);
    let url = player.line_starting("http://", Duration::from_secs(30));
    let addr = url
        .trim_start_matches("http://")
        .trim_end_matches('/')
        .to_string();
    // The recorded robots come online and the ball is followed, on the log's own clock.
    let state = wait_for("a replayed ball", Duration::from_secs(30), || {
        let v = get_json(&addr, "/api/state");
        v["ball"]["position_m"].is_array().then_some(v)
    });
    let robots = state["robots"].as_array().map(|r| r.len()).unwrap_or(0);
    assert!(robots >= 2, "{state}");
    let stamp = state["stamp"].as_u64().expect("stamp");
    let start = sim::SimConfig::default().start;
    let t_s = Stamp(stamp).secs_since(start);
    assert!(
        (0.0..10.0).contains(&t_s),
        "the server's clock runs through the match: {t_s}"
    );
    // 8 s of match at 4× ends by itself.
    let status = wait_for("the end of the log", Duration::from_secs(30), || {
        player.child.try_wait().ok().flatten()
    });
    assert!(status.success());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Two servers (two ids) recording into one directory, started together, both run and
/// leave complete logs of their own.
#[test]
fn two_servers_share_a_record_directory() {
    let dir = temp_dir("two-servers");
    let d = dir.to_str().expect("utf-8 path");
    let (mut a, _, _) = start_server(&["--id", "rec-a", "--record", d]);
    let (mut b, _, _) = start_server(&["--id", "rec-b", "--record", d]);
    assert!(a.terminate(Duration::from_secs(20)).success());
    assert!(b.terminate(Duration::from_secs(20)).success());
    let files = mcap_files(&dir);
    assert_eq!(files.len(), 2, "{files:?}");
    for f in &files {
        assert!(read_log(f).expect("read").complete, "{f:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
