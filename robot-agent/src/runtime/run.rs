//! The agent's run: the models and the pipeline set up from the flags, a frame source
//! opened, the perceive loop on its own thread and the Zenoh side on the async runtime
//! (observations, status and camera views out, the team's ball state in for validation,
//! liveliness).

use crate::agent::Agent;
use crate::runtime::detector_choice::DetectorArgs;
use crate::runtime::models::{load_config, load_models};
use crate::runtime::perceive::{FrameHook, Outbound, Summary, perceive, print_summary};
use crate::runtime::ros_frames::RosTopics;
use crate::runtime::source::{FrameSource, ImagesSource, McapSource, SourceSpec};
use crate::runtime::views::check_view_hz;
use anyhow::{Context, Result};
use proto::net::NetConfig;
use proto::{BallState, Camera, KeySpace, Pitch};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use tokio::sync::mpsc;

/// The flags of a run, whatever the source (the `--source` flag is the caller's: the
/// product's names a file or live source, a tool brings its own).
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    #[command(flatten)]
    pub detector: DetectorArgs,
    /// This robot's id (letters, digits, `_` and `-`).
    #[arg(long)]
    pub robot_id: String,
    /// With `--source zenoh:…`: the Zenoh key prefix the bridge puts before the topic
    /// names (none by default).
    #[arg(long, default_value = "")]
    pub ros_key_prefix: String,
    /// Camera calibration from `ball-lab calibrate`: the left camera's, and the right
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
    /// Pipeline settings (TOML: `[detector]` tuning, `[noise]`, `[validation]`).
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
    /// TLS with mutual authentication: DIR holds this robot's ca.pem, cert.pem and key.pem
    /// (`fusion-server keys` writes it). Endpoints must then be tls/HOST:PORT.
    #[arg(long, value_name = "DIR")]
    pub tls: Option<PathBuf>,
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
    /// Camera views per second per camera (a small JPEG of a frame with the detector's
    /// candidates, built on a thread of its own; dropped while it is busy); 0 turns them
    /// off, at most 30. Offline runs build none.
    #[arg(long, default_value_t = 2.0, value_parser = parse_view_hz)]
    pub view_hz: f64,
    /// Stop when this process is no longer the parent (a launcher that died).
    #[arg(long, hide = true)]
    pub parent_pid: Option<u32>,
    #[command(flatten)]
    pub ros: RosTopics,
}

/// `--view-hz`: a number [`check_view_hz`] accepts.
fn parse_view_hz(text: &str) -> Result<f64, String> {
    let hz: f64 = text.parse().map_err(|e| format!("{text:?}: {e}"))?;
    check_view_hz(hz)
}

/// Where a run's frames come from.
pub enum Source {
    /// A source the runtime opens: an image folder, a recording or live ROS over Zenoh.
    Spec(SourceSpec),
    /// A source the caller opened.
    Given(Box<dyn FrameSource>),
}

impl std::fmt::Debug for Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Source::Spec(spec) => f.debug_tuple("Spec").field(spec).finish(),
            Source::Given(_) => f.write_str("Given(..)"),
        }
    }
}

async fn open_source(
    args: &RunArgs,
    source: Source,
    session: Option<&zenoh::Session>,
    stop: &Arc<AtomicBool>,
) -> Result<Box<dyn FrameSource>> {
    let spec = match source {
        Source::Given(source) => return Ok(source),
        Source::Spec(spec) => spec,
    };
    Ok(match spec {
        SourceSpec::Zenoh(encoding) => {
            let session = session.context("a live source needs the Zenoh session")?;
            Box::new(
                crate::runtime::live_ros::LiveRosSource::open(
                    session,
                    &args.ros,
                    encoding,
                    &args.ros_key_prefix,
                    stop.clone(),
                )
                .await?,
            )
        }
        SourceSpec::Ros1 => Box::new(
            crate::runtime::ros1_source::Ros1Source::open(&args.ros, &args.robot_id, stop.clone())
                .await?,
        ),
        SourceSpec::Images(dir) => Box::new(ImagesSource::open(dir)?),
        SourceSpec::Mcap(file) => Box::new(McapSource::open(file, &args.ros)?),
    })
}

/// Runs the agent until the source ends, `--duration` passes or Ctrl-C: the perceive loop
/// over `source`, publishing over Zenoh unless `--offline`, `hook` called after every
/// processed frame. Prints the summary and returns it.
pub async fn run(args: RunArgs, source: Source, hook: Option<FrameHook>) -> Result<Summary> {
    anyhow::ensure!(
        proto::is_valid_id(&args.robot_id),
        "robot id {:?} is not valid",
        args.robot_id
    );
    check_view_hz(args.view_hz).map_err(|e| anyhow::anyhow!("--view-hz: {e}"))?;
    let models = load_models(
        args.calibration.as_deref(),
        args.calibration_right.as_deref(),
    )?;
    let config = load_config(args.config.as_deref())?;
    let chosen = args.detector.choose(&config.detector)?;
    tracing::info!("{}: {}", args.robot_id, chosen.describe());
    let agent = Agent::new(&args.robot_id, Pitch::default(), config, models, chosen);
    let stop = Arc::new(AtomicBool::new(false));
    let net = NetConfig {
        mode: args.mode.clone(),
        listen: args.listen.clone(),
        connect: args.connect.clone(),
        tls: args.tls.as_deref().map(proto::net::TlsFiles::in_dir),
        ..NetConfig::default()
    };
    // A live source needs the session even offline (to subscribe, not to publish).
    let session = if !args.offline || matches!(source, Source::Spec(SourceSpec::Zenoh(_))) {
        Some(net.open().await.context("opening the Zenoh session")?)
    } else {
        None
    };
    let source = open_source(&args, source, session.as_ref(), &stop).await?;
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
        let summary = tokio::task::spawn_blocking(move || {
            perceive(agent, source, &a, shared, None, stop, hook)
        })
        .await??;
        print_summary(&id, &summary);
        return Ok(summary);
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
    // Views yield to observations and status, and are dropped rather than queued when the
    // network is congested.
    let mut view_pubs = Vec::with_capacity(2);
    for camera in [Camera::Left, Camera::Right] {
        let publisher = session
            .declare_publisher(keys.robot_view(&id, camera)?)
            .priority(zenoh::qos::Priority::DataLow)
            .congestion_control(zenoh::qos::CongestionControl::Drop)
            .await
            .map_err(|e| anyhow::anyhow!("view publisher: {e}"))?;
        view_pubs.push((camera, publisher));
    }
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
    if args.view_hz > 0.0 {
        tracing::info!(
            "{id}: camera views at {} Hz per camera on {}",
            args.view_hz,
            keys.robot_view(&id, Camera::Left)?
                .replace("/left", "/{left|right}")
        );
    }
    let (tx, mut rx) = mpsc::channel::<Outbound>(256);
    let args = Arc::new(args);
    let a = args.clone();
    let worker = tokio::task::spawn_blocking(move || {
        perceive(agent, source, &a, shared, Some(tx), stop, hook)
    });
    while let Some(msg) = rx.recv().await {
        let result = match msg {
            Outbound::Observation(o) => obs_pub.put(proto::encode(&o)).await,
            Outbound::Status(s) => status_pub.put(proto::encode(&s)).await,
            Outbound::View(v) => match view_pubs.iter().find(|(c, _)| *c == v.camera) {
                Some((_, publisher)) => publisher.put(proto::encode(&v)).await,
                None => Ok(()),
            },
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
    Ok(summary)
}
