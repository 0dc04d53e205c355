//! One camera's perception counters: totals since the agent started (frames, candidates
//! scored, balls published, rejections by reason) and the rates over the last status
//! interval, for the robot's status ([`proto::CameraPerception`]).
//!
//! Time comes in as frame and status stamps; nothing here reads a clock. An interval runs
//! from one status to the next (the first from the camera's first frame); its pipeline
//! times are the caller's measurements, passed in per frame.

use crate::pipeline::FrameResult;
use proto::{Camera, CameraPerception, MAX_REJECTION_REASONS, Stamp};
use std::collections::{BTreeMap, VecDeque};

/// Pipeline times kept per interval (the latest ones), so a status that never comes (an
/// offline run) leaves memory bounded.
const MAX_INTERVAL_TIMES: usize = 1024;

/// The reason under which rejections are counted once [`MAX_REJECTION_REASONS`] reasons
/// are taken (the pipeline has fewer reasons than that; this is a guard).
const OTHER_REASON: &str = "other";

/// A camera's counters.
#[derive(Debug, Clone, Default)]
pub(crate) struct CameraCounters {
    frames: u64,
    candidates: u64,
    balls: u64,
    rejections: BTreeMap<&'static str, u64>,
    interval: Interval,
}

/// What happened since the last status.
#[derive(Debug, Clone, Default)]
struct Interval {
    /// The first frame's stamp, for a first interval (no status before it).
    first_frame: Option<Stamp>,
    frames: u64,
    candidates: u64,
    balls: u64,
    pipeline_ms: VecDeque<f64>,
}

impl CameraCounters {
    /// Counts a processed frame.
    pub(crate) fn on_frame(&mut self, stamp: Stamp, result: &FrameResult) {
        let candidates = result.scored.len() as u64;
        let balls = u64::from(result.sighting.is_some());
        self.frames += 1;
        self.candidates += candidates;
        self.balls += balls;
        for (_, why) in &result.rejected {
            self.count_rejection(why.reason());
        }
        let i = &mut self.interval;
        i.first_frame.get_or_insert(stamp);
        i.frames += 1;
        i.candidates += candidates;
        i.balls += balls;
    }

    /// The pipeline's time on the last frame counted, milliseconds.
    pub(crate) fn on_pipeline_ms(&mut self, pipeline_ms: f64) {
        let times = &mut self.interval.pipeline_ms;
        if times.len() == MAX_INTERVAL_TIMES {
            times.pop_front();
        }
        times.push_back(pipeline_ms);
    }

    fn count_rejection(&mut self, reason: &'static str) {
        let full = self.rejections.len() >= MAX_REJECTION_REASONS - 1;
        let key = if full && !self.rejections.contains_key(reason) {
            OTHER_REASON
        } else {
            reason
        };
        *self.rejections.entry(key).or_default() += 1;
    }

    /// The counters at a status stamped `stamp`, whose interval began at `since` (the
    /// previous status; `None` for the first, which then begins at the camera's first
    /// frame). Starts the next interval.
    pub(crate) fn close_interval(
        &mut self,
        camera: Camera,
        since: Option<Stamp>,
        stamp: Stamp,
    ) -> CameraPerception {
        let interval = std::mem::take(&mut self.interval);
        let start = since.or(interval.first_frame);
        let span_s = start.map_or(0.0, |s| stamp.secs_since(s));
        let per_s = |n: u64| {
            if span_s > 0.0 { n as f64 / span_s } else { 0.0 }
        };
        let per_frame = if interval.frames > 0 {
            interval.candidates as f64 / interval.frames as f64
        } else {
            0.0
        };
        let times: Vec<f64> = interval.pipeline_ms.into_iter().collect();
        CameraPerception {
            camera,
            frames: self.frames,
            candidates: self.candidates,
            balls: self.balls,
            rejections: self
                .rejections
                .iter()
                .map(|(r, n)| (r.to_string(), *n))
                .collect(),
            frames_per_s: rate(per_s(interval.frames)),
            candidates_per_frame: rate(per_frame),
            balls_per_s: rate(per_s(interval.balls)),
            detector_ms: rate(proto::stats::median(&times).unwrap_or(0.0)),
        }
    }
}

