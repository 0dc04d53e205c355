//! What changed the estimate's motion, as the tracker judged it: the wall bounces it went
//! through (predicted by its flight, or found at a wall in its sightings) and the kicks it
//! inferred. Counted since the start, and the last few kept with their times, so that a
//! replay or an evaluation can tell which of a track's bounces were taken for kicks.

use std::collections::VecDeque;

/// A change in the estimate's motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MotionEventKind {
    /// A wall bounce the estimate went through.
    Bounce,
    /// A kick nobody reported, inferred from surprising sightings.
    Kick,
}

/// One change in the estimate's motion and when it happened (fusion time axis).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionEvent {
    pub t_s: f64,
    pub kind: MotionEventKind,
}

/// The last events kept.
const KEPT: usize = 32;
/// The same wall met again within this time is the same bounce (the estimate, pulled back
/// over the wall by a sighting, meets it twice).
const SAME_BOUNCE_S: f64 = 0.4;

/// Counts and the last [`KEPT`] events.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct MotionLog {
    events: VecDeque<MotionEvent>,
    bounces: u64,
    kicks: u64,
    /// The last bounce: time, normal axis, wall coordinate.
    last_bounce: Option<(f64, usize, f64)>,
}

impl MotionLog {
    /// The estimate met the wall at `wall_m` on `axis` at `t_s`; false when it is the bounce
    /// already counted.
    pub fn bounce(&mut self, t_s: f64, axis: usize, wall_m: f64) -> bool {
        let same = self.last_bounce.is_some_and(|(t, a, w)| {
            a == axis && (w - wall_m).abs() < 1e-6 && (t_s - t).abs() < SAME_BOUNCE_S
        });
        if same {
            return false;
        }
        self.last_bounce = Some((t_s, axis, wall_m));
        self.bounces += 1;
        self.push(t_s, MotionEventKind::Bounce);
        true
    }

    pub fn kick(&mut self, t_s: f64) {
        self.kicks += 1;
        self.push(t_s, MotionEventKind::Kick);
    }

    fn push(&mut self, t_s: f64, kind: MotionEventKind) {
        self.events.push_back(MotionEvent { t_s, kind });
        if self.events.len() > KEPT {
            self.events.pop_front();
        }
    }

    pub fn bounces(&self) -> u64 {
        self.bounces
    }

    pub fn kicks(&self) -> u64 {
        self.kicks
    }

    pub fn events(&self) -> impl Iterator<Item = &MotionEvent> {
        self.events.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_bounce_met_twice_counts_once_and_kicks_always_count() {
        let mut log = MotionLog::default();
        assert!(log.bounce(1.0, 0, 1.9));
        assert!(!log.bounce(1.1, 0, 1.9), "the same wall at once");
        assert!(log.bounce(1.2, 1, 0.9), "another wall");
        assert!(log.bounce(2.0, 0, 1.9), "the first wall again, later");
        log.kick(2.5);
        log.kick(2.5);
        assert_eq!((log.bounces(), log.kicks()), (3, 2));
        let kinds: Vec<_> = log.events().map(|e| e.kind).collect();
        assert_eq!(kinds.len(), 5);
        assert_eq!(kinds[4], MotionEventKind::Kick);
    }

    #[test]
    fn only_the_last_events_are_kept() {
        let mut log = MotionLog::default();
        for k in 0..100 {
            log.kick(f64::from(k));
        }
        assert_eq!(log.events().count(), KEPT);
        assert_eq!(log.events().next().map(|e| e.t_s), Some(68.0));
        assert_eq!(log.kicks(), 100);
    }
}
