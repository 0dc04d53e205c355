//! `robot-agent run`: frames from a source through the perception pipeline, observations
//! and status out over Zenoh, the team's ball state in for validation.
//!
//! The pipeline runs on its own thread (it is CPU-bound and must not stall the network);
//! the Zenoh side runs on the async runtime and takes what to publish from a channel.

use crate::frames_io::{FolderWriter, McapFrameWriter, StoredFrame};
use crate::sources::{Captured, FrameSource, ImagesSource, McapSource, SourceSpec};
use crate::timer::StageTimer;
use anyhow::{Context, Result};
use proto::net::NetConfig;
use proto::{BallState, KeySpace, Observation, Pitch, RobotStatus, StageTiming, Stamp};
use robot_agent::agent::{Agent, FrameInput, PipelineConfig};
use robot_agent::calibrate::Calibration;
use robot_agent::camera::CameraModel;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use tokio::sync::mpsc;

#[derive(Debug, clap::Args)]
pub struct RunArgs {
    #[command(flatten)]
    pub model: crate::defaults::ClassifierArgs,
    /// This robot's id (letters, digits, `_` and `-`).
    #[arg(long)]
    pub robot_id: String,
    /// `sim` (the simulator's rendered cameras), `images:DIR` (a folder with a frames.jsonl
    /// index), `mcap:FILE` (a recording of camera images and robot states, or a MiRo's
    /// ROS 2 bag or converted ROS 1 bag), or `zenoh:ros2` / `zenoh:ros1` (a running MiRo's
    /// ROS topics as a Zenoh ROS bridge publishes them).
    #[arg(long, default_value = "sim")]
    pub source: SourceSpec,
    /// With `--source zenoh:…`: the Zenoh key prefix the bridge puts before the topic
    /// names (none by default).
    #[arg(long, default_value = "")]
    pub ros_key_prefix: String,
    /// Camera calibration from `robot-agent calibrate`: the left camera's, and the right
    /// one's too unless `--calibration-right` is given. Default: the simulated MiRo's.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// The right camera's calibration.
    #[arg(long, requires = "calibration")]
    pub calibration_right: Option<PathBuf>,
    /// When the frames are not the size the calibration was made at (a resized stream),
    /// scale the calibration to them (with a warning) instead of stopping. Frames of
    /// another shape (a crop) are refused either way.
    #[arg(long)]
    pub rescale_calibration: bool,
    /// Pipeline settings (TOML: `[detector]`, `[noise]`, `[validation]`).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Zenoh endpoints to connect to (the server, or a router).
    #[arg(long)]
    pub connect: Vec<String>,
    /// Zenoh endpoints to listen on.
    #[arg(long)]
    pub listen: Vec<String>,
    /// Zenoh mode: peer, client or router.
    #[arg(long, default_value = "peer")]
    pub mode: String,
    /// Key prefix.
    #[arg(long, default_value = proto::DEFAULT_PREFIX)]
    pub prefix: String,
    /// Process frames as fast as possible instead of at their capture times.
    #[arg(long)]
    pub fast: bool,
    /// Shift file frames' stamps so the first one is now (replaying a recording live).
    #[arg(long)]
    pub restamp: bool,
    /// Process without Zenoh and print a summary (offline runs).
    #[arg(long)]
    pub offline: bool,
    /// Stop after this many seconds of frames.
    #[arg(long)]
    pub duration: Option<f64>,
    /// Write the frames processed to an MCAP file (`.mcap`) or an image folder.
    #[arg(long)]
    pub record_frames: Option<PathBuf>,
    /// Status messages per second.
    #[arg(long, default_value_t = 2.0)]
    pub status_hz: f64,
    /// Stop when this process is no longer the parent (a launcher that died).
    #[arg(long, hide = true)]
    pub parent_pid: Option<u32>,
    #[command(flatten)]
    pub sim: crate::sim_source::SimArgs,
    #[command(flatten)]
    pub ros: crate::ros_frames::RosTopics,
}

/// What the pipeline thread hands to the network side.
#[derive(Debug)]
enum Outbound {
    Observation(Observation),
    Status(RobotStatus),
}

