//! The agent on the simulator's cameras as a process (`sim_agent`): offline, recorded to
//! MCAP and to an image folder and played back from both by `robot-agent run`, and live
//! over a real loopback Zenoh session (observations, status, liveliness, the shared ball
//! state); a robot the scenario lacks and a calibration of another frame shape refused.
//! On a secured network (`--tls DIR`, a listener demanding a certificate from the
//! network's authority and applying the roster's access-control list), its observations
//! arrive with its own certificate, and none with another robot's under its id.

#![allow(clippy::unwrap_used)]

use fusion_server::{Authority, Issued, Validity};
use fusion_server::{Roster, install_acl};
use fusion_server::{robot_common_name, server_common_name};
use proto::net::{NetConfig, TlsFiles, free_loopback_port};
use proto::{Observation, Pitch, RobotStatus, Validate, ValidationContext};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The `robot-agent` command line, built by this package from the product's source.
const AGENT_CLI: &str = env!("CARGO_BIN_EXE_system-robot-agent");

const SIM_AGENT: &str = env!("CARGO_BIN_EXE_system-sim-agent");

/// `sim_agent run` as miro1 of the `seed-1-across` match (seed 2) for `duration_s`,
/// publishing to `endpoint`, with `extra` flags.
fn live_agent(endpoint: &str, duration_s: &str, extra: &[&std::ffi::OsStr]) -> Command {
    let mut c = Command::new(SIM_AGENT);
    c.args(["run", "--robot-id", "miro1", "--connect", endpoint])
        .args(extra)
        .args(["--scenario", "seed-1-across", "--seed", "2"])
        .args(["--duration-s", duration_s])
        .env("RUST_LOG", "warn,zenoh=error")
        .stderr(Stdio::inherit());
    c
}

/// Runs the agent (`bin`: `sim_agent` or `robot-agent`) to its end and returns (frames,
/// observations) from its summary line.
fn run_offline(bin: &Path, args: &[&str]) -> (u64, u64, String) {
    let out = Command::new(bin)
        .args(["run", "--robot-id", "miro1", "--offline"])
        .args(args)
        .env("RUST_LOG", "warn")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "agent failed: {stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let line = stdout
        .lines()
        .find(|l| l.starts_with("miro1: "))
        .unwrap_or_else(|| panic!("no summary in {stdout}"));
    let words: Vec<&str> = line.split_whitespace().collect();
    let frames = words[1].parse().unwrap();
    let observations = words[3].parse().unwrap();
    (frames, observations, stdout)
}

fn recall_and_precision(stdout: &str) -> (f64, f64) {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("against the simulator's truth"))
        .unwrap();
    let pct = |key: &str| -> f64 {
        let after = &line[line.find(key).unwrap() + key.len()..];
        after.split_whitespace().next().unwrap().parse().unwrap()
    };
    (pct("(recall "), pct("(precision "))
}

#[test]
fn simulated_cameras_recorded_and_played_back_give_the_same_sightings() {
    let robot_agent = Path::new(AGENT_CLI);
    let dir = tempfile::tempdir().unwrap();
    let mcap = dir.path().join("frames.mcap");
    let folder = dir.path().join("frames");
    let common = ["--scenario", "seed-1-across", "--seed", "2", "--fast"];
    let (frames, observations, stdout) = run_offline(
        Path::new(SIM_AGENT),
        &[&common[..], &["--record-frames", mcap.to_str().unwrap()]].concat(),
    );
    assert!(frames >= 30, "{stdout}");
    assert!(observations >= frames / 4, "{stdout}");
    let (recall, precision) = recall_and_precision(&stdout);
    // Loose floors: the evaluation measures the real figures.
    assert!(recall >= 85.0 && precision >= 95.0, "{stdout}");
    let (frames_mcap, observations_mcap, _) = run_offline(
        robot_agent,
        &["--source", &format!("mcap:{}", mcap.display())],
    );
    assert_eq!((frames_mcap, observations_mcap), (frames, observations));
    // The MCAP recording, re-recorded as an image folder, plays back the same again.
    run_offline(
        robot_agent,
        &[
            "--source",
            &format!("mcap:{}", mcap.display()),
            "--record-frames",
            folder.to_str().unwrap(),
        ],
    );
    let (frames_dir, observations_dir, _) = run_offline(
        robot_agent,
        &["--source", &format!("images:{}", folder.display())],
    );
    assert_eq!((frames_dir, observations_dir), (frames, observations));
}