/// A rate as the status carries it: finite, 0..=1e6.
fn rate(v: f64) -> f64 {
    if v.is_finite() {
        v.clamp(0.0, 1e6)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use crate::pipeline::Rejection;
    use vision::Circle;

    const S: u64 = 1_000_000_000;

    fn circle() -> Circle {
        Circle {
            center_px: [10.0, 10.0],
            radius_px: 5.0,
            score: 1.0,
        }
    }

    /// A frame with `scored` candidates, all rejected for low probability.
    fn rejected(scored: usize) -> FrameResult {
        FrameResult {
            scored: vec![(circle(), 0.1); scored],
            rejected: vec![(circle(), Rejection::LowProbability { probability: 0.1 }); scored],
            ..FrameResult::default()
        }
    }

    #[test]
    fn totals_accumulate_and_rates_cover_the_interval() {
        let mut c = CameraCounters::default();
        // Ten frames over one second (stamps 0.1 s apart from 1.0 s), three candidates each.
        for k in 1..=10 {
            c.on_frame(Stamp(S + k * S / 10), &rejected(3));
            c.on_pipeline_ms(k as f64);
        }
        let p = c.close_interval(Camera::Left, Some(Stamp(S)), Stamp(2 * S));
        assert_eq!((p.frames, p.candidates, p.balls), (10, 30, 0));
        assert_eq!(p.rejections.get("low_probability"), Some(&30));
        assert!((p.frames_per_s - 10.0).abs() < 1e-9);
        assert!((p.candidates_per_frame - 3.0).abs() < 1e-9);
        assert!((p.detector_ms - 5.5).abs() < 1e-9);
        // The next interval: no frames, so no rates, but the totals stay.
        let q = c.close_interval(Camera::Left, Some(Stamp(2 * S)), Stamp(3 * S));
        assert_eq!((q.frames, q.candidates), (10, 30));
        assert_eq!(
            (q.frames_per_s, q.candidates_per_frame, q.detector_ms),
            (0.0, 0.0, 0.0)
        );
    }

    #[test]
    fn a_first_interval_begins_at_the_first_frame() {
        let mut c = CameraCounters::default();
        c.on_frame(Stamp(S), &FrameResult::default());
        c.on_frame(Stamp(3 * S), &FrameResult::default());
        let p = c.close_interval(Camera::Right, None, Stamp(3 * S));
        assert!((p.frames_per_s - 1.0).abs() < 1e-9, "{p:?}");
        // A status at the only frame's stamp has no span: no rate rather than infinity.
        let mut c = CameraCounters::default();
        c.on_frame(Stamp(S), &FrameResult::default());
        let p = c.close_interval(Camera::Right, None, Stamp(S));
        assert_eq!(p.frames_per_s, 0.0);
    }

    #[test]
    fn rejection_reasons_stay_within_the_limit() {
        const REASONS: [&str; 20] = [
            "r0", "r1", "r2", "r3", "r4", "r5", "r6", "r7", "r8", "r9", "r10", "r11", "r12", "r13",
            "r14", "r15", "r16", "r17", "r18", "r19",
        ];
        let mut c = CameraCounters::default();
        for r in REASONS {
            c.count_rejection(r);
        }
        c.count_rejection("r0");
        let p = c.close_interval(Camera::Left, None, Stamp(S));
        assert_eq!(p.rejections.len(), MAX_REJECTION_REASONS);
        assert_eq!(p.rejections.get("r0"), Some(&2));
        assert_eq!(p.rejections.values().sum::<u64>(), 21);
        assert_eq!(p.rejections.get(OTHER_REASON), Some(&5));
    }

    #[test]
    fn the_pipeline_times_kept_are_bounded() {
        let mut c = CameraCounters::default();
        for k in 0..(3 * MAX_INTERVAL_TIMES) {
            c.on_pipeline_ms(k as f64);
        }
        assert_eq!(c.interval.pipeline_ms.len(), MAX_INTERVAL_TIMES);
    }
}
