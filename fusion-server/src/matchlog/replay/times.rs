//! When replay computes states beyond the recorded ones: at times the user lists, or on a
//! grid at the state rate through a chosen stamp, possibly on past the end of the log.

use proto::Stamp;
use std::str::FromStr;

/// A time given to replay: a stamp, or seconds after the log's first message (`+1.5`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeArg {
    Stamp(Stamp),
    AfterFirst { secs: f64 },
}

impl TimeArg {
    /// The stamp, with `first` the log's first message.
    pub fn resolve(self, first: Stamp) -> Stamp {
        match self {
            TimeArg::Stamp(s) => s,
            TimeArg::AfterFirst { secs } => first.offset_secs(secs),
        }
    }
}

impl FromStr for TimeArg {
    type Err = String;

    /// `NANOSECONDS` since the UNIX epoch, or `+SECONDS` after the first message.
    fn from_str(s: &str) -> Result<Self, String> {
        let s = s.trim();
        if let Some(rest) = s.strip_prefix('+') {
            return match rest.parse::<f64>() {
                Ok(secs) if secs.is_finite() && secs >= 0.0 => Ok(TimeArg::AfterFirst { secs }),
                _ => Err(format!(
                    "{s:?}: after `+` give the seconds after the first message, e.g. +1.5"
                )),
            };
        }
        s.parse::<u64>()
            .map(|ns| TimeArg::Stamp(Stamp(ns)))
            .map_err(|_| {
                format!(
                    "{s:?} is neither a stamp (nanoseconds since the UNIX epoch) nor +SECONDS \
                 after the first message"
                )
            })
    }
}

/// The grid's times, `origin + k / rate`, from the first at or after `from`.
#[derive(Debug, Clone)]
pub(super) struct Grid {
    origin: Stamp,
    step_s: f64,
    k: i64,
    /// Last time of the grid (inclusive).
    until: Stamp,
}

impl Grid {
    fn new(origin: Stamp, rate_hz: f64, from: Stamp, until: Stamp) -> Self {
        let step_s = 1.0 / rate_hz.max(1e-3);
        let mut k = (from.secs_since(origin) / step_s).ceil() as i64;
        let at = |k: i64| origin.offset_secs(k as f64 * step_s);
        // Rounding to nanoseconds may put the first point a hair before `from`, or leave
        // an earlier one at or after it.
        while at(k) < from {
            k += 1;
        }
        while at(k - 1) >= from {
            k -= 1;
        }
        Grid {
            origin,
            step_s,
            k,
            until,
        }
    }

    fn peek(&self) -> Option<Stamp> {
        let t = self.origin.offset_secs(self.k as f64 * self.step_s);
        (t <= self.until).then_some(t)
    }
}

/// The times at which states are asked for, in order.
#[derive(Debug, Clone)]
pub(super) enum Schedule {
    None,
    /// Exactly these, sorted, without repeats; `next` indexes the first still due.
    At {
        times: Vec<Stamp>,
        next: usize,
    },
    Grid(Grid),
}

impl Schedule {
    /// Exactly the listed times.
    pub(super) fn at(times: &[TimeArg], first: Stamp) -> Self {
        let mut times: Vec<Stamp> = times.iter().map(|t| t.resolve(first)).collect();
        times.sort();
        times.dedup();
        Schedule::At { times, next: 0 }
    }

    /// A grid at `rate_hz` through `align` (default: the first message), from the first
    /// message `first` to `until` (default: the last message, `last`), both included.
    pub(super) fn grid(
        rate_hz: f64,
        align: Option<TimeArg>,
        until: Option<TimeArg>,
        first: Stamp,
        last: Stamp,
    ) -> Self {
        let origin = align.map_or(first, |a| a.resolve(first));
        let until = until.map_or(last, |u| u.resolve(first));
        Schedule::Grid(Grid::new(origin, rate_hz, first, until))
    }

    /// No time is asked for: the recorded states are the replay's.
    pub(super) fn asks_nothing(&self) -> bool {
        matches!(self, Schedule::None)
    }

    /// The next time still due, if it is before `before` (`None`: any, the log has ended).
    pub(super) fn next_before(&mut self, before: Option<Stamp>) -> Option<Stamp> {
        let t = match self {
            Schedule::None => None,
            Schedule::At { times, next } => times.get(*next).copied(),
            Schedule::Grid(g) => g.peek(),
        }?;
        if before.is_some_and(|b| t >= b) {
            return None;
        }
        match self {
            Schedule::At { next, .. } => *next += 1,
            Schedule::Grid(g) => g.k += 1,
            Schedule::None => {}
        }
        Some(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const T0: Stamp = Stamp(1_795_478_399_000_000_000);

    fn drain(s: &mut Schedule, before: Option<Stamp>) -> Vec<Stamp> {
        std::iter::from_fn(|| s.next_before(before)).collect()
    }

    #[test]
    fn times_are_stamps_or_seconds_after_the_first_message() {
        assert_eq!(
            "1795478399000000000".parse::<TimeArg>(),
            Ok(TimeArg::Stamp(T0))
        );
        let rel = "+1.5".parse::<TimeArg>().expect("relative");
        assert_eq!(rel.resolve(T0), Stamp(T0.0 + 1_500_000_000));
        for bad in ["1.5", "-3", "+", "+-1", "+inf", "soon", ""] {
            let e = bad.parse::<TimeArg>().expect_err(bad);
            assert!(e.contains("first message"), "{bad}: {e}");
        }
    }

    #[test]
    fn listed_times_come_sorted_once_each_then_after_the_end() {
        let args = [
            TimeArg::AfterFirst { secs: 2.0 },
            TimeArg::Stamp(T0),
            TimeArg::AfterFirst { secs: 0.0 },
            TimeArg::AfterFirst { secs: 9.0 },
        ];
        let mut s = Schedule::at(&args, T0);
        assert_eq!(drain(&mut s, Some(T0)), vec![]);
        assert_eq!(
            drain(&mut s, Some(T0.offset_secs(5.0))),
            vec![T0, T0.offset_secs(2.0)]
        );
        assert_eq!(drain(&mut s, None), vec![T0.offset_secs(9.0)]);
    }

    #[test]
    fn a_grid_runs_through_its_alignment_from_the_first_message() {
        let first = T0.offset_secs(0.03);
        let last = T0.offset_secs(0.4);
        let align = TimeArg::Stamp(T0);
        let mut s = Schedule::grid(10.0, Some(align), None, first, last);
        let got = drain(&mut s, Some(T0.offset_secs(0.35)));
        let want: Vec<Stamp> = [0.1, 0.2, 0.3].iter().map(|t| T0.offset_secs(*t)).collect();
        assert_eq!(got, want);
        assert_eq!(drain(&mut s, None), vec![last], "to the last message");

        let until = TimeArg::AfterFirst { secs: 0.27 };
        let mut s = Schedule::grid(10.0, Some(align), Some(until), first, last);
        assert_eq!(drain(&mut s, Some(T0.offset_secs(0.15))).len(), 1);
        assert_eq!(
            drain(&mut s, None),
            vec![T0.offset_secs(0.2), T0.offset_secs(0.3)]
        );
        // Without an alignment the grid starts at the first message, which is on it.
        let mut s = Schedule::grid(30.0, None, None, first, last);
        assert_eq!(s.next_before(Some(first.offset_secs(0.01))), Some(first));
    }
}
