//! Tests of the perceive loop's hand-offs: observations, status and camera views out of a
//! run over given frames.

#![allow(clippy::unwrap_used)]

use super::*;
use crate::agent::PipelineConfig;
use crate::runtime::frame::RobotState;
use crate::test_fixtures::{head, miro_lens};
use clap::Parser;
use proto::{Camera, Pitch, Pose2, Validate, ValidationContext};
use vision::HoughOnly;

#[derive(Debug, Parser)]
struct Cli {
    #[command(flatten)]
    run: RunArgs,
}

fn args(extra: &[&str]) -> RunArgs {
    let argv = ["robot-agent", "--robot-id", "miro1"]
        .into_iter()
        .chain(extra.iter().copied());
    Cli::try_parse_from(argv).unwrap().run
}

/// Frames handed over in order, as a file source would.
struct Frames(std::vec::IntoIter<StoredFrame>);

impl FrameSource for Frames {
    fn next_frame(&mut self) -> Result<Option<StoredFrame>> {
        Ok(self.0.next())
    }

    fn live(&self) -> bool {
        false
    }
}

const T0: u64 = 1_700_000_000_000_000_000;

/// Both cameras at 10 Hz for `seconds`, an orange disc low in the middle of each frame.
fn frames(seconds: u64) -> Frames {
    let mut image = RgbImage::filled(640, 360, [120, 118, 112]).unwrap();
    for y in 0..360 {
        for x in 0..640 {
            if (f64::from(x) - 300.0).hypot(f64::from(y) - 250.0) <= 26.0 {
                image.set_pixel(x, y, [235, 120, 30]);
            }
        }
    }
    let state = RobotState {
        state_stamp: None,
        pose: Pose2::default(),
        pose_covariance: [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-4],
        head: head(0.0),
    };
    let frames: Vec<StoredFrame> = (0..seconds * 10)
        .flat_map(|k| {
            [Camera::Left, Camera::Right].map(|camera| StoredFrame {
                stamp: Stamp(T0 + k * 100_000_000),
                camera,
                image: image.clone(),
                state,
            })
        })
        .collect();
    Frames(frames.into_iter())
}

fn agent() -> Agent {
    Agent::new(
        "miro1",
        Pitch::default(),
        PipelineConfig::default(),
        [miro_lens(), miro_lens()],
        crate::runtime::detector_choice::ChosenDetector::with_classifier(
            crate::runtime::detector_choice::DetectorKind::Dissertation,
            &PipelineConfig::default().detector,
            std::sync::Arc::new(HoughOnly),
        )
        .unwrap(),
    )
}

/// The run's summary and what it handed to the network side.
fn run(args: &RunArgs, publish: bool, seconds: u64) -> (Summary, Vec<Outbound>) {
    let (tx, mut rx) = mpsc::channel(1024);
    let summary = perceive(
        agent(),
        Box::new(frames(seconds)),
        args,
        Arc::new(Mutex::new(None)),
        publish.then_some(tx),
        Arc::new(AtomicBool::new(false)),
        None,
    )
    .unwrap();
    let mut out = Vec::new();
    while let Ok(msg) = rx.try_recv() {
        out.push(msg);
    }
    (summary, out)
}

#[test]
fn views_go_out_at_their_rate_beside_observations_and_status() {
    let (summary, out) = run(&args(&[]), true, 3);
    assert_eq!(summary.frames, 60);
    // 2 Hz per camera over 3 s of frames: due at 0, 0.5, …, 2.5 s, six per camera; a view
    // due while the encoder is busy is dropped, never waited for.
    assert_eq!(
        summary.views_sent + summary.views_dropped,
        12,
        "{summary:?}"
    );
    assert_eq!(summary.views_failed, 0);
    assert!(summary.views_sent >= 1, "{summary:?}");
    let views: Vec<&CameraView> = out
        .iter()
        .filter_map(|m| match m {
            Outbound::View(v) => Some(v),
            _ => None,
        })
        .collect();
    assert_eq!(views.len() as u64, summary.views_sent);
    for (k, v) in views.iter().enumerate() {
        assert_eq!(v.seq, k as u64);
        v.validate(&ValidationContext::new(Pitch::default(), v.stamp))
            .unwrap();
        assert!(v.detector_ms > 0.0);
        // The disc is the ball, drawn at half the frame's scale.
        let ball = v
            .candidates
            .iter()
            .find(|c| c.outcome == proto::CandidateOutcome::Ball)
            .unwrap();
        assert!((ball.u_px - 150.0).abs() < 2.0 && (ball.v_px - 125.0).abs() < 2.0);
    }
    let observations = out
        .iter()
        .filter(|m| matches!(m, Outbound::Observation(_)))
        .count();
    assert_eq!(observations as u64, summary.observations);
    // The status carries both cameras' counters.
    let last = out
        .iter()
        .rev()
        .find_map(|m| match m {
            Outbound::Status(s) => Some(s),
            _ => None,
        })
        .unwrap();
    assert_eq!(last.cameras.len(), 2);
    assert!(last.cameras.iter().all(|c| c.frames >= 20 && c.balls >= 20));
    assert!(
        last.cameras
            .iter()
            .all(|c| (c.frames_per_s - 10.0).abs() < 1.5)
    );
}

