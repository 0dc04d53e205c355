//! Camera views off the perception thread: when each camera's next view is due (by frame
//! stamp, [`ViewClock`]), and the view encoder ([`ViewEncoder`]): a thread that builds each
//! view ([`crate::view::camera_view`]) and hands it to the network side. The perceive loop
//! hands a frame over without ever waiting: while the encoder is busy, views are dropped
//! and counted.

use crate::pipeline::FrameResult;
use crate::view::camera_view;
use proto::{Camera, CameraView, Stamp};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use vision::image::RgbImage;

/// Most views per second per camera `--view-hz` accepts.
pub const MAX_VIEW_HZ: f64 = 30.0;

/// A failed view is logged at most this often (each one is counted).
const WARN_EVERY: Duration = Duration::from_secs(5);

/// Checks a views-per-second rate: finite, 0 (no views) to [`MAX_VIEW_HZ`].
pub fn check_view_hz(view_hz: f64) -> Result<f64, String> {
    if view_hz.is_finite() && (0.0..=MAX_VIEW_HZ).contains(&view_hz) {
        Ok(view_hz)
    } else {
        Err(format!(
            "views per second must be between 0 and {MAX_VIEW_HZ}, not {view_hz}"
        ))
    }
}

/// When each camera's next view is due, at a rate of frame time.
#[derive(Debug, Clone)]
pub(crate) struct ViewClock {
    /// Seconds between a camera's views; `None`: no views.
    period_s: Option<f64>,
    /// Each camera's next due stamp (left, right).
    next: [Option<Stamp>; 2],
}

impl ViewClock {
    /// Views at `view_hz` per camera; 0 (or anything not positive and finite): never.
    pub(crate) fn new(view_hz: f64) -> ViewClock {
        ViewClock {
            period_s: (view_hz.is_finite() && view_hz > 0.0).then(|| 1.0 / view_hz),
            next: [None; 2],
        }
    }

    /// Whether `camera`'s frame at `stamp` is to be viewed. Views keep their rate on
    /// average (the next is due a period after the last was due, not after the frame that
    /// took it); after a gap, or when time went back (a recording replayed again), the
    /// schedule starts over from the frame.
    pub(crate) fn due(&mut self, camera: Camera, stamp: Stamp) -> bool {
        let Some(period_s) = self.period_s else {
            return false;
        };
        let next = &mut self.next[match camera {
            Camera::Left => 0,
            Camera::Right => 1,
        }];
        match *next {
            Some(n) if stamp < n && n.secs_since(stamp) <= period_s => false,
            Some(n) if stamp >= n && stamp.secs_since(n) < period_s => {
                *next = Some(n.offset_secs(period_s));
                true
            }
            _ => {
                *next = Some(stamp.offset_secs(period_s));
                true
            }
        }
    }
}

/// What the encoder needs of a frame to view it.
#[derive(Debug)]
pub(crate) struct ViewJob {
    pub camera: Camera,
    pub stamp: Stamp,
    /// A copy of the frame.
    pub image: RgbImage,
    pub result: FrameResult,
    /// The pipeline's time on the frame, milliseconds.
    pub detector_ms: f64,
}

/// The perceive loop's end of the hand-off: never waits.
#[derive(Debug)]
pub(crate) struct ViewHandoff {
    tx: SyncSender<ViewJob>,
    dropped: u64,
}

impl ViewHandoff {
    /// A hand-off holding at most one job while the encoder works on another, and the
    /// encoder's end.
    pub(crate) fn new() -> (ViewHandoff, Receiver<ViewJob>) {
        let (tx, rx) = sync_channel(1);
        (ViewHandoff { tx, dropped: 0 }, rx)
    }

    /// Hands `job` over if the encoder can take it now; otherwise drops it and counts it.
    /// Whether it was handed over.
    pub(crate) fn offer(&mut self, job: ViewJob) -> bool {
        match self.tx.try_send(job) {
            Ok(()) => true,
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                self.dropped += 1;
                false
            }
        }
    }

    /// Views dropped because the encoder was busy (or gone).
    pub(crate) fn dropped(&self) -> u64 {
        self.dropped
    }
}

