//! A match log played back as if live, under control: the server's clock runs through the
//! recorded match and can be paused, sped up or slowed down, and moved to any time of the
//! log (the engine is then re-fused up to that time, see [`crate::matchlog::replay::Seeker`]).
//! The HTTP control endpoints ([`crate::shell::http`]) drive a [`ReplayControl`]; [`play`] is the
//! loop that hands each recorded input over when the clock reaches it.

use crate::clock::Clock;
use crate::engine::EngineConfig;
use crate::matchlog::read::LogMessage;
use crate::matchlog::replay::{Seeker, is_input, is_view, views_before};
use crate::shell::live::Live;
use futures_util::future::BoxFuture;
use proto::{KeySpace, Stamp};
use serde::Serialize;
use std::future::Future;
use std::sync::atomic::Ordering::Relaxed;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};
use tokio::sync::Notify;

/// Slowest and fastest playback.
pub const SPEED_RANGE: (f64, f64) = (0.05, 64.0);

/// After a seek, how long the loop waits at most for the inputs it already handed over to
/// land (over Zenoh) before it replaces the engine: a late one would meet the new clock.
const SETTLE_MAX: Duration = Duration::from_secs(1);

#[derive(Debug, Clone, Copy)]
struct ClockState {
    /// The recorded time at `wall`.
    at: Stamp,
    wall: Instant,
    speed: f64,
    paused: bool,
}

/// Recorded time that runs `speed` times as fast as the wall clock, stops when paused and
/// jumps when moved.
#[derive(Debug)]
pub struct ReplayClock {
    state: Mutex<ClockState>,
}

impl ReplayClock {
    pub fn new(at: Stamp, speed: f64) -> Self {
        ReplayClock {
            state: Mutex::new(ClockState {
                at,
                wall: Instant::now(),
                speed,
                paused: false,
            }),
        }
    }

    fn lock(&self) -> MutexGuard<'_, ClockState> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn read(s: &ClockState) -> Stamp {
        if s.paused {
            s.at
        } else {
            s.at.offset_secs(s.wall.elapsed().as_secs_f64() * s.speed)
        }
    }

    /// Applies `f` to the clock from its current reading.
    fn rebase(&self, f: impl FnOnce(&mut ClockState)) {
        let mut s = self.lock();
        s.at = Self::read(&s);
        s.wall = Instant::now();
        f(&mut s);
    }

    /// Wall time until the clock reads `at`: zero when it is past, `None` while paused.
    pub fn wall_until(&self, at: Stamp) -> Option<Duration> {
        let s = self.lock();
        if s.paused {
            return None;
        }
        let dt_s = at.secs_since(Self::read(&s)) / s.speed;
        Some(Duration::from_secs_f64(dt_s.max(0.0)))
    }

    pub fn speed(&self) -> f64 {
        self.lock().speed
    }

    pub fn paused(&self) -> bool {
        self.lock().paused
    }
}

impl Clock for ReplayClock {
    fn now(&self) -> Stamp {
        Self::read(&self.lock())
    }
}

/// Why a control request was refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ControlError {
    #[error("speed must be a number from {lo} to {hi}, got {0}", lo = SPEED_RANGE.0, hi = SPEED_RANGE.1)]
    Speed(f64),
    #[error("t_s must be a number from 0 to the log's length, {duration_s:.3} s, got {t_s}")]
    Time { t_s: f64, duration_s: f64 },
}

/// Where a replay stands, as `GET /api/replay` and the live stream report it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReplayStatus {
    pub paused: bool,
    pub speed: f64,
    /// Match time: seconds since the log's first message.
    pub t_s: f64,
    /// The log's length, seconds.
    pub duration_s: f64,
    /// The log's first and last message times.
    pub start: Stamp,
    pub end: Stamp,
    /// Every message has been played (the clock stands at the end).
    pub ended: bool,
}

/// The shared handle between the control endpoints and the playing loop.
#[derive(Debug)]
pub struct ReplayControl {
    pub clock: Arc<ReplayClock>,
    start: Stamp,
    end: Stamp,
    /// A seek the loop has not carried out yet.
    pending_seek: Mutex<Option<Stamp>>,
    ended: Mutex<bool>,
    changed: Notify,
}

impl ReplayControl {
    /// Control over a log running from `start` to `end`, playing at `speed` from the start.
    pub fn new(start: Stamp, end: Stamp, speed: f64) -> Result<Self, ControlError> {
        check_speed(speed)?;
        Ok(ReplayControl {
            clock: Arc::new(ReplayClock::new(start, speed)),
            start,
            end: end.max(start),
            pending_seek: Mutex::new(None),
            ended: Mutex::new(false),
            changed: Notify::new(),
        })
    }

    pub fn duration_s(&self) -> f64 {
        self.end.secs_since(self.start)
    }

    pub fn status(&self) -> ReplayStatus {
        let now = self.clock.now();
        ReplayStatus {
            paused: self.clock.paused(),
            speed: self.clock.speed(),
            t_s: now.secs_since(self.start),
            duration_s: self.duration_s(),
            start: self.start,
            end: self.end,
            ended: *self.ended.lock().unwrap_or_else(|p| p.into_inner()),
        }
    }

