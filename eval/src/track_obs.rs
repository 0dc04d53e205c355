//! Observations of a recorded track as robots would report them: robots standing at fixed
//! poses around the pitch, looking at its centre, each capturing at its own rate (with its
//! own phase), reporting the track's position at the capture instant plus isotropic
//! Gaussian noise whose σ the covariance states honestly, arriving after a jittered
//! latency, sometimes not at all. Every robot sees the ball in every frame it keeps: no
//! field of view, range or occlusion is modelled; those belong to the simulator's
//! observers, not to a test of the filter on somebody else's track.

use proto::{Camera, Observation, Pitch, Pose2, Stamp};
use sim::Rng;
use sim::{Delivery, ObsKind};
use thiserror::Error;
use tools::tracks::Track;

/// How the robots observe a track.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ObserverSetup {
    pub robots: usize,
    /// Captures per second, per robot.
    pub rate_hz: f64,
    /// σ of the position noise, per axis.
    pub noise_m: f64,
    /// Mean delay from capture to arrival: half of it fixed, half exponentially distributed.
    pub latency_s: f64,
    /// Probability that a capture is lost.
    pub dropout: f64,
    /// The first robot's clock runs this far ahead of the others' (its stamps are late by
    /// it): a robot whose clock was never set.
    pub clock_offset_s: f64,
}

impl Default for ObserverSetup {
    fn default() -> Self {
        ObserverSetup {
            robots: 4,
            rate_hz: 30.0,
            noise_m: 0.02,
            latency_s: 0.04,
            dropout: 0.0,
            clock_offset_s: 0.0,
        }
    }
}

#[derive(Debug, Error, Clone, PartialEq)]
pub enum SetupError {
    #[error("robots must be between 1 and 64, not {0}")]
    Robots(usize),
    #[error("rate_hz must be positive and at most 1000, not {0}")]
    Rate(f64),
    #[error("noise_m must be positive, not {0}")]
    Noise(f64),
    #[error("latency_s must be ≥ 0, not {0}")]
    Latency(f64),
    #[error("dropout must be in 0..1, not {0}")]
    Dropout(f64),
    #[error("clock_offset_s must be within ±5 s, not {0}")]
    ClockOffset(f64),
}

impl ObserverSetup {
    pub fn check(&self) -> Result<(), SetupError> {
        if !(1..=64).contains(&self.robots) {
            return Err(SetupError::Robots(self.robots));
        }
        if !(self.rate_hz > 0.0 && self.rate_hz <= 1000.0) {
            return Err(SetupError::Rate(self.rate_hz));
        }
        if !(self.noise_m.is_finite() && self.noise_m > 0.0) {
            return Err(SetupError::Noise(self.noise_m));
        }
        if !(self.latency_s.is_finite() && self.latency_s >= 0.0) {
            return Err(SetupError::Latency(self.latency_s));
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return Err(SetupError::Dropout(self.dropout));
        }
        if !(self.clock_offset_s.is_finite() && self.clock_offset_s.abs() <= 5.0) {
            return Err(SetupError::ClockOffset(self.clock_offset_s));
        }
        Ok(())
    }
}

/// How far inside the walls the robots stand.
const ROBOT_INSET_M: f64 = 0.3;
const CONFIDENCE: f64 = 0.9;

/// `n` poses evenly spread on an ellipse `ROBOT_INSET_M` inside the walls, each facing the
/// pitch centre.
pub fn robot_poses(pitch: &Pitch, n: usize) -> Vec<Pose2> {
    let a = (pitch.half_length_m() - ROBOT_INSET_M).max(0.1);
    let b = (pitch.half_width_m() - ROBOT_INSET_M).max(0.1);
    (0..n)
        .map(|k| {
            let angle = std::f64::consts::TAU * (k as f64 + 0.5) / n as f64;
            let (x, y) = (a * angle.cos(), b * angle.sin());
            Pose2 {
                x_m: x,
                y_m: y,
                theta_rad: (-y).atan2(-x),
            }
        })
        .collect()
}

impl ObserverSetup {
    /// How far robot `k`'s clock is ahead of true time.
    pub fn clock_offset_of(&self, k: usize) -> f64 {
        if k == 0 { self.clock_offset_s } else { 0.0 }
    }
}

/// The robots' name for robot `k`.
pub fn robot_id(k: usize) -> String {
    format!("robot{}", k + 1)
}

/// The true capture times (seconds after `start`) of `deliveries`, sorted: their stamps
/// less the clock offset of the robot that made them.
pub fn capture_times_s(deliveries: &[Delivery], setup: &ObserverSetup, start: Stamp) -> Vec<f64> {
    let mut out: Vec<f64> = deliveries
        .iter()
        .map(|d| {
            let k = (0..setup.robots)
                .find(|k| robot_id(*k) == d.obs.robot_id)
                .unwrap_or(usize::MAX);
            d.obs.stamp.secs_since(start) - setup.clock_offset_of(k)
        })
        .collect();
    out.sort_by(f64::total_cmp);
    out
}

