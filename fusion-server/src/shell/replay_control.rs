//! The controls of a match log played back as if live: a clock that runs through the
//! recorded match and can be paused, sped up or slowed down and moved ([`ReplayClock`]),
//! and the handle the HTTP control endpoints drive ([`ReplayControl`]). The loop that plays
//! the log by this clock is [`super::replay_live`]; this knows nothing of the server.

use crate::clock::Clock;
use proto::Stamp;
use serde::Serialize;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};
use tokio::sync::Notify;

/// Slowest and fastest playback.
pub const SPEED_RANGE: (f64, f64) = (0.05, 64.0);

#[derive(Debug, Clone, Copy)]
pub(super) struct ClockState {
    /// The recorded time at `wall`.
    pub(super) at: Stamp,
    wall: Instant,
    speed: f64,
    pub(super) paused: bool,
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
    pub(super) fn rebase(&self, f: impl FnOnce(&mut ClockState)) {
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
    pub(super) end: Stamp,
    /// A seek the loop has not carried out yet.
    pending_seek: Mutex<Option<Stamp>>,
    ended: Mutex<bool>,
    pub(super) changed: Notify,
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

    pub(super) fn take_seek(&self) -> Option<Stamp> {
        self.pending_seek
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take()
    }

    pub(super) fn set_ended(&self, ended: bool) {
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