#[test]
fn no_views_at_zero_or_offline() {
    let (summary, out) = run(&args(&["--view-hz", "0"]), true, 1);
    assert_eq!(summary.views_sent + summary.views_dropped, 0);
    assert!(!out.iter().any(|m| matches!(m, Outbound::View(_))));
    assert!(out.iter().any(|m| matches!(m, Outbound::Status(_))));
    let (summary, _) = run(&args(&["--offline"]), false, 1);
    assert_eq!(
        (summary.views_sent, summary.views_dropped, summary.frames),
        (0, 0, 20)
    );
}

#[test]
fn view_rates_out_of_range_are_refused_by_the_flag() {
    for bad in ["-1", "31", "NaN", "inf", "fast"] {
        let argv = ["robot-agent", "--robot-id", "miro1", "--view-hz", bad];
        assert!(Cli::try_parse_from(argv).is_err(), "{bad}");
    }
    assert_eq!(args(&[]).view_hz, 2.0);
    assert_eq!(args(&["--view-hz", "0.5"]).view_hz, 0.5);
}

#[test]
fn each_camera_is_perceived_on_its_own_thread_and_accounted_in_order() {
    type Seen = Vec<(Stamp, Camera, Option<u64>)>;
    let seen: Arc<Mutex<Seen>> = Arc::default();
    let threads: Arc<Mutex<std::collections::BTreeSet<String>>> = Arc::default();
    let hook: FrameHook = {
        let (seen, threads) = (seen.clone(), threads.clone());
        Box::new(move |r: &FrameReport<'_>| {
            let seq = r.outcome.observation.as_ref().map(|o| o.seq);
            seen.lock()
                .unwrap()
                .push((r.source_stamp, r.frame.camera, seq));
            // The process's threads by name, while the eyes run.
            if let Ok(tasks) = std::fs::read_dir("/proc/self/task") {
                for task in tasks.flatten() {
                    if let Ok(name) = std::fs::read_to_string(task.path().join("comm")) {
                        threads.lock().unwrap().insert(name.trim().to_string());
                    }
                }
            }
        })
    };
    let summary = perceive(
        agent(),
        Box::new(frames(2)),
        &args(&["--offline"]),
        Arc::new(Mutex::new(None)),
        None,
        Arc::new(AtomicBool::new(false)),
        Some(hook),
    )
    .unwrap();
    let seen = seen.lock().unwrap();
    assert_eq!((summary.frames, seen.len()), (40, 40));
    // Accounted in the order the source gave them: the left then the right frame of each
    // capture time.
    for pair in seen.windows(2) {
        let [(t0, c0, _), (t1, c1, _)] = [pair[0], pair[1]];
        assert!(
            t0 < t1 || (t0 == t1 && c0 == Camera::Left && c1 == Camera::Right),
            "{pair:?}"
        );
    }
    // The observations numbered in that order (each frame holds the ball).
    let seqs: Vec<u64> = seen.iter().filter_map(|s| s.2).collect();
    assert!(seqs.len() >= 30, "{seqs:?}");
    assert_eq!(seqs, (0..seqs.len() as u64).collect::<Vec<u64>>());
    if cfg!(target_os = "linux") {
        let threads = threads.lock().unwrap();
        assert!(
            threads.contains("eye-left") && threads.contains("eye-right"),
            "{threads:?}"
        );
    }
}
