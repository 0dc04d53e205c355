//! The `robot-agent` binary as a process: the simulated cameras offline, recorded to MCAP
//! and to an image folder and played back from both, and live over a real loopback Zenoh
//! session (observations, status, liveliness, the shared ball state).

#![allow(clippy::unwrap_used)]

use proto::net::{NetConfig, free_loopback_port};
use proto::{Observation, Pitch, RobotStatus, Validate, ValidationContext};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_robot-agent");

/// Runs the agent to its end and returns (frames, observations) from its summary line.
fn run_offline(args: &[&str]) -> (u64, u64, String) {
    let out = Command::new(BIN)
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
    let dir = tempfile::tempdir().unwrap();
    let mcap = dir.path().join("frames.mcap");
    let folder = dir.path().join("frames");
    let common = ["--scenario", "seed-1-across", "--seed", "2", "--fast"];
    let (frames, observations, stdout) =
        run_offline(&[&common[..], &["--record-frames", mcap.to_str().unwrap()]].concat());
    assert!(frames >= 30, "{stdout}");
    assert!(observations >= frames / 4, "{stdout}");
    let (recall, precision) = recall_and_precision(&stdout);
    // Loose floors: the evaluation measures the real figures.
    assert!(recall >= 85.0 && precision >= 95.0, "{stdout}");
    let (frames_mcap, observations_mcap, _) =
        run_offline(&["--source", &format!("mcap:{}", mcap.display())]);
    assert_eq!((frames_mcap, observations_mcap), (frames, observations));
    // The MCAP recording, re-recorded as an image folder, plays back the same again.
    run_offline(&[
        "--source",
        &format!("mcap:{}", mcap.display()),
        "--record-frames",
        folder.to_str().unwrap(),
    ]);
    let (frames_dir, observations_dir, _) =
        run_offline(&["--source", &format!("images:{}", folder.display())]);
    assert_eq!((frames_dir, observations_dir), (frames, observations));
}

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
            .contains("is not sim, images:DIR, mcap:FILE, zenoh:ros2 or zenoh:ros1")
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
    assert!(run(&["--calibration", bad_cal.to_str().unwrap()]).contains("cal.toml"));
    let out = Command::new(BIN)
        .args([
            "run",
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
    let child = Command::new(BIN)
        .args(["run", "--robot-id", "miro1", "--connect", &endpoint])
        .args([
            "--scenario",
            "seed-1-across",
            "--seed",
            "2",
            "--sim-duration",
            "4",
        ])
        .env("RUST_LOG", "warn,zenoh=error")
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
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
    assert!(last.timings.iter().any(|t| t.stage == "hough"));
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
fn calibrate_writes_a_usable_calibration_from_photographs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("left.toml");
    let photos = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/chessboard-photos");
    let run = Command::new(BIN)
        .args([
            "calibrate",
            "--images",
            photos,
            "--board",
            "9x6",
            "--square",
            "0.025",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{stdout}");
    assert!(stdout.contains("13 of 13 views used"), "{stdout}");
    let c =
        robot_agent::calibrate::Calibration::from_toml_str(&std::fs::read_to_string(&out).unwrap())
            .unwrap();
    assert!(c.rms_px < 0.5, "{}", c.rms_px);
    // The agent takes it as its camera model: for 640×480 photos, so it refuses the
    // simulator's 640×360 frames, which are not a resize of them, naming both sizes.
    let refused = Command::new(BIN)
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

#[test]
fn train_fits_a_model_from_patch_folders() {
    let dir = tempfile::tempdir().unwrap();
    let (pos, neg) = (dir.path().join("pos"), dir.path().join("neg"));
    std::fs::create_dir_all(&pos).unwrap();
    std::fs::create_dir_all(&neg).unwrap();
    for k in 0..24u32 {
        // Shaded discs of varying size and offset against stripes of varying period.
        let r = 9.0 + f64::from(k % 5);
        let off = f64::from(k % 3) - 1.0;
        let mut disc = robot_agent::image::RgbImage::filled(32, 32, [90, 110, 90]).unwrap();
        let mut stripes = disc.clone();
        for y in 0..32u32 {
            for x in 0..32u32 {
                let (dx, dy) = (f64::from(x) - 15.5 - off, f64::from(y) - 15.5 + off);
                if dx.hypot(dy) <= r {
                    let shade = 0.6 + 0.4 * (1.0 - dy / r) / 2.0;
                    disc.set_pixel(x, y, [(240.0 * shade) as u8, (120.0 * shade) as u8, 30]);
                }
                if (x + k) / (3 + k % 4) % 2 == 0 {
                    stripes.set_pixel(x, y, [230, 120, 40]);
                }
            }
        }
        let png = |i: &robot_agent::image::RgbImage| robot_agent::image_io::encode_png(i).unwrap();
        std::fs::write(pos.join(format!("{k}.png")), png(&disc)).unwrap();
        std::fs::write(neg.join(format!("{k}.png")), png(&stripes)).unwrap();
    }
    let model = dir.path().join("model.json");
    let run = Command::new(BIN)
        .arg("train")
        .arg("--positives")
        .arg(&pos)
        .arg("--negatives")
        .arg(&neg)
        .arg("--out")
        .arg(&model)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(stdout.contains("precision"), "{stdout}");
    let m = robot_agent::svm::Model::from_json(&std::fs::read_to_string(&model).unwrap()).unwrap();
    assert_eq!(m.dim(), robot_agent::hog::HOG_LEN);
}
