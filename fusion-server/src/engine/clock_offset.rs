//! How far a robot's clock is from the server's, and the correction of its stamps.
//!
//! Each observation's arrival (server clock) minus its capture stamp (robot clock) is the
//! clock offset plus the time the observation took to reach the server, which is never
//! below some floor: queueing and network delays only ever add to the lag, so the smallest
//! recent lag is the least disturbed (NTP's reasoning). The floor is the robots' common
//! least latency: the lower median of the smallest lags of the robots whose smallest lag is
//! not negative (a negative lag is impossible for an honest clock: its stamps are ahead of
//! the server's), and never below the configured floor. A robot's offset is its smallest
//! lag less that floor; once it has enough observations and the offset is beyond a dead
//! band, its stamps are corrected by it, up to a bound. The window is long in count and in
//! time, so that a flood, whose lags grow as it queues, moves nobody's estimate within a
//! second. A clock that jumps is caught: a lag far below the window's least restarts the
//! window at once (stamps jumped ahead), a long run of lags far above it (in count and in
//! time) restarts it from the run (stamps jumped back).

use proto::Stamp;
use std::collections::VecDeque;

/// Observations the estimate looks back over, at least.
pub const OFFSET_WINDOW: usize = 64;

/// What the server assumes about the robots' clocks, and how it corrects them.
#[derive(Debug, Clone, PartialEq)]
pub struct ClockCheck {
    /// The least time from capture to arrival an observation can take (processing on the
    /// robot and the network): the floor is never taken below this.
    pub latency_floor_s: f64,
    /// An estimated offset larger than this (either way) marks the robot's clock as
    /// suspect: a lone robot's clock error becomes a position bias of speed × offset.
    pub warn_s: f64,
    /// Whether stamps are corrected by the estimated offset (else it is only reported).
    pub correct: bool,
    /// A robot's offset is trusted (used in the floor, and to correct) after this many
    /// observations.
    pub min_samples: usize,
    /// Offsets within this of zero are latency jitter, not a clock error: not corrected.
    pub deadband_s: f64,
    /// The largest correction applied either way; a larger offset is corrected by this.
    pub max_correction_s: f64,
    /// A lag this far from the window's least is a clock jump ...
    pub jump_s: f64,
    /// ... at once when below it, after this many in a row when above it, lasting at
    /// least `jump_back_s`.
    pub jump_run: usize,
    pub jump_back_s: f64,
    /// The estimate looks back over at least this long of arrivals (and at least
    /// [`OFFSET_WINDOW`] observations).
    pub window_s: f64,
}

impl Default for ClockCheck {
    fn default() -> Self {
        ClockCheck {
            latency_floor_s: 0.0,
            warn_s: 0.1,
            correct: true,
            min_samples: 16,
            deadband_s: 0.02,
            max_correction_s: 2.0,
            jump_s: 0.05,
            jump_run: 32,
            jump_back_s: 0.5,
            window_s: 1.0,
        }
    }
}

/// Which way a robot's clock jumped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClockJump {
    /// Its stamps moved ahead (the lag fell).
    Ahead,
    /// Its stamps moved back (the lag rose and stayed up).
    Back,
}

/// The recent arrival − capture lags of one robot: at least the last [`OFFSET_WINDOW`] of
/// them and at least the last `window_s` of arrivals, kept as the least lag of each
/// `window_s / SLOTS` of arrivals, so that a flood (thousands a second, queueing as they
/// come) is judged over the same time as a trickle, in bounded memory.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OffsetWindow {
    slots: VecDeque<Slot>,
    /// Lags in `slots`.
    samples: usize,
    /// The last `jump_run` lags, each with its arrival: a jump back restarts from them.
    tail: VecDeque<(Stamp, f64)>,
    /// Consecutive lags more than `jump_s` above the window's least, and the arrival of
    /// the first of them.
    above_run: usize,
    above_since: Option<Stamp>,
    jumps: u64,
    /// The window restarted at a jump: its lags are evidence enough however few.
    restarted: bool,
}

/// The least of the lags that arrived within one slot's time of `at`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Slot {
    at: Stamp,
    min_lag_s: f64,
    n: usize,
}

/// Slots a window's time is cut into.
pub const SLOTS: u32 = 32;