/// What became of the views.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct ViewCounts {
    /// Built and handed to the network side.
    pub sent: u64,
    /// Dropped because the encoder was still busy.
    pub dropped: u64,
    /// Could not be built.
    pub failed: u64,
}

/// The view-encoding thread and the hand-off to it.
#[derive(Debug)]
pub(crate) struct ViewEncoder {
    handoff: ViewHandoff,
    thread: JoinHandle<ViewCounts>,
}

impl ViewEncoder {
    /// Starts the thread; each view it builds goes to `publish` (false: it could not be
    /// sent).
    pub(crate) fn spawn(
        robot_id: String,
        publish: impl FnMut(CameraView) -> bool + Send + 'static,
    ) -> std::io::Result<ViewEncoder> {
        let (handoff, rx) = ViewHandoff::new();
        let thread = std::thread::Builder::new()
            .name("views".into())
            .spawn(move || encode_views(&robot_id, &rx, publish))?;
        Ok(ViewEncoder { handoff, thread })
    }

    /// See [`ViewHandoff::offer`].
    pub(crate) fn offer(&mut self, job: ViewJob) -> bool {
        self.handoff.offer(job)
    }

    /// Lets the thread finish the views handed over, and counts.
    pub(crate) fn finish(self) -> ViewCounts {
        let dropped = self.handoff.dropped();
        drop(self.handoff);
        let built = self.thread.join().unwrap_or_else(|_| {
            tracing::warn!("the view encoder stopped with a panic");
            ViewCounts::default()
        });
        ViewCounts { dropped, ..built }
    }
}

