//! Acquisition: when a hypothesis becomes the estimate.
//!
//! The rule does not assume a frame rate. Each robot camera is a stream of frames whose
//! interval the tracker learns from the capture stamps it sees ([`FrameClock`]). A
//! hypothesis is counted in *expected sightings*: a stream that has reported it in most of
//! the frames it could have (its detection ratio) over a short confirmation time is steady.
//! A phantom or a false positive flickers (a few sightings in many frames); a real ball is
//! seen frame after frame, whether the robot runs at 5 Hz or at 130 Hz.
//!
//! A hypothesis takes over when, over a support window stretched to hold at least
//! `promote_min_hits` frames of its slowest stream, it has clearly more support than the
//! main track, and either
//! - several robots agree (two with two sightings each before there is any estimate), or
//! - one credible robot sees it steadily while nothing supports the main track.

use super::{ACTIVE_ROBOT_S, Track, Tracker};
use proto::Camera;

/// Shortest and longest frame interval a stream can be credited with.
const FRAME_INTERVAL_RANGE_S: (f64, f64) = (0.001, 1.0);

/// The frame interval of one camera stream, learned from the stamps it reports.
///
/// A robot that sees nothing sends nothing, so gaps of several frames are common: the
/// interval follows the lower envelope of the gaps. A gap shorter than the interval is
/// adopted quickly, one up to 1.5 intervals nudges it, and a longer one lengthens it only
/// slowly (a robot that truly slowed down is still followed within a few dozen frames).
/// Jittered stamps bias it a little low, which only makes the detection ratio stricter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameClock {
    /// Capture time of the newest frame seen.
    pub last_s: f64,
    /// Learned interval between frames; `None` until two frames were seen.
    pub interval_s: Option<f64>,
}

impl Default for FrameClock {
    fn default() -> Self {
        FrameClock {
            last_s: f64::NEG_INFINITY,
            interval_s: None,
        }
    }
}

impl FrameClock {
    /// Notes a frame captured at `t_s` (several sightings of one frame share its stamp).
    pub fn tick(&mut self, t_s: f64) {
        let gap = t_s - self.last_s;
        if gap.is_nan() || gap <= 0.0 {
            return;
        }
        self.last_s = t_s;
        let (lo, hi) = FRAME_INTERVAL_RANGE_S;
        if gap > hi {
            return; // The stream was silent, not slow.
        }
        let gap = gap.max(lo);
        self.interval_s = Some(match self.interval_s {
            None => gap,
            Some(iv) if gap < iv => 0.7 * iv + 0.3 * gap,
            Some(iv) if gap <= 1.5 * iv => 0.95 * iv + 0.05 * gap,
            Some(iv) => (1.03 * iv).min(gap),
        });
    }
}

/// A robot's two camera streams.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CameraClocks {
    pub left: FrameClock,
    pub right: FrameClock,
}

impl CameraClocks {
    pub fn get(&self, camera: Camera) -> &FrameClock {
        match camera {
            Camera::Left => &self.left,
            Camera::Right => &self.right,
        }
    }

    pub fn get_mut(&mut self, camera: Camera) -> &mut FrameClock {
        match camera {
            Camera::Left => &mut self.left,
            Camera::Right => &mut self.right,
        }
    }
}

/// One observation that supported a track.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    pub t_s: f64,
    /// Index into the tracker's robots.
    pub robot: usize,
    pub camera: Camera,
}

/// How steadily the best stream of a hypothesis has seen it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Steadiness {
    pub hits: usize,
    pub expected: f64,
    pub required: usize,
}

impl Steadiness {
    fn holds(&self, min_ratio: f64) -> bool {
        self.hits >= self.required && self.hits as f64 >= min_ratio * self.expected
    }
}

impl Tracker {
    /// The frame interval of a stream, when known.
    fn interval_of(&self, robot: usize, camera: Camera) -> Option<f64> {
        self.robots.get(robot)?.clocks.get(camera).interval_s
    }

    /// The support window of a hypothesis: `promote_window_s`, stretched so that its
    /// slowest stream has `promote_min_hits` frames in it (at most `promote_window_max_s`).
    fn support_window_s(&self, tr: &Track) -> f64 {
        let cfg = &self.cfg;
        let slowest = tr
            .hits
            .iter()
            .filter_map(|h| self.interval_of(h.robot, h.camera))
            .fold(0.0, f64::max);
        let frames = cfg.promote_min_hits.max(1) as f64 - 0.5;
        (frames * slowest)
            .max(cfg.promote_window_s)
            .min(cfg.promote_window_max_s.max(cfg.promote_window_s))
    }

    /// The sightings needed from one stream of frame interval `interval_s` to confirm a
    /// hypothesis alone: as many as it captures in `confirm_s`, but at least
    /// `promote_min_hits` and at most twice that.
    fn required_hits(&self, interval_s: f64, confirm_s: f64) -> usize {
        let cfg = &self.cfg;
        let n = (confirm_s / interval_s.max(1e-6)).ceil();
        let lo = cfg.promote_min_hits.max(1);
        (n.max(0.0) as usize).clamp(lo, 2 * lo)
    }