/// Every robot's observations of `track`, sorted by arrival (ties: capture stamp, robot).
/// Track time `t` is captured at `start.offset_secs(t)`. The same seed gives the same
/// observations.
pub fn observe(
    track: &Track,
    pitch: &Pitch,
    setup: &ObserverSetup,
    seed: u64,
    start: Stamp,
) -> Vec<Delivery> {
    let mut out = Vec::new();
    let var = setup.noise_m * setup.noise_m;
    let frame_s = 1.0 / setup.rate_hz;
    for (k, pose) in robot_poses(pitch, setup.robots).into_iter().enumerate() {
        let mut rng = Rng::stream(seed, "track-observer", k as u64);
        let id = robot_id(k);
        let mut t_s = track.start_s() + rng.range(0.0, frame_s);
        let mut seq = 0;
        while t_s <= track.end_s() {
            let capture_s = t_s;
            t_s += frame_s;
            // Nothing to see while the ball is off the pitch (a break in the track).
            let Some(p) = track.position_at(capture_s) else {
                continue;
            };
            if rng.chance(setup.dropout) {
                continue;
            }
            let position_m = [
                p[0] + setup.noise_m * rng.normal(),
                p[1] + setup.noise_m * rng.normal(),
            ];
            let half = 0.5 * setup.latency_s;
            let delay_s = half + rng.exponential(half);
            let arrival = start.offset_secs(capture_s + delay_s);
            let stamp = start.offset_secs(capture_s + setup.clock_offset_of(k));
            seq += 1;
            out.push(Delivery {
                arrival,
                obs: Observation {
                    version: proto::VERSION,
                    robot_id: id.clone(),
                    seq,
                    camera: camera_towards(&pose, position_m),
                    stamp,
                    position_m,
                    covariance_m2: [var, 0.0, 0.0, var],
                    confidence: CONFIDENCE,
                    robot_pose: pose,
                    pixel: None,
                },
                kind: ObsKind::Ball,
            });
        }
    }
    out.sort_by(|a, b| {
        (a.arrival, a.obs.stamp, &a.obs.robot_id).cmp(&(b.arrival, b.obs.stamp, &b.obs.robot_id))
    });
    out
}

/// The camera on the side of the robot's heading the ball is on (a MiRo looks out of two).
fn camera_towards(pose: &Pose2, p: [f64; 2]) -> Camera {
    let bearing = (p[1] - pose.y_m).atan2(p[0] - pose.x_m) - pose.theta_rad;
    if bearing.sin() >= 0.0 {
        Camera::Left
    } else {
        Camera::Right
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tools::tracks::TrackSample;

    fn line_track() -> Track {
        Track {
            name: "line".into(),
            samples: (0..=100)
                .map(|k| TrackSample {
                    t_s: 2.0 + 0.02 * k as f64,
                    position_m: [-1.0 + 0.02 * k as f64, 0.3],
                })
                .collect(),
        }
    }

    #[test]
    fn robots_stand_inside_the_walls_facing_the_centre() {
        let pitch = Pitch::default();
        let poses = robot_poses(&pitch, 5);
        assert_eq!(poses.len(), 5);
        for p in &poses {
            assert!(pitch.outside_distance_m([p.x_m, p.y_m]) < -0.25, "{p:?}");
            let towards_centre = (-p.y_m).atan2(-p.x_m);
            assert!((p.theta_rad - towards_centre).abs() < 1e-12);
        }
    }

    #[test]
    fn observations_cover_the_track_at_the_rate_with_the_stated_noise() {
        let track = line_track();
        let setup = ObserverSetup {
            robots: 3,
            dropout: 0.1,
            ..ObserverSetup::default()
        };
        let start = Stamp(1_000_000_000_000);
        let d = observe(&track, &Pitch::default(), &setup, 7, start);
        assert_eq!(d, observe(&track, &Pitch::default(), &setup, 7, start));
        assert_ne!(d, observe(&track, &Pitch::default(), &setup, 8, start));
        // 2 s at 30 Hz, three robots, a tenth dropped.
        let expected = 3.0 * 60.0 * 0.9;
        assert!((d.len() as f64 - expected).abs() < 20.0, "{}", d.len());
        assert!(d.windows(2).all(|w| w[0].arrival <= w[1].arrival));
        let (mut sum2, mut n) = (0.0, 0.0);
        for x in &d {
            let t = x.obs.stamp.secs_since(start);
            assert!(
                t >= track.start_s() - 1e-9 && t <= track.end_s() + 1e-9,
                "{t}"
            );
            let late = x.arrival.secs_since(x.obs.stamp);
            assert!(late >= 0.5 * setup.latency_s - 1e-9, "{late}");
            let truth = track.position_at(t).unwrap_or([f64::NAN; 2]);
            sum2 +=
                (x.obs.position_m[0] - truth[0]).powi(2) + (x.obs.position_m[1] - truth[1]).powi(2);
            n += 2.0;
            assert_eq!(x.obs.covariance_m2, [0.0004, 0.0, 0.0, 0.0004]);
        }
        let sigma = (sum2 / n).sqrt();
        assert!((sigma - 0.02).abs() < 0.003, "{sigma}");
        let mean_late = d
            .iter()
            .map(|x| x.arrival.secs_since(x.obs.stamp))
            .sum::<f64>()
            / d.len() as f64;
        assert!((mean_late - setup.latency_s).abs() < 0.006, "{mean_late}");
        let seqs: Vec<u64> = d
            .iter()
            .filter(|x| x.obs.robot_id == "robot1")
            .map(|x| x.obs.seq)
            .collect();
        let mut sorted = seqs.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), seqs.len(), "sequence numbers are unique");
    }

    #[test]
    fn a_bad_setup_is_refused() {
        let bad = |f: fn(&mut ObserverSetup)| {
            let mut s = ObserverSetup::default();
            f(&mut s);
            s.check().is_err()
        };
        assert!(ObserverSetup::default().check().is_ok());
        assert!(bad(|s| s.robots = 0));
        assert!(bad(|s| s.rate_hz = 0.0));
        assert!(bad(|s| s.noise_m = 0.0));
        assert!(bad(|s| s.latency_s = f64::NAN));
        assert!(bad(|s| s.dropout = 1.0));
    }
}
