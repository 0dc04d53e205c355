//! The perceive loop: frames from a source through the perception pipeline, observations
//! and status handed to the network side, camera views handed to their encoder thread
//! ([`crate::runtime::views`]), with pacing, restamping, frame recording and a summary. It
//! runs on its own thread (it is CPU-bound and must not stall the network).

use crate::agent::{Agent, FrameOutcome};
use crate::pipeline::FrameResult;
use crate::runtime::RunArgs;
use crate::runtime::eyes::{Done, Eyes};
use crate::runtime::frame::StoredFrame;
use crate::runtime::frames_io::{FolderWriter, McapFrameWriter};
use crate::runtime::source::FrameSource;
use crate::runtime::timer::StageTimer;
use crate::runtime::views::{ViewClock, ViewEncoder, ViewJob};
use crate::runtime::wall_now;
use anyhow::{Context, Result};
use proto::{BallState, CameraView, Observation, RobotStatus, StageTiming, Stamp};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio::sync::mpsc;
use vision::image::RgbImage;

/// What the pipeline thread hands to the network side.
#[derive(Debug)]
pub(crate) enum Outbound {
    Observation(Observation),
    Status(RobotStatus),
    View(CameraView),
}

/// Frames whose pipeline time the summary keeps (about nine hours of both cameras at
/// 15 Hz), so a live agent's memory stays bounded.
const MAX_TIMED_FRAMES: usize = 1_000_000;

/// A live frame more than this late is skipped, seconds.
const MAX_LAG_S: f64 = 0.2;

/// One processed frame, as the loop hands it to a [`FrameHook`].
#[derive(Debug)]
pub struct FrameReport<'a> {
    /// The frame's stamp as its source gave it (before `--restamp`), to pair the frame
    /// with what the caller knows about it.
    pub source_stamp: Stamp,
    /// The frame as processed (restamped with `--restamp`).
    pub frame: &'a StoredFrame,
    /// What the pipeline made of it.
    pub outcome: &'a FrameOutcome,
}