/// Frames whose pipeline time the summary keeps (about nine hours of both cameras at
/// 15 Hz), so a live agent's memory stays bounded.
const MAX_TIMED_FRAMES: usize = 1_000_000;

/// A live frame more than this late is skipped, seconds.
const MAX_LAG_S: f64 = 0.2;

/// Counts reported at the end.
#[derive(Debug, Default)]
struct Summary {
    frames: u64,
    /// Live frames skipped because the pipeline had fallen behind.
    skipped: u64,
    observations: u64,
    truth_frames: u64,
    truth_visible: u64,
    truth_hits: u64,
    false_sightings: u64,
    /// Visible balls not found, by what happened to them.
    misses: std::collections::BTreeMap<String, u64>,
    total_ms: Vec<f64>,
}

pub fn wall_now() -> Stamp {
    let d = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap_or_default();
    Stamp(u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

/// The left and right camera models: `left` from a file of `robot-agent calibrate` (or the
/// built-in calibration of the simulated camera), `right` from its own file or else the
/// same as the left.
pub fn load_models(left: Option<&Path>, right: Option<&Path>) -> Result<[CameraModel; 2]> {
    let read = |path: Option<&Path>| -> Result<CameraModel> {
        let (text, name) = match path {
            Some(p) => (
                std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?,
                p.display().to_string(),
            ),
            None => (
                crate::defaults::SIM_CALIBRATION.to_string(),
                "the built-in calibration".to_string(),
            ),
        };
        let c = Calibration::from_toml_str(&text)
            .with_context(|| format!("{name} is not a calibration from `robot-agent calibrate`"))?;
        Ok(c.model)
    };
    let l = read(left)?;
    let r = match right {
        Some(_) => read(right)?,
        None => l,
    };
    Ok([l, r])
}

pub fn load_config(path: Option<&Path>) -> Result<PipelineConfig> {
    match path {
        None => Ok(PipelineConfig::default()),
        Some(p) => {
            let text =
                std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
            toml::from_str(&text).with_context(|| format!("{}: bad pipeline settings", p.display()))
        }
    }
}

enum FrameSink {
    Mcap(Box<McapFrameWriter>),
    Folder(FolderWriter),
}

impl FrameSink {
    fn create(path: &Path) -> Result<Self> {
        if path.extension().is_some_and(|e| e == "mcap") {
            Ok(FrameSink::Mcap(Box::new(McapFrameWriter::create(path)?)))
        } else {
            Ok(FrameSink::Folder(FolderWriter::create(path)?))
        }
    }

    fn write(&mut self, frame: &StoredFrame) -> Result<()> {
        match self {
            FrameSink::Mcap(w) => w.write(frame),
            FrameSink::Folder(w) => w.write(frame),
        }
    }

    fn finish(self) -> Result<()> {
        match self {
            FrameSink::Mcap(w) => w.finish(),
            FrameSink::Folder(w) => w.finish(),
        }
    }
}

/// Runs the pipeline over the source until it ends, `duration` passes or `stop` is set.
fn perceive(
    mut agent: Agent,
    mut source: Box<dyn FrameSource>,
    args: &RunArgs,
    shared: Arc<Mutex<Option<BallState>>>,
    out: Option<mpsc::Sender<Outbound>>,
    stop: Arc<AtomicBool>,
) -> Result<Summary> {
    let pace = !args.fast && (source.live() || args.restamp);
    let mut sink = args
        .record_frames
        .as_deref()
        .map(FrameSink::create)
        .transpose()?;
    let mut timer = StageTimer::new();
    let mut summary = Summary::default();
    let started = Instant::now();
    let mut first: Option<Stamp> = None;
    let mut restamp_offset_ns: i128 = 0;
    let mut next_status: Option<Stamp> = None;
    let mut last_progress = Instant::now();
    let status_dt = 1.0 / args.status_hz.max(0.1);
    while !stop.load(Ordering::Relaxed) {
        #[cfg(unix)]
        if args
            .parent_pid
            .is_some_and(|p| std::os::unix::process::parent_id() != p)
        {
            tracing::warn!(
                "{}: the launching process is gone; stopping",
                agent.robot_id()
            );
            break;
        }
        let Some(Captured { mut frame, truth }) = source.next_frame()? else {
            break;
        };
        let first_stamp = *first.get_or_insert(frame.stamp);
        if args
            .duration
            .is_some_and(|d| frame.stamp.secs_since(first_stamp) > d)
        {
            break;
        }
        if args.restamp {
            if summary.frames == 0 {
                restamp_offset_ns = i128::from(wall_now().0) - i128::from(frame.stamp.0);
            }
            frame.stamp =
                Stamp(u64::try_from(i128::from(frame.stamp.0) + restamp_offset_ns).unwrap_or(0));
        }
        if pace {
            let ahead_s = frame.stamp.secs_since(wall_now());
            if ahead_s > 0.0 {
                std::thread::sleep(Duration::from_secs_f64(ahead_s.min(1.0)));
            } else if ahead_s < -MAX_LAG_S {
                // A camera hands over its newest frame: a pipeline that fell behind skips
                // frames instead of publishing stale sightings.
                summary.skipped += 1;
                continue;
            }
        }
        // Each new state is handed over once; the agent keeps the latest.
        if let Some(state) = shared.lock().ok().and_then(|mut s| s.take()) {
            agent.on_ball_state(state);
        }
        fit_calibration(
            &mut agent,
            frame.camera,
            &frame.image,
            args.rescale_calibration,
        )?;
        let input = FrameInput {
            stamp: frame.stamp,
            camera: frame.camera,
            image: &frame.image,
            pose: frame.state.pose,
            pose_covariance: frame.state.pose_covariance,
            head: frame.state.head,
        };
        timer.start();
        let outcome = agent.on_frame(&input, &mut timer).context("pipeline")?;
        summary.frames += 1;
        if summary.total_ms.len() < MAX_TIMED_FRAMES {
            summary.total_ms.push(timer.frame_ms());
        }
        if let Some(t) = &truth {
            summary.truth_frames += 1;
            let visible = t.in_frame
                && t.visible_fraction >= 0.5
                && t.radius_px >= 4.0
                && t.center_px.is_some_and(|c| on_image(c, &frame.image));
            summary.truth_visible += u64::from(visible);
            let near = |p: [f64; 2]| {
                t.center_px
                    .is_some_and(|c| (p[0] - c[0]).hypot(p[1] - c[1]) <= t.radius_px.max(4.0))
            };
            let hit = outcome
                .observation
                .as_ref()
                .and_then(|o| o.pixel)
                .is_some_and(|p| near([p.u_px, p.v_px]));
            summary.truth_hits += u64::from(hit && visible);
            summary.false_sightings += u64::from(outcome.observation.is_some() && !hit);
            if visible && !hit {
                let why = outcome
                    .result
                    .rejected
                    .iter()
                    .find(|(c, _)| near(c.center_px))
                    .map_or_else(
                        || "no candidate".to_string(),
                        |(_, why)| why.reason().to_string(),
                    );
                *summary.misses.entry(why).or_default() += 1;
            }
        }
        if let Some(o) = outcome.observation {
            summary.observations += 1;
            if let Some(tx) = &out {
                let _ = tx.blocking_send(Outbound::Observation(o));
            }
        }
        if next_status.is_none_or(|n| frame.stamp >= n) {
            next_status = Some(frame.stamp.offset_secs(status_dt));
            let fps = summary.frames as f64 / started.elapsed().as_secs_f64().max(1e-3);
            let timings = timer
                .medians_ms()
                .into_iter()
                .map(|(stage, ms)| StageTiming { stage, ms })
                .collect();
            let s = frame.state;
            let status = agent.status(frame.stamp, s.pose, s.pose_covariance, s.head, fps, timings);
            if let Some(tx) = &out {
                let _ = tx.blocking_send(Outbound::Status(status));
            }
        }
        if let Some(sink) = &mut sink {
            sink.write(&frame)?;
        }
        if last_progress.elapsed() >= Duration::from_secs(5) {
            last_progress = Instant::now();
            let total = timer.medians_ms().last().map_or(0.0, |(_, ms)| *ms);
            tracing::info!(
                "{}: {} frames, {} observations, pipeline median {total:.2} ms/frame, rejected {:?}",
                agent.robot_id(),
                summary.frames,
                summary.observations,
                agent.rejections()
            );
        }
    }
    if let Some(sink) = sink {
        sink.finish()?;
    }
    Ok(summary)
}

/// Checks that `camera`'s calibration is for frames of `image`'s size; a calibration for
/// another size is an error, or with `rescale` is scaled to the frames once (a warning).
fn fit_calibration(
    agent: &mut Agent,
    camera: proto::Camera,
    image: &robot_agent::image::RgbImage,
    rescale: bool,
) -> Result<()> {
    let model = agent.camera_model(camera);
    let (w, h) = (image.width(), image.height());
    let (cw, ch) = (model.intrinsics.width_px, model.intrinsics.height_px);
    if (cw, ch) == (w, h) {
        return Ok(());
    }
    let fitted = robot_agent::photo::fit_to_photo(model, w, h, rescale).with_context(|| {
        format!("the {camera:?} camera's frames (use --rescale-calibration for a resized stream)")
    })?;
    tracing::warn!(
        "the {camera:?} camera's calibration is for {cw}×{ch} px frames: scaled to the frames' {w}×{h} px"
    );
    agent.set_camera_model(camera, fitted);
    Ok(())
}

/// Whether a pixel lies on the image.
fn on_image(p: [f64; 2], image: &robot_agent::image::RgbImage) -> bool {
    (0.0..f64::from(image.width())).contains(&p[0])
        && (0.0..f64::from(image.height())).contains(&p[1])
}

async fn open_source(
    args: &RunArgs,
    session: Option<&zenoh::Session>,
    stop: &Arc<AtomicBool>,
) -> Result<Box<dyn FrameSource>> {
    Ok(match &args.source {
        SourceSpec::Zenoh(encoding) => {
            let session = session.context("a live source needs the Zenoh session")?;
            Box::new(
                crate::live_ros::LiveRosSource::open(
                    session,
                    &args.ros,
                    *encoding,
                    &args.ros_key_prefix,
                    stop.clone(),
                )
                .await?,
            )
        }
        SourceSpec::Sim => Box::new(crate::sim_source::SimSource::new(
            &args.robot_id,
            &args.sim,
            wall_now(),
        )?),
        SourceSpec::Images(dir) => Box::new(ImagesSource::open(dir.clone())?),
        SourceSpec::Mcap(file) => Box::new(McapSource::open(file.clone(), &args.ros)?),
    })
}

fn print_summary(agent_id: &str, s: &Summary) {
    let mut ms = s.total_ms.clone();
    ms.sort_by(f64::total_cmp);
    let q = |p: f64| {
        ms.get(((ms.len() as f64 - 1.0) * p).round() as usize)
            .copied()
            .unwrap_or(f64::NAN)
    };
    if ms.is_empty() {
        println!("{agent_id}: 0 frames, 0 observations");
    } else {
        println!(
            "{agent_id}: {} frames, {} observations; pipeline per frame median {:.2} ms, p99 {:.2} ms",
            s.frames,
            s.observations,
            q(0.5),
            q(0.99)
        );
    }
    if s.skipped > 0 {
        println!(
            "{agent_id}: {} frames skipped because the pipeline fell behind",
            s.skipped
        );
    }
    if s.truth_frames > 0 {
        let recall = s.truth_hits as f64 / s.truth_visible.max(1) as f64;
        let precision = s.truth_hits as f64 / (s.truth_hits + s.false_sightings).max(1) as f64;
        println!(
            "against the simulator's truth: ball visible in {} frames, found in {} (recall {:.1} %), {} false sightings (precision {:.1} %)",
            s.truth_visible,
            s.truth_hits,
            100.0 * recall,
            s.false_sightings,
            100.0 * precision
        );
        for (why, n) in &s.misses {
            println!("  missed: {why}: {n}");
        }
    }
}

pub async fn run(args: RunArgs) -> Result<()> {
    anyhow::ensure!(
        proto::is_valid_id(&args.robot_id),
        "robot id {:?} is not valid",
        args.robot_id
    );
    let models = load_models(
        args.calibration.as_deref(),
        args.calibration_right.as_deref(),
    )?;
    let config = load_config(args.config.as_deref())?;
    let classifier =
        crate::defaults::classifier(&config.detector, args.model.classifier.as_deref())?;
    let agent = Agent::new(&args.robot_id, Pitch::default(), config, models, classifier)?;
    let stop = Arc::new(AtomicBool::new(false));
    let net = NetConfig {
        mode: args.mode.clone(),
        listen: args.listen.clone(),
        connect: args.connect.clone(),
        ..NetConfig::default()
    };
    // A live source needs the session even offline (to subscribe, not to publish).
    let session = if !args.offline || matches!(args.source, SourceSpec::Zenoh(_)) {
        Some(net.open().await.context("opening the Zenoh session")?)
    } else {
        None
    };
    let source = open_source(&args, session.as_ref(), &stop).await?;
    {
        let stop = stop.clone();
        tokio::spawn(async move {
            if tokio::signal::ctrl_c().await.is_ok() {
                stop.store(true, Ordering::Relaxed);
            }
        });
    }
    let shared: Arc<Mutex<Option<BallState>>> = Arc::new(Mutex::new(None));
    let id = args.robot_id.clone();
    if args.offline {
        let args = Arc::new(args);
        let a = args.clone();
        let summary =
            tokio::task::spawn_blocking(move || perceive(agent, source, &a, shared, None, stop))
                .await??;
        print_summary(&id, &summary);
        return Ok(());
    }
    let keys = KeySpace::new(&args.prefix)?;
    let session = session.context("no Zenoh session")?;
    let token = session
        .liveliness()
        .declare_token(keys.robot_liveliness(&id)?)
        .await
        .map_err(|e| anyhow::anyhow!("liveliness token: {e}"))?;
    let obs_pub = session
        .declare_publisher(keys.robot_obs(&id)?)
        .express(true)
        .await
        .map_err(|e| anyhow::anyhow!("observation publisher: {e}"))?;
    let status_pub = session
        .declare_publisher(keys.robot_status(&id)?)
        .await
        .map_err(|e| anyhow::anyhow!("status publisher: {e}"))?;
    let bad_states = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let subscriber = {
        let (shared, bad) = (shared.clone(), bad_states.clone());
        session
            .declare_subscriber(keys.ball_state())
            .callback(move |sample| {
                match proto::decode::<BallState>(&sample.payload().to_bytes()) {
                    Ok(state) => {
                        if let Ok(mut s) = shared.lock() {
                            *s = Some(state);
                        }
                    }
                    Err(_) => {
                        bad.fetch_add(1, Ordering::Relaxed);
                    }
                }
            })
            .await
            .map_err(|e| anyhow::anyhow!("ball state subscriber: {e}"))?
    };
    tracing::info!(
        "{id}: publishing on {} and {}",
        keys.robot_obs(&id)?,
        keys.robot_status(&id)?
    );
    let (tx, mut rx) = mpsc::channel::<Outbound>(256);
    let args = Arc::new(args);
    let a = args.clone();
    let worker =
        tokio::task::spawn_blocking(move || perceive(agent, source, &a, shared, Some(tx), stop));
    while let Some(msg) = rx.recv().await {
        let result = match msg {
            Outbound::Observation(o) => obs_pub.put(proto::encode(&o)).await,
            Outbound::Status(s) => status_pub.put(proto::encode(&s)).await,
        };
        if let Err(e) = result {
            tracing::warn!("publishing: {e}");
        }
    }
    let summary = worker.await??;
    print_summary(&id, &summary);
    let bad = bad_states.load(Ordering::Relaxed);
    if bad > 0 {
        tracing::warn!("{bad} ball state message(s) could not be decoded");
    }
    let _ = subscriber.undeclare().await;
    let _ = token.undeclare().await;
    let _ = session.close().await;
    Ok(())
}