impl OffsetWindow {
    /// Adds one lag, of an observation that arrived at `at` (server clock); says whether
    /// it showed a clock jump (the window then restarts).
    pub fn push(&mut self, at: Stamp, lag_s: f64, check: &ClockCheck) -> Option<ClockJump> {
        if !lag_s.is_finite() {
            return None;
        }
        let mut jump = None;
        if let Some(min) = self.min_lag_s().filter(|_| self.confident(check)) {
            if lag_s < min - check.jump_s {
                self.slots.clear();
                self.samples = 0;
                jump = Some(ClockJump::Ahead);
            } else if lag_s > min + check.jump_s {
                self.above_run += 1;
                let since = *self.above_since.get_or_insert(at);
                // A run long in count and in time: queueing under a flood is not a jump.
                if self.above_run >= check.jump_run.max(1)
                    && at.secs_since(since) >= check.jump_back_s
                {
                    let keep = (self.above_run - 1).min(self.tail.len());
                    let run: Vec<(Stamp, f64)> = self
                        .tail
                        .iter()
                        .skip(self.tail.len() - keep)
                        .copied()
                        .collect();
                    self.slots.clear();
                    self.samples = 0;
                    for (t, l) in run {
                        self.add(t, l, check);
                    }
                    jump = Some(ClockJump::Back);
                }
            } else {
                self.above_run = 0;
                self.above_since = None;
            }
        }
        if jump.is_some() {
            self.above_run = 0;
            self.above_since = None;
            self.jumps += 1;
            self.restarted = true;
        }
        self.add(at, lag_s, check);
        if self.tail.len() >= check.jump_run.max(1) {
            self.tail.pop_front();
        }
        self.tail.push_back((at, lag_s));
        jump
    }

    fn add(&mut self, at: Stamp, lag_s: f64, check: &ClockCheck) {
        let slot_s = check.window_s / f64::from(SLOTS);
        match self.slots.back_mut() {
            Some(s) if at.secs_since(s.at).abs() < slot_s => {
                s.min_lag_s = s.min_lag_s.min(lag_s);
                s.n += 1;
            }
            _ => self.slots.push_back(Slot {
                at,
                min_lag_s: lag_s,
                n: 1,
            }),
        }
        self.samples += 1;
        while let Some(front) = self.slots.front().copied() {
            let enough = self.samples - front.n >= OFFSET_WINDOW;
            let old = at.secs_since(front.at) > check.window_s;
            if !(enough && old) {
                break;
            }
            self.slots.pop_front();
            self.samples -= front.n;
        }
    }

    /// The smallest recent lag.
    pub fn min_lag_s(&self) -> Option<f64> {
        self.slots.iter().map(|s| s.min_lag_s).reduce(f64::min)
    }

    /// Enough lags to trust the smallest one (or a jump just measured it).
    pub fn confident(&self, check: &ClockCheck) -> bool {
        self.samples > 0 && (self.restarted || self.samples >= check.min_samples)
    }

    /// Clock jumps caught so far.
    pub fn jumps(&self) -> u64 {
        self.jumps
    }

    /// Server clock minus robot clock, seconds (positive: the robot's clock is behind),
    /// given the robots' common latency `floor_s`.
    pub fn offset_s(&self, floor_s: f64) -> Option<f64> {
        Some(self.min_lag_s()? - floor_s)
    }

    /// What to add to this robot's stamps: its offset once confident and beyond the dead
    /// band, bounded; zero otherwise.
    pub fn correction_s(&self, floor_s: f64, check: &ClockCheck) -> f64 {
        match self.offset_s(floor_s) {
            Some(o) if check.correct && self.confident(check) && o.abs() > check.deadband_s => {
                o.clamp(-check.max_correction_s, check.max_correction_s)
            }
            _ => 0.0,
        }
    }
}