/// Builds a view of every job until the hand-off closes; views are numbered in order.
fn encode_views(
    robot_id: &str,
    rx: &Receiver<ViewJob>,
    mut publish: impl FnMut(CameraView) -> bool,
) -> ViewCounts {
    let mut counts = ViewCounts::default();
    let mut seq = 0;
    let mut warned: Option<Instant> = None;
    for job in rx.iter() {
        let view = camera_view(
            robot_id,
            seq,
            job.camera,
            job.stamp,
            &job.image,
            &job.result,
            job.detector_ms,
        );
        match view {
            Ok(view) => {
                seq += 1;
                if publish(view) {
                    counts.sent += 1;
                }
            }
            Err(e) => {
                counts.failed += 1;
                if warned.is_none_or(|t| t.elapsed() >= WARN_EVERY) {
                    warned = Some(Instant::now());
                    tracing::warn!(
                        "{robot_id}: no view of the {:?} camera's frame: {e} ({} view(s) failed so far)",
                        job.camera,
                        counts.failed
                    );
                }
            }
        }
    }
    counts
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use std::sync::mpsc::channel;

    const S: u64 = 1_000_000_000;

    fn job(camera: Camera, stamp: Stamp) -> ViewJob {
        ViewJob {
            camera,
            stamp,
            image: RgbImage::filled(64, 36, [100, 120, 100]).unwrap(),
            result: FrameResult::default(),
            detector_ms: 2.0,
        }
    }

    /// Views of `camera` among frames at `fps` for `seconds` from 100 s.
    fn count_due(clock: &mut ViewClock, camera: Camera, fps: u64, seconds: u64) -> usize {
        (0..fps * seconds)
            .filter(|k| clock.due(camera, Stamp(100 * S + k * S / fps)))
            .count()
    }

    #[test]
    fn views_are_due_at_the_rate_per_camera_by_stamp() {
        let mut clock = ViewClock::new(2.0);
        // Frames at 15 Hz for 10 s: 20 views, not one per 8 frames (18.75).
        assert_eq!(count_due(&mut clock, Camera::Left, 15, 10), 20);
        // The other camera has its own schedule.
        assert_eq!(count_due(&mut clock, Camera::Right, 15, 10), 20);
        // Slower frames than views: every frame.
        let mut clock = ViewClock::new(2.0);
        assert_eq!(count_due(&mut clock, Camera::Left, 1, 10), 10);
        // The first frame is viewed; one a period later is the next.
        let mut clock = ViewClock::new(4.0);
        assert!(clock.due(Camera::Left, Stamp(S)));
        assert!(!clock.due(Camera::Left, Stamp(S + S / 5)));
        assert!(clock.due(Camera::Left, Stamp(S + S / 4)));
        // Time going back (a recording again) starts over.
        assert!(clock.due(Camera::Left, Stamp(S / 10)));
        assert!(!clock.due(Camera::Left, Stamp(S / 10 + 1)));
    }

    #[test]
    fn zero_views_per_second_is_never() {
        let mut clock = ViewClock::new(0.0);
        assert_eq!(count_due(&mut clock, Camera::Left, 30, 5), 0);
        assert_eq!(count_due(&mut clock, Camera::Right, 30, 5), 0);
    }

    #[test]
    fn view_rates_are_checked() {
        assert_eq!(check_view_hz(0.0), Ok(0.0));
        assert_eq!(check_view_hz(2.0), Ok(2.0));
        assert_eq!(check_view_hz(30.0), Ok(30.0));
        for bad in [-0.5, 30.5, f64::NAN, f64::INFINITY] {
            assert!(check_view_hz(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn a_busy_encoder_drops_and_counts_instead_of_waiting() {
        // Nobody takes the jobs: the first waits in the hand-off, the rest are dropped.
        let (mut handoff, _rx) = ViewHandoff::new();
        let started = Instant::now();
        let taken: Vec<bool> = (0..5)
            .map(|k| handoff.offer(job(Camera::Left, Stamp(k * S))))
            .collect();
        assert_eq!(taken, [true, false, false, false, false]);
        assert_eq!(handoff.dropped(), 4);
        assert!(started.elapsed() < Duration::from_secs(1));
    }

    #[test]
    fn the_encoder_sends_views_and_drops_while_busy() {
        // The network side holds the first view until released: the encoder is busy.
        let (release_tx, release_rx) = channel::<()>();
        let (views_tx, views_rx) = channel::<CameraView>();
        let mut encoder = ViewEncoder::spawn("miro1".into(), move |view| {
            if view.seq == 0 {
                release_rx.recv().ok();
            }
            views_tx.send(view).is_ok()
        })
        .unwrap();
        assert!(encoder.offer(job(Camera::Left, Stamp(S))));
        // Until the encoder has taken the first job out of the hand-off, a second may be
        // refused; once it has, one waits and the rest are dropped.
        let mut waiting = false;
        let deadline = Instant::now() + Duration::from_secs(10);
        while !waiting && Instant::now() < deadline {
            waiting = encoder.offer(job(Camera::Right, Stamp(2 * S)));
            std::thread::yield_now();
        }
        assert!(waiting, "the encoder never took the first view");
        for k in 0..3 {
            assert!(!encoder.offer(job(Camera::Left, Stamp((3 + k) * S))));
        }
        release_tx.send(()).unwrap();
        let counts = encoder.finish();
        assert_eq!((counts.sent, counts.failed), (2, 0));
        assert!(counts.dropped >= 3, "{counts:?}");
        let views: Vec<CameraView> = views_rx.iter().collect();
        let seqs: Vec<(u64, Camera)> = views.iter().map(|v| (v.seq, v.camera)).collect();
        assert_eq!(seqs, [(0, Camera::Left), (1, Camera::Right)]);
    }

    #[test]
    fn a_view_that_fails_is_counted_and_the_encoder_goes_on() {
        let (views_tx, views_rx) = channel::<CameraView>();
        let mut encoder =
            ViewEncoder::spawn("miro1".into(), move |view| views_tx.send(view).is_ok()).unwrap();
        let mut bad = job(Camera::Left, Stamp(S));
        bad.detector_ms = f64::NAN;
        assert!(encoder.offer(bad));
        // Waits for room rather than racing the encoder.
        let deadline = Instant::now() + Duration::from_secs(10);
        while !encoder.offer(job(Camera::Left, Stamp(2 * S))) {
            assert!(Instant::now() < deadline);
            std::thread::yield_now();
        }
        let counts = encoder.finish();
        assert_eq!((counts.sent, counts.failed), (1, 1), "{counts:?}");
        assert_eq!(views_rx.iter().map(|v| v.seq).collect::<Vec<_>>(), [0]);
    }
}
