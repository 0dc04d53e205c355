//! Stage timings: the pipeline marks the end of each stage, this clock measures the time
//! between marks and keeps a window of recent durations per stage for the status.

use std::collections::{BTreeMap, VecDeque};
use std::time::Instant;
use vision::StageClock;

/// Durations kept per stage.
const WINDOW: usize = 64;

#[derive(Debug)]
pub struct StageTimer {
    last: Instant,
    /// Sum of the current frame's stages so far, milliseconds.
    frame_ms: f64,
    order: Vec<&'static str>,
    recent: BTreeMap<&'static str, VecDeque<f64>>,
}

impl Default for StageTimer {
    fn default() -> Self {
        Self::new()
    }
}

impl StageTimer {
    pub fn new() -> Self {
        StageTimer {
            last: Instant::now(),
            frame_ms: 0.0,
            order: Vec::new(),
            recent: BTreeMap::new(),
        }
    }

    /// Starts timing a frame.
    pub fn start(&mut self) {
        self.last = Instant::now();
        self.frame_ms = 0.0;
    }

    /// The time the current (or last) frame's stages took, milliseconds.
    pub fn frame_ms(&self) -> f64 {
        self.frame_ms
    }

    /// Median duration of each stage over the recent frames, in pipeline order, and the
    /// median of their sum as `total`.
    pub fn medians_ms(&self) -> Vec<(String, f64)> {
        let mut out: Vec<(String, f64)> = self
            .order
            .iter()
            .filter_map(|s| Some((s.to_string(), median(self.recent.get(s)?)?)))
            .collect();
        let total: f64 = out.iter().map(|(_, ms)| ms).sum();
        if !out.is_empty() {
            out.push(("total".into(), total));
        }
        out
    }
}

fn median(values: &VecDeque<f64>) -> Option<f64> {
    let v: Vec<f64> = values.iter().copied().collect();
    proto::stats::median(&v)
}

impl StageTimer {
    /// Records a stage of the current frame timed elsewhere (on a camera's own thread).
    pub fn record(&mut self, stage: &'static str, ms: f64) {
        self.frame_ms += ms;
        if !self.order.contains(&stage) {
            self.order.push(stage);
        }
        let q = self.recent.entry(stage).or_default();
        if q.len() == WINDOW {
            q.pop_front();
        }
        q.push_back(ms);
    }
}

impl StageClock for StageTimer {
    fn mark(&mut self, stage: &'static str) {
        let now = Instant::now();
        let ms = now.duration_since(self.last).as_secs_f64() * 1e3;
        self.last = now;
        self.record(stage, ms);
    }
}