    pub fn pause(&self) {
        self.clock.rebase(|s| s.paused = true);
        self.changed.notify_one();
    }

    pub fn play(&self) {
        self.clock.rebase(|s| s.paused = false);
        self.changed.notify_one();
    }

    pub fn set_speed(&self, speed: f64) -> Result<(), ControlError> {
        check_speed(speed)?;
        self.clock.rebase(|s| s.speed = speed);
        self.changed.notify_one();
        Ok(())
    }

    /// Moves the replay to `t_s` seconds after the log's first message. The clock moves at
    /// once; the loop re-fuses the log up to there.
    pub fn seek(&self, t_s: f64) -> Result<(), ControlError> {
        let duration_s = self.duration_s();
        if !(t_s.is_finite() && (0.0..=duration_s).contains(&t_s)) {
            return Err(ControlError::Time { t_s, duration_s });
        }
        let at = self.start.offset_secs(t_s).min(self.end);
        self.clock.rebase(|s| s.at = at);
        *self.pending_seek.lock().unwrap_or_else(|p| p.into_inner()) = Some(at);
        self.changed.notify_one();
        Ok(())
    }

    fn take_seek(&self) -> Option<Stamp> {
        self.pending_seek
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take()
    }

    fn set_ended(&self, ended: bool) {
        *self.ended.lock().unwrap_or_else(|p| p.into_inner()) = ended;
    }
}

fn check_speed(speed: f64) -> Result<(), ControlError> {
    if speed.is_finite() && (SPEED_RANGE.0..=SPEED_RANGE.1).contains(&speed) {
        Ok(())
    } else {
        Err(ControlError::Speed(speed))
    }
}

/// Waits (a while at most) until the server has received `inputs` inputs in all.
async fn settle(live: &Live, inputs: u64) {
    let deadline = Instant::now() + SETTLE_MAX;
    while live.stats.inputs_received.load(Relaxed) < inputs && Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
}

/// Hands a recorded input to the server: over Zenoh in the program, straight into the
/// shared state in tests.
pub trait Deliver: Send {
    fn deliver<'a>(&'a mut self, m: &'a LogMessage) -> BoxFuture<'a, ()>;
}

/// What [`play`] needs besides the messages.
#[derive(Debug, Clone)]
pub struct PlayConfig {
    pub engine: EngineConfig,
    pub keys: KeySpace,
    /// At the end of the log, pause there and wait for a seek (until shutdown) instead of
    /// returning.
    pub stay: bool,
}

/// Plays `messages` (in log order) as `control`'s clock reaches them, honouring pause,
/// speed and seeks, until the end of the log (or, with `stay`, until `shutdown`).
/// `progress(done, total)` is called now and then. Returns the messages handed over.
pub async fn play(
    live: Arc<Live>,
    control: Arc<ReplayControl>,
    messages: &[LogMessage],
    cfg: PlayConfig,
    deliver: &mut dyn Deliver,
    progress: &mut (dyn FnMut(usize, usize) + Send),
    shutdown: impl Future<Output = ()>,
) -> usize {
    tokio::pin!(shutdown);
    let mut seeker = Seeker::new(cfg.engine, cfg.keys);
    let mut next = 0;
    let mut delivered = 0;
    let received_before = live.stats.inputs_received.load(Relaxed);
    loop {
        if let Some(at) = control.take_seek() {
            settle(&live, received_before + delivered as u64).await;
            let (engine, index) = seeker.engine_at(messages, at);
            live.replace_engine(engine);
            // The cameras show what they saw last before the new time.
            live.views.clear();
            for v in views_before(messages, index) {
                deliver.deliver(v).await;
            }
            next = index;
            control.set_ended(false);
            continue;
        }
        let Some(m) = messages.get(next) else {
            progress(messages.len(), messages.len());
            if !cfg.stay {
                return delivered;
            }
            control.set_ended(true);
            // Stand at the end until a control request (a seek back) comes.
            let end = control.end;
            control.clock.rebase(|s| {
                s.paused = true;
                s.at = s.at.min(end);
            });
            tokio::select! {
                _ = control.changed.notified() => continue,
                _ = &mut shutdown => return delivered,
            }
        };
        if !is_input(m) && !is_view(m) {
            next += 1;
            continue;
        }
        match control.clock.wall_until(m.log_time) {
            Some(d) if d.is_zero() => {
                deliver.deliver(m).await;
                // Views are not fusion inputs: the settling after a seek does not wait
                // for them.
                delivered += usize::from(is_input(m));
                next += 1;
                if next % 1000 == 0 {
                    progress(next, messages.len());
                }
            }
            wait => {
                // Sleep at most a second at a time: a slow clock still notices controls.
                let d = wait.unwrap_or(Duration::from_secs(3600));
                tokio::select! {
                    _ = tokio::time::sleep(d.min(Duration::from_secs(1))) => {}
                    _ = control.changed.notified() => {}
                    _ = &mut shutdown => return delivered,
                }
            }
        }
    }
}