#[tokio::test(flavor = "multi_thread")]
async fn live_agent_publishes_over_zenoh() {
    let endpoint = format!("tcp/127.0.0.1:{}", free_loopback_port().unwrap());
    let session = NetConfig::listening(&endpoint).open().await.unwrap();
    let observations: Arc<Mutex<Vec<Observation>>> = Arc::default();
    let statuses: Arc<Mutex<Vec<RobotStatus>>> = Arc::default();
    let _obs_sub = {
        let o = observations.clone();
        session
            .declare_subscriber("rf/robots/miro1/obs")
            .callback(move |s| {
                o.lock()
                    .unwrap()
                    .push(proto::decode(&s.payload().to_bytes()).unwrap());
            })
            .await
            .unwrap()
    };
    let _status_sub = {
        let st = statuses.clone();
        session
            .declare_subscriber("rf/robots/miro1/status")
            .callback(move |s| {
                st.lock()
                    .unwrap()
                    .push(proto::decode(&s.payload().to_bytes()).unwrap());
            })
            .await
            .unwrap()
    };
    let child = live_agent(&endpoint, "4", &[])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    // The robot is alive while it runs.
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut alive = false;
    while !alive && Instant::now() < deadline {
        let replies = session.liveliness().get("rf/robots/*").await.unwrap();
        while let Ok(r) = replies.recv_async().await {
            alive |= r
                .result()
                .is_ok_and(|s| s.key_expr().as_str() == "rf/robots/miro1");
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    assert!(alive, "no liveliness token");
    // A garbage ball state is counted, not fatal.
    session.put("rf/ball/state", "{not json").await.unwrap();
    let status = tokio::task::spawn_blocking(move || child.wait_with_output())
        .await
        .unwrap()
        .unwrap();
    assert!(status.status.success());
    tokio::time::sleep(Duration::from_millis(300)).await;
    let obs = observations.lock().unwrap().clone();
    let st = statuses.lock().unwrap().clone();
    assert!(obs.len() >= 10, "{} observations", obs.len());
    for (k, o) in obs.iter().enumerate() {
        assert_eq!(o.seq, k as u64, "sequence numbers count up without gaps");
        let ctx = ValidationContext::new(Pitch::default(), o.stamp);
        o.validate(&ctx).unwrap();
        assert!(o.pixel.is_some());
    }
    let last = st.last().unwrap();
    assert!(st.len() >= 4, "{} statuses", st.len());
    assert_eq!(last.footprints.len(), 2);
    assert!(
        last.timings
            .iter()
            .any(|t| t.stage == "total" && t.ms > 0.0)
    );
    // The robot's detector's stages, as the status names them.
    assert!(last.timings.iter().any(|t| t.stage == "candidates"));
    assert!(last.fps > 5.0, "{}", last.fps);
    last.validate(&ValidationContext::new(Pitch::default(), last.stamp))
        .unwrap();
    // Gone once it stopped.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let replies = session.liveliness().get("rf/robots/*").await.unwrap();
    let mut still = false;
    while let Ok(r) = replies.recv_async().await {
        still |= r.result().is_ok();
    }
    assert!(!still, "the token outlived the process");
}

#[test]
fn a_robot_the_scenario_lacks_is_an_error() {
    let out = Command::new(SIM_AGENT)
        .args([
            "--robot-id",
            "nobody",
            "--offline",
            "--scenario",
            "seed-1-across",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("has no robot \"nobody\""));
    // Only the simulator's cameras.
    let out = Command::new(SIM_AGENT)
        .args([
            "--robot-id",
            "miro1",
            "--offline",
            "--source",
            "mcap:x.mcap",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--source sim"));
}

/// A calibration of the chessboard photographs (640×480) is refused for the simulator's
/// 640×360 frames, which are not a resize of them, naming both sizes; the leading `run`
/// of the old command line is accepted.
#[test]
fn a_calibration_of_another_shape_is_refused() {
    let photos = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../robot-agent/tests/data/chessboard-photos"
    );
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("left.toml");
    let made = Command::new(env!("CARGO_BIN_EXE_system-ball-lab"))
        .args(["calibrate", "--images", photos, "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(made.status.success());
    let refused = Command::new(SIM_AGENT)
        .args([
            "run",
            "--robot-id",
            "miro1",
            "--offline",
            "--scenario",
            "seed-1-across",
        ])
        .args([
            "--duration",
            "0.2",
            "--fast",
            "--rescale-calibration",
            "--calibration",
        ])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success());
    assert!(
        stderr.contains("640×480") && stderr.contains("640×360") && stderr.contains("shape"),
        "{stderr}"
    );
}

fn write(dir: &Path, ca: &Authority, node: &Issued) -> PathBuf {
    fusion_server::write_node_dir(dir, &ca.issued.cert_pem, node).unwrap();
    dir.to_path_buf()
}

/// Runs `sim_agent` as miro1 for 3 s with the certificate in `tls`; returns how many of
/// its observations the listener received.
async fn observations_received_over_tls(tls: &Path, server_tls: &Path) -> u64 {
    let endpoint = format!("tls/127.0.0.1:{}", free_loopback_port().unwrap());
    let net = NetConfig {
        tls: Some(TlsFiles::in_dir(server_tls)),
        ..NetConfig::listening(&endpoint)
    };
    let mut config = net.zenoh_config().unwrap();
    let (robots, servers) = (
        vec!["miro1".to_string(), "miro2".into()],
        vec!["main".to_string()],
    );
    install_acl(
        &mut config,
        &Roster {
            prefix: "rf",
            robots: &robots,
            servers: &servers,
            routers: &[],
        },
    )
    .unwrap();
    let session = zenoh::open(config).await.unwrap();
    let count = Arc::new(AtomicU64::new(0));
    let c = count.clone();
    let _sub = session
        .declare_subscriber("rf/robots/*/obs")
        .callback(move |_| {
            c.fetch_add(1, Ordering::Relaxed);
        })
        .await
        .unwrap();
    let child = live_agent(&endpoint, "3", &["--tls".as_ref(), tls.as_os_str()])
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let out = tokio::task::spawn_blocking(move || child.wait_with_output())
        .await
        .unwrap()
        .unwrap();
    assert!(out.status.success());
    tokio::time::sleep(Duration::from_millis(300)).await;
    let _ = session.close().await;
    count.load(Ordering::Relaxed)
}

#[tokio::test(flavor = "multi_thread")]
async fn the_agent_joins_with_its_own_certificate_only() {
    let tmp = tempfile::tempdir().unwrap();
    let validity = Validity::starting(jiff::Timestamp::now(), 2).unwrap();
    let ca = Authority::new("test authority", validity).unwrap();
    let hosts = ["127.0.0.1".to_string()];
    let server = write(
        &tmp.path().join("server"),
        &ca,
        &ca.issue(&server_common_name("main"), &hosts, validity)
            .unwrap(),
    );
    let miro1 = write(
        &tmp.path().join("miro1"),
        &ca,
        &ca.issue(&robot_common_name("miro1"), &[], validity)
            .unwrap(),
    );
    let miro2 = write(
        &tmp.path().join("miro2"),
        &ca,
        &ca.issue(&robot_common_name("miro2"), &[], validity)
            .unwrap(),
    );
    let own = observations_received_over_tls(&miro1, &server).await;
    assert!(
        own >= 10,
        "only {own} observations with its own certificate"
    );
    let borrowed = observations_received_over_tls(&miro2, &server).await;
    assert_eq!(borrowed, 0, "miro2's certificate published as miro1");
}
