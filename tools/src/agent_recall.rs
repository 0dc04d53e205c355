//! The agent's detection scored against the simulator's truth, frame by frame, the way
//! `sim_agent` reports it: a ball is visible when it is in the frame, at least half of it
//! shows, its image radius is at least 4 px and its centre is on the image; it is found
//! when the agent's observation lies within the ball's image radius (at least 4 px) of its
//! centre. Observations anywhere else are false sightings; visible balls not found are
//! counted by what became of the candidate nearest them.

use crate::sim_source::Truths;
use proto::Camera;
use robot_agent::{FrameHook, FrameReport};
use sim::BallTruth;
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};

/// Counts against the truth.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Recall {
    pub frames: u64,
    pub visible: u64,
    pub hits: u64,
    pub false_sightings: u64,
    /// Visible balls not found, by what happened to them.
    pub misses: BTreeMap<String, u64>,
}

impl Recall {
    /// Scores one processed frame against its truth.
    pub fn add(&mut self, report: &FrameReport<'_>, truth: &BallTruth) {
        let image = &report.frame.image;
        let outcome = report.outcome;
        self.frames += 1;
        let on_image = |p: [f64; 2]| {
            (0.0..f64::from(image.width())).contains(&p[0])
                && (0.0..f64::from(image.height())).contains(&p[1])
        };
        let visible = truth.in_frame
            && truth.visible_fraction >= 0.5
            && truth.radius_px >= 4.0
            && truth.center_px.is_some_and(on_image);
        self.visible += u64::from(visible);
        let near = |p: [f64; 2]| {
            truth
                .center_px
                .is_some_and(|c| (p[0] - c[0]).hypot(p[1] - c[1]) <= truth.radius_px.max(4.0))
        };
        let hit = outcome
            .observation
            .as_ref()
            .and_then(|o| o.pixel)
            .is_some_and(|p| near([p.u_px, p.v_px]));
        self.hits += u64::from(hit && visible);
        self.false_sightings += u64::from(outcome.observation.is_some() && !hit);
        if visible && !hit {
            let why = outcome
                .result
                .rejected
                .iter()
                .find(|(c, _)| near(c.center_px))
                .map_or_else(
                    || "no candidate".to_string(),
                    |(_, why)| why.reason().to_string(),
                );
            *self.misses.entry(why).or_default() += 1;
        }
    }

    /// The lines `sim_agent` prints after the run's summary (nothing without frames).
    pub fn lines(&self) -> Vec<String> {
        if self.frames == 0 {
            return Vec::new();
        }
        let recall = self.hits as f64 / self.visible.max(1) as f64;
        let precision = self.hits as f64 / (self.hits + self.false_sightings).max(1) as f64;
        let mut out = vec![format!(
            "against the simulator's truth: ball visible in {} frames, found in {} (recall {:.1} %), {} false sightings (precision {:.1} %)",
            self.visible,
            self.hits,
            100.0 * recall,
            self.false_sightings,
            100.0 * precision
        )];
        for (why, n) in &self.misses {
            out.push(format!("  missed: {why}: {n}"));
        }
        out
    }
}

/// A frame hook that pairs each processed frame with its truth from `truths` (by stamp
/// and camera; the truths of frames the loop skipped are passed over) and scores it into
/// the returned counts.
pub fn scoring_hook(truths: Truths) -> (FrameHook, Arc<Mutex<Recall>>) {
    let recall = Arc::new(Mutex::new(Recall::default()));
    let counts = recall.clone();
    let hook = Box::new(move |report: &FrameReport<'_>| {
        let key: (proto::Stamp, Camera) = (report.source_stamp, report.frame.camera);
        let Ok(mut q) = truths.lock() else {
            return;
        };
        while let Some((stamp, camera, truth)) = q.pop_front() {
            if (stamp, camera) != key {
                continue;
            }
            if let (Some(truth), Ok(mut r)) = (truth, counts.lock()) {
                r.add(report, &truth);
            }
            break;
        }
    });
    (hook, recall)
}