/// Called on the pipeline thread after every processed frame (frames skipped for lag or
/// past `--duration` are not reported).
pub type FrameHook = Box<dyn FnMut(&FrameReport<'_>) + Send>;

/// Counts reported at the end.
#[derive(Debug, Default)]
pub struct Summary {
    pub frames: u64,
    /// Live frames skipped because the pipeline had fallen behind.
    pub skipped: u64,
    pub observations: u64,
    /// The pipeline's time per processed frame, milliseconds (at most
    /// `MAX_TIMED_FRAMES` of them).
    pub total_ms: Vec<f64>,
    /// Camera views built and handed to the network side.
    pub views_sent: u64,
    /// Camera views dropped because the encoder was still busy with the last.
    pub views_dropped: u64,
    /// Camera views that could not be built.
    pub views_failed: u64,
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

/// Runs the pipeline over the source until it ends, `duration` passes or `stop` is set:
/// each camera's frames on that camera's own thread ([`Eyes`]), what they give accounted
/// here in the order the frames came.
pub(crate) fn perceive(
    agent: Agent,
    mut source: Box<dyn FrameSource>,
    args: &RunArgs,
    shared: Arc<Mutex<Option<BallState>>>,
    out: Option<mpsc::Sender<Outbound>>,
    stop: Arc<AtomicBool>,
    hook: Option<FrameHook>,
) -> Result<Summary> {
    let sink = args
        .record_frames
        .as_deref()
        .map(FrameSink::create)
        .transpose()?;
    let mut pacer = Pacer::new(args, source.live());
    let views = Views::start(args, &agent, out.as_ref())?;
    let mut eyes = Eyes::start(&agent)?;
    let mut books = Books {
        agent,
        status: StatusClock::new(args.status_hz),
        views,
        timer: StageTimer::new(),
        summary: Summary::default(),
        last_progress: Instant::now(),
        sink,
        out,
        hook,
    };
    let mut given = 0u64;
    while !stop.load(Ordering::Relaxed) && !launcher_gone(args, &books.agent) {
        let Some(mut frame) = source.next_frame()? else {
            break;
        };
        let source_stamp = frame.stamp;
        match pacer.admit(&mut frame.stamp, given == 0) {
            Admission::End => break,
            Admission::Late => {
                books.summary.skipped += 1;
                continue;
            }
            Admission::Now => {}
        }
        // The camera's eye takes one frame at a time: what came before it is accounted
        // first, in order.
        while eyes.busy(frame.camera) {
            books.take_oldest(&mut eyes)?;
        }
        // A frame that went stale while its camera's eye finished the last one is skipped
        // too, as at admission.
        if pacer.late(frame.stamp) {
            books.summary.skipped += 1;
            continue;
        }
        // Each new state is handed over once; the agent keeps the latest.
        if let Some(state) = shared.lock().ok().and_then(|mut s| s.take()) {
            books.agent.on_ball_state(state);
        }
        fit_calibration(
            &mut books.agent,
            frame.camera,
            &frame.image,
            args.rescale_calibration,
        )?;
        let model = *books.agent.camera_model(frame.camera);
        let ball = books.agent.shared_at(frame.stamp);
        eyes.give(frame, source_stamp, model, ball)?;
        given += 1;
    }
    while books.take_oldest(&mut eyes)? {}
    drop(eyes);
    books.finish()
}

/// What the loop keeps of the frames the eyes give back: the agent's accounts, the
/// summary, and everything a frame's outcome goes to.
struct Books {
    agent: Agent,
    status: StatusClock,
    views: Option<Views>,
    timer: StageTimer,
    summary: Summary,
    last_progress: Instant,
    sink: Option<FrameSink>,
    out: Option<mpsc::Sender<Outbound>>,
    hook: Option<FrameHook>,
}

impl Books {
    /// Accounts the oldest frame the eyes hold (waiting for it); false when they hold none.
    fn take_oldest(&mut self, eyes: &mut Eyes) -> Result<bool> {
        let Some(done) = eyes.take_oldest()? else {
            return Ok(false);
        };
        let Done {
            frame,
            source_stamp,
            result,
            marks,
        } = done;
        self.timer.start();
        for (stage, ms) in &marks {
            self.timer.record(stage, *ms);
        }
        eyes.recycle(frame.camera, marks);
        let result = result.context("pipeline")?;
        let outcome = self.agent.account(&frame.input(), result);
        self.account(&frame, source_stamp, outcome)?;
        Ok(true)
    }

    /// A frame's outcome: the summary, the hook, the observation, the view, the status,
    /// the recording and the progress line.
    fn account(
        &mut self,
        frame: &StoredFrame,
        source_stamp: Stamp,
        outcome: FrameOutcome,
    ) -> Result<()> {
        let frame_ms = self.timer.frame_ms();
        self.agent.record_pipeline_ms(frame.camera, frame_ms);
        let summary = &mut self.summary;
        summary.frames += 1;
        if summary.total_ms.len() < MAX_TIMED_FRAMES {
            summary.total_ms.push(frame_ms);
        }
        if let Some(hook) = &mut self.hook {
            hook(&FrameReport {
                source_stamp,
                frame,
                outcome: &outcome,
            });
        }
        if let Some(o) = outcome.observation {
            summary.observations += 1;
            if let Some(tx) = &self.out {
                let _ = tx.blocking_send(Outbound::Observation(o));
            }
        }
        if let Some(views) = &mut self.views {
            views.offer(frame, outcome.result, frame_ms);
        }
        if let Some(st) = self
            .status
            .due(&mut self.agent, frame, &self.timer, summary.frames)
            && let Some(tx) = &self.out
        {
            let _ = tx.blocking_send(Outbound::Status(st));
        }
        if let Some(sink) = &mut self.sink {
            sink.write(frame)?;
        }
        if self.last_progress.elapsed() >= PROGRESS_EVERY {
            self.last_progress = Instant::now();
            log_progress(&self.agent, &self.summary, &self.timer);
        }
        Ok(())
    }

    /// The views' and the recording's ends, and the summary.
    fn finish(self) -> Result<Summary> {
        let mut summary = self.summary;
        if let Some(views) = self.views {
            let counts = views.encoder.finish();
            summary.views_sent = counts.sent;
            summary.views_dropped = counts.dropped;
            summary.views_failed = counts.failed;
        }
        if let Some(sink) = self.sink {
            sink.finish()?;
        }
        Ok(summary)
    }
}

/// The camera views of a run that publishes: when each is due, and their encoder.
struct Views {
    clock: ViewClock,
    encoder: ViewEncoder,
}

impl Views {
    /// The views of a publishing run (`out`) at `--view-hz`; none offline or at 0.
    fn start(
        args: &RunArgs,
        agent: &Agent,
        out: Option<&mpsc::Sender<Outbound>>,
    ) -> Result<Option<Views>> {
        let Some(out) = out.filter(|_| args.view_hz > 0.0) else {
            return Ok(None);
        };
        let out = out.clone();
        let encoder = ViewEncoder::spawn(agent.robot_id().to_string(), move |view| {
            out.blocking_send(Outbound::View(view)).is_ok()
        })
        .context("starting the view encoder")?;
        Ok(Some(Views {
            clock: ViewClock::new(args.view_hz),
            encoder,
        }))
    }

    /// Hands the frame to the encoder when its camera's view is due (the image is copied
    /// only then); a busy encoder drops it.
    fn offer(&mut self, frame: &StoredFrame, result: FrameResult, detector_ms: f64) {
        if self.clock.due(frame.camera, frame.stamp) {
            self.encoder.offer(ViewJob {
                camera: frame.camera,
                stamp: frame.stamp,
                image: frame.image.clone(),
                result,
                detector_ms,
            });
        }
    }
}

/// How often the loop logs its progress.
const PROGRESS_EVERY: Duration = Duration::from_secs(5);

/// Whether the process that launched this one (`--parent-pid`) is gone: then the agent
/// stops rather than run on as an orphan.
fn launcher_gone(args: &RunArgs, agent: &Agent) -> bool {
    #[cfg(unix)]
    if args
        .parent_pid
        .is_some_and(|p| std::os::unix::process::parent_id() != p)
    {
        tracing::warn!(
            "{}: the launching process is gone; stopping",
            agent.robot_id()
        );
        return true;
    }
    let _ = (args, agent);
    false
}

/// What becomes of a frame from the source.
enum Admission {
    /// Process it.
    Now,
    /// Skip it: a live pipeline that fell behind.
    Late,
    /// Stop: `--duration` has passed.
    End,
}

/// The frames' times: `--duration` from the first frame, `--restamp` onto the wall clock,
/// and pacing to the wall clock for live sources (and restamped recordings).
struct Pacer {
    pace: bool,
    restamp: bool,
    duration_s: Option<f64>,
    first: Option<Stamp>,
    restamp_offset_ns: i128,
}

impl Pacer {
    fn new(args: &RunArgs, live: bool) -> Pacer {
        Pacer {
            pace: !args.fast && (live || args.restamp),
            restamp: args.restamp,
            duration_s: args.duration,
            first: None,
            restamp_offset_ns: 0,
        }
    }

    /// Restamps `stamp` (the offset is taken until a first frame is processed, `before_first`)
    /// and waits for its time when pacing.
    fn admit(&mut self, stamp: &mut Stamp, before_first: bool) -> Admission {
        let first = *self.first.get_or_insert(*stamp);
        if self.duration_s.is_some_and(|d| stamp.secs_since(first) > d) {
            return Admission::End;
        }
        if self.restamp {
            if before_first {
                self.restamp_offset_ns = i128::from(wall_now().0) - i128::from(stamp.0);
            }
            *stamp =
                Stamp(u64::try_from(i128::from(stamp.0) + self.restamp_offset_ns).unwrap_or(0));
        }
        if self.pace {
            let ahead_s = stamp.secs_since(wall_now());
            if ahead_s > 0.0 {
                std::thread::sleep(Duration::from_secs_f64(ahead_s.min(1.0)));
            } else if ahead_s < -MAX_LAG_S {
                // A camera hands over its newest frame: a pipeline that fell behind skips
                // frames instead of publishing stale sightings.
                return Admission::Late;
            }
        }
        Admission::Now
    }

    /// Whether a paced frame is now more than [`MAX_LAG_S`] behind the wall clock.
    fn late(&self, stamp: Stamp) -> bool {
        self.pace && stamp.secs_since(wall_now()) < -MAX_LAG_S
    }
}

/// When the next status is due, at `--status-hz` of frame time.
struct StatusClock {
    started: Instant,
    next: Option<Stamp>,
    dt_s: f64,
}

impl StatusClock {
    fn new(status_hz: f64) -> StatusClock {
        StatusClock {
            started: Instant::now(),
            next: None,
            dt_s: 1.0 / status_hz.max(0.1),
        }
    }

    /// The robot's status at `frame`, if one is due.
    fn due(
        &mut self,
        agent: &mut Agent,
        frame: &StoredFrame,
        timer: &StageTimer,
        frames: u64,
    ) -> Option<RobotStatus> {
        if self.next.is_some_and(|n| frame.stamp < n) {
            return None;
        }
        self.next = Some(frame.stamp.offset_secs(self.dt_s));
        let fps = frames as f64 / self.started.elapsed().as_secs_f64().max(1e-3);
        let timings = timer
            .medians_ms()
            .into_iter()
            .map(|(stage, ms)| StageTiming { stage, ms })
            .collect();
        let s = frame.state;
        Some(agent.status(frame.stamp, s.pose, s.pose_covariance, s.head, fps, timings))
    }
}

fn log_progress(agent: &Agent, summary: &Summary, timer: &StageTimer) {
    let total = timer.medians_ms().last().map_or(0.0, |(_, ms)| *ms);
    tracing::info!(
        "{}: {} frames, {} observations, pipeline median {total:.2} ms/frame, rejected {:?}",
        agent.robot_id(),
        summary.frames,
        summary.observations,
        agent.rejections()
    );
}

/// Checks that `camera`'s calibration is for frames of `image`'s size; a calibration for
/// another size is an error, or with `rescale` is scaled to the frames once (a warning).
fn fit_calibration(
    agent: &mut Agent,
    camera: proto::Camera,
    image: &RgbImage,
    rescale: bool,
) -> Result<()> {
    let model = agent.camera_model(camera);
    let (w, h) = (image.width(), image.height());
    let (cw, ch) = (model.intrinsics.width_px, model.intrinsics.height_px);
    if (cw, ch) == (w, h) {
        return Ok(());
    }
    let fitted = vision::photo::fit_to_photo(model, w, h, rescale).with_context(|| {
        format!("the {camera:?} camera's frames (use --rescale-calibration for a resized stream)")
    })?;
    tracing::warn!(
        "the {camera:?} camera's calibration is for {cw}×{ch} px frames: scaled to the frames' {w}×{h} px"
    );
    agent.set_camera_model(camera, fitted);
    Ok(())
}

/// Prints the frames processed, the observations and the pipeline's time per frame.
pub fn print_summary(agent_id: &str, s: &Summary) {
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
    if s.views_sent + s.views_dropped + s.views_failed > 0 {
        println!(
            "{agent_id}: {} camera views sent, {} dropped (encoder busy), {} failed",
            s.views_sent, s.views_dropped, s.views_failed
        );
    }
}

#[cfg(test)]
#[path = "perceive_tests.rs"]
mod tests;