/// The robots' common least latency from their smallest lags (one per robot whose window
/// is confident): the lower median of those that are not negative, never below the
/// configured floor.
pub fn common_floor_s(min_lags_s: impl IntoIterator<Item = f64>, check: &ClockCheck) -> f64 {
    let mut lags: Vec<f64> = min_lags_s
        .into_iter()
        .filter(|l| l.is_finite() && *l >= 0.0)
        .collect();
    if lags.is_empty() {
        return check.latency_floor_s;
    }
    lags.sort_by(f64::total_cmp);
    lags[(lags.len() - 1) / 2].max(check.latency_floor_s)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The arrival of a robot's k-th observation at 60 Hz.
    fn at(k: usize) -> Stamp {
        Stamp(1_000_000_000_000 + k as u64 * 16_666_667)
    }

    fn filled(offset_s: f64, n: usize, check: &ClockCheck) -> OffsetWindow {
        let mut w = OffsetWindow::default();
        for k in 0..n {
            let latency_s = 0.02 + 0.04 * (k % 5) as f64 / 4.0;
            w.push(at(k), offset_s + latency_s, check);
        }
        w
    }

    #[test]
    fn the_smallest_recent_lag_less_the_floor() {
        let check = ClockCheck::default();
        let mut w = OffsetWindow::default();
        assert_eq!(w.offset_s(0.0), None);
        // A clock 0.2 s behind, latencies 20..60 ms with one queueing spike.
        for k in 0..100 {
            let latency_s = 0.02 + 0.04 * f64::from(k % 5) / 4.0;
            w.push(
                at(k as usize),
                0.2 + latency_s + if k == 50 { 1.0 } else { 0.0 },
                &check,
            );
        }
        w.push(at(100), f64::NAN, &check);
        let offset = w.offset_s(0.01).expect("an estimate");
        assert!((offset - 0.21).abs() < 1e-9, "{offset}");
        assert_eq!(w.jumps(), 0, "one spike is not a jump");
    }

    #[test]
    fn the_floor_is_the_honest_robots_least_latency() {
        let check = ClockCheck::default();
        // Two honest robots (least latency 20 ms) and one 200 ms ahead (its lags negative).
        let robots = [
            filled(0.0, 64, &check),
            filled(0.0, 64, &check),
            filled(-0.2, 64, &check),
        ];
        let floor = common_floor_s(robots.iter().filter_map(|w| w.min_lag_s()), &check);
        assert!((floor - 0.02).abs() < 1e-9, "{floor}");
        assert_eq!(robots[0].correction_s(floor, &check), 0.0);
        let c = robots[2].correction_s(floor, &check);
        assert!((c + 0.2).abs() < 1e-9, "{c}");
        // A lone robot ahead: the floor cannot be negative, so it is corrected to zero lag.
        let floor = common_floor_s(robots[2].min_lag_s(), &check);
        assert_eq!(floor, 0.0);
        assert!((robots[2].correction_s(floor, &check) + 0.18).abs() < 1e-9);
        // One honest robot and one 200 ms behind: the lower median keeps the honest one.
        let behind = filled(0.2, 64, &check);
        let floor = common_floor_s(
            [robots[0].min_lag_s(), behind.min_lag_s()]
                .into_iter()
                .flatten(),
            &check,
        );
        assert!((behind.correction_s(floor, &check) - 0.2).abs() < 1e-9);
        assert_eq!(robots[0].correction_s(floor, &check), 0.0);
    }

    #[test]
    fn corrections_wait_for_confidence_are_bounded_and_can_be_off() {
        let check = ClockCheck::default();
        let few = filled(-0.5, check.min_samples - 1, &check);
        assert_eq!(few.correction_s(0.02, &check), 0.0);
        let far = filled(-5.0, 64, &check);
        assert_eq!(far.correction_s(0.02, &check), -check.max_correction_s);
        let off = ClockCheck {
            correct: false,
            ..check.clone()
        };
        assert_eq!(far.correction_s(0.02, &off), 0.0);
    }

    #[test]
    fn a_clock_that_jumps_either_way_is_caught() {
        let check = ClockCheck::default();
        let mut w = filled(0.0, 64, &check);
        // Stamps jump 0.3 s ahead: caught at the first such lag, the estimate follows.
        assert_eq!(w.push(at(64), -0.28, &check), Some(ClockJump::Ahead));
        assert!((w.min_lag_s().expect("lag") + 0.28).abs() < 1e-9);
        assert!(
            (w.correction_s(0.02, &check) + 0.3).abs() < 1e-9,
            "corrected at once"
        );
        for k in 0..64 {
            w.push(at(65 + k), -0.27, &check);
        }
        // ... and back: caught after a run of high lags, the window keeps the run.
        let mut caught = None;
        for k in 0..check.jump_run {
            if let Some(j) = w.push(at(129 + k), 0.03, &check) {
                caught = Some((k, j));
            }
        }
        assert_eq!(caught, Some((check.jump_run - 1, ClockJump::Back)));
        assert!((w.min_lag_s().expect("lag") - 0.03).abs() < 1e-9);
        assert_eq!(w.jumps(), 2);
    }

    #[test]
    fn a_flood_queueing_up_moves_no_estimate_and_keeps_few_slots() {
        let check = ClockCheck::default();
        let mut w = filled(0.0, 64, &check);
        // 10 000 observations a second for 0.4 s, queueing up to 0.4 s behind: no jump.
        let t0 = at(64);
        for k in 0..4_000u64 {
            let lag_s = 0.02 + 0.4 * k as f64 / 4_000.0;
            assert_eq!(
                w.push(Stamp(t0.0 + k * 100_000), lag_s, &check),
                None,
                "{k}"
            );
        }
        assert!((w.min_lag_s().expect("lag") - 0.02).abs() < 1e-9);
        assert!(
            w.slots.len() <= OFFSET_WINDOW + SLOTS as usize + 1,
            "{}",
            w.slots.len()
        );
        // Past the window, the old least is forgotten (the lags stay up: a real change).
        for k in 4_000..30_000u64 {
            w.push(Stamp(t0.0 + k * 100_000), 0.42, &check);
        }
        assert!(w.min_lag_s().expect("lag") > 0.4);
        assert!(w.slots.len() <= SLOTS as usize + 2, "{}", w.slots.len());
    }
}