    /// The steadiest stream of `tr` at `t_s`: its sightings since it first saw the
    /// hypothesis against the frames it captured since then, and the sightings it needs
    /// to confirm the hypothesis alone within `confirm_s`.
    pub(super) fn steadiness(&self, tr: &Track, t_s: f64, confirm_s: f64) -> Option<Steadiness> {
        let mut streams: Vec<(usize, Camera, f64, usize)> = Vec::new();
        for h in tr.hits.iter().filter(|h| h.t_s >= tr.born_s) {
            match streams
                .iter_mut()
                .find(|(r, c, _, _)| *r == h.robot && *c == h.camera)
            {
                Some((_, _, first, n)) => {
                    *first = first.min(h.t_s);
                    *n += 1;
                }
                None => streams.push((h.robot, h.camera, h.t_s, 1)),
            }
        }
        streams
            .into_iter()
            .filter_map(|(robot, camera, first_s, hits)| {
                let interval = self.interval_of(robot, camera)?;
                Some(Steadiness {
                    hits,
                    expected: 1.0 + ((t_s - first_s) / interval).round().max(0.0),
                    required: self.required_hits(interval, confirm_s),
                })
            })
            .max_by(|a, b| {
                let ratio = |s: &Steadiness| s.hits as f64 / s.expected;
                ratio(a).total_cmp(&ratio(b)).then(a.hits.cmp(&b.hits))
            })
    }

    /// Robots with at least two sightings of `tr` since `since_s`.
    fn robots_seeing_twice(tr: &Track, since_s: f64) -> usize {
        let mut per_robot: Vec<(usize, usize)> = Vec::new();
        for h in tr.hits.iter().filter(|h| h.t_s >= since_s) {
            match per_robot.iter_mut().find(|(r, _)| *r == h.robot) {
                Some((_, n)) => *n += 1,
                None => per_robot.push((h.robot, 1)),
            }
        }
        per_robot.iter().filter(|(_, n)| *n >= 2).count()
    }

    /// Promotes the best-supported hypothesis that qualifies (see the module's rule).
    pub(super) fn promote(&mut self, t_s: f64) {
        let cfg = self.cfg.clone();
        let active_robots = self
            .robots
            .iter()
            .filter(|r| t_s - r.last_obs_s < ACTIVE_ROBOT_S)
            .count();
        let main_silent = self.main().is_none_or(|m| {
            // Silent for a while, or in view of cameras that do not see it.
            t_s - m.last_hit_s > cfg.main_silence_s || m.existence() < cfg.views.refuted_below
        });
        let mut best: Option<(usize, usize)> = None;
        for (i, tr) in self.tracks.iter().enumerate() {
            if Some(i) == self.main {
                continue;
            }
            let since = tr.born_s.max(t_s - self.support_window_s(tr));
            let (hits, n_robots, robots) = tr.support_since(since);
            let main_hits = self.main().map_or(0, |m| m.support_since(since).0);
            if hits < cfg.promote_min_hits || 2 * main_hits >= hits {
                continue;
            }
            // Before there is any estimate, one stray report from another robot must not
            // vouch for a flickering phantom: two robots seeing it repeatedly, or one
            // seeing it steadily for `lone_confirm_s`, are needed. Once there is one, a
            // robot alone takes over sooner (a kick that one robot sees first).
            let confirm_s = if self.main.is_none() {
                cfg.lone_confirm_s
            } else {
                cfg.lone_takeover_s
            };
            let steady = self
                .steadiness(tr, t_s, confirm_s)
                .is_some_and(|s| s.holds(cfg.lone_min_detection_ratio));
            if self.main.is_none() && Self::robots_seeing_twice(tr, since) < 2 && !steady {
                continue;
            }
            let diverse = n_robots >= active_robots.clamp(1, 2);
            let credible = robots
                .iter()
                .all(|r| self.robots[*r].credible(cfg.outlier_rate_max));
            let unopposed = main_hits == 0 || main_silent;
            let lone_ok = unopposed && credible && steady;
            if (diverse || lone_ok) && best.is_none_or(|(_, h)| hits > h) {
                best = Some((i, hits));
            }
        }
        if let Some((i, _)) = best {
            self.take_over(i, t_s);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_clock_learns_the_interval_through_missed_frames() {
        let mut c = FrameClock::default();
        // 5 Hz with every third frame missing (no sighting, nothing sent).
        let mut t = 0.0;
        for k in 0..60 {
            if k % 3 != 2 {
                c.tick(t);
                c.tick(t); // A second sighting in the same frame.
            }
            t += 0.2;
        }
        let iv = c.interval_s.unwrap_or(f64::NAN);
        assert!((iv - 0.2).abs() < 0.03, "interval {iv}");
    }

    #[test]
    fn a_frame_clock_follows_a_robot_that_slows_down_or_speeds_up() {
        let mut c = FrameClock::default();
        let mut t = 0.0;
        for _ in 0..30 {
            c.tick(t);
            t += 1.0 / 30.0;
        }
        for _ in 0..80 {
            c.tick(t);
            t += 0.1;
        }
        let slow = c.interval_s.unwrap_or(f64::NAN);
        assert!((slow - 0.1).abs() < 0.01, "slowed: {slow}");
        for _ in 0..20 {
            c.tick(t);
            t += 0.01;
        }
        let fast = c.interval_s.unwrap_or(f64::NAN);
        assert!((fast - 0.01).abs() < 0.002, "sped up: {fast}");
        // A long silence is not a slow robot.
        c.tick(t + 30.0);
        assert_eq!(c.interval_s, Some(fast));
    }
}
