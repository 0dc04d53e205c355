//! What the tracker learns about each robot: how honest its stated covariance is, and how
//! often it reports something the other robots do not see.

use super::{ObsInput, Tracker};
use crate::estimator::filter::Innovation;
use proto::Pose2;
use std::sync::Arc;

const OUTLIER_ALPHA: f64 = 0.03;
/// A robot's outlier rate means something after this many observations.
const MIN_OUTLIER_SAMPLES: u32 = 20;
/// Another robot must have confirmed the main track this recently for an outlier to count.
const OUTLIER_CONFIRM_S: f64 = 0.15;
/// Mahalanobis distance² beyond which a report is another object, not noise.
const OUTLIER_D2: f64 = 50.0;

/// What the tracker has learned about one robot.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotTrust {
    pub robot: Arc<str>,
    pub pose: Pose2,
    /// Capture time of its newest observation.
    pub last_obs_s: f64,
    /// Scale applied to the covariance it reports (1 = honest, > 1 = it under-reports).
    pub covariance_scale: f64,
    /// Share of its observations that did not fit the main track while others did.
    pub outlier_rate: f64,
    /// Observations that informed `outlier_rate`.
    pub outlier_samples: u32,
    pub observations: u64,
    /// Frame intervals of its cameras, learned from the stamps it reports.
    pub clocks: super::CameraClocks,
}

impl RobotTrust {
    /// Not known to report what the others do not see: may alone promote a hypothesis.
    /// A robot that has rarely been checked against the others (it is often the only one
    /// to see the ball) gets the benefit of the doubt.
    pub(super) fn credible(&self, max_outlier_rate: f64) -> bool {
        self.outlier_samples < MIN_OUTLIER_SAMPLES || self.outlier_rate <= max_outlier_rate
    }
}

impl Tracker {
    /// A robot's covariance scale relative to the team's median. Relative, because what
    /// the filter cannot explain (unmodelled ball physics) inflates everyone's residuals
    /// alike; only the differences between robots say who misreports.
    pub(super) fn relative_trust(&self, ri: usize) -> f64 {
        let mut scales: Vec<f64> = self.robots.iter().map(|r| r.covariance_scale).collect();
        scales.sort_by(f64::total_cmp);
        let median = scales.get(scales.len() / 2).copied().unwrap_or(1.0);
        self.robots[ri].covariance_scale / median.max(1e-6)
    }

    /// Learns how a robot's residuals compare with the covariance it reports:
    /// E[yᵀR⁻¹y] = tr(R⁻¹HPHᵀ) + 2·scale, measured against the settled main track.
    pub(super) fn learn_trust(&mut self, ri: usize, o: &ObsInput) {
        let Some(m) = self.main() else { return };
        let t_s = o.t_s;
        if t_s < m.boost_until_s
            || t_s - m.last_hit_s > 0.3
            || self.near_robot(m.filter.position(), t_s)
        {
            return;
        }
        let Some(r_inv) = o.covariance_m2.try_inverse() else {
            return;
        };
        let inn: Innovation = m.filter.innovation(o.position_m, &o.covariance_m2);
        let raw = (inn.y.transpose() * r_inv * inn.y)[(0, 0)];
        if raw > 60.0 {
            return; // Another object altogether, not noise.
        }
        let prior = (r_inv * m.filter.covariance().fixed_view::<2, 2>(0, 0)).trace();
        let sample = ((raw - prior) / 2.0).clamp(0.0, 30.0);
        let (lo, hi) = self.cfg.trust_range;
        let alpha = self.cfg.trust_alpha;
        let r = &mut self.robots[ri];
        r.covariance_scale = ((1.0 - alpha) * r.covariance_scale + alpha * sample).clamp(lo, hi);
    }

    /// How often a robot reports something clearly off the main track (another object)
    /// while other robots confirm the main track at that very moment.
    pub(super) fn learn_outlier_rate(&mut self, ri: usize, o: &ObsInput, on_main: bool) {
        let Some(m) = self.main() else { return };
        let t_s = o.t_s;
        let confirmed_by_others = m
            .hits
            .iter()
            .rev()
            .take_while(|h| h.t_s > t_s - OUTLIER_CONFIRM_S)
            .any(|h| h.robot != ri);
        if !confirmed_by_others {
            return;
        }
        let x = if on_main {
            0.0
        } else if m.filter.innovation(o.position_m, &o.covariance_m2).d2 > OUTLIER_D2 {
            1.0
        } else {
            return; // Near the main track but not on it: ambiguous, not evidence.
        };
        let r = &mut self.robots[ri];
        r.outlier_rate = (1.0 - OUTLIER_ALPHA) * r.outlier_rate + OUTLIER_ALPHA * x;
        r.outlier_samples = r.outlier_samples.saturating_add(1);
    }
}
